"""Where each panel goes in the window: the view (the device's screen scaled up by a whole
number, or the whole left part for `desktop`), and a side panel with the god view above the
HUD text. Rectangles are (x, y, width, height) in window pixels, y up (OpenGL)."""
from __future__ import annotations

from dataclasses import dataclass

PANEL = 480       # side panel width; the god view is PANEL x PANEL (360 looked tiny)
TEXT_HEIGHT = 320  # room for the HUD and the help (keys.HELP, unwrapped) under the god view


@dataclass(frozen=True)
class Layout:
    view: tuple
    god: tuple
    text: tuple
    scale: int


def window_size(render_size, scale: int) -> tuple:
    """(width, height) of a window that shows render_size at scale beside the panel."""
    width, height = render_size
    return width * scale + PANEL, max(height * scale, PANEL + TEXT_HEIGHT)


def layout(size, render_size, fill=False) -> Layout:
    """Panels of a window of size (width, height).

    render_size : (width, height) of the frames
    fill        : the frames are rendered at the view's size (desktop): scale 1, whole left part
    """
    width, height = (int(v) for v in size)
    room = (max(width - PANEL, 1), max(height, 1))
    if fill:
        scale, shown = 1, room
    else:
        scale = max(1, min(room[0] // render_size[0], room[1] // render_size[1]))
        shown = (render_size[0] * scale, render_size[1] * scale)
    view = (0, height - shown[1], shown[0], shown[1])  # top-left aligned
    panel_x = max(width - PANEL, shown[0])
    god = (panel_x, height - PANEL, PANEL, PANEL)
    text = (panel_x, 0, PANEL, max(height - PANEL, 0))
    return Layout(view, god, text, scale)


def view_size(size) -> tuple:
    """(width, height) the `desktop` frames take in a window of size."""
    return max(int(size[0]) - PANEL, 1), max(int(size[1]), 1)

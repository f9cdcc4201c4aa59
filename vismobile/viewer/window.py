"""The viewer's window (pyglet): shows Session frames, feeds it keys and mouse drags.

pyglet rather than moderngl-window: a window opens in about half the time here (measured in
tools/bench_viewer.py) and it is one pure-Python package. The renderer keeps its own headless
(EGL) context, the same one playback uses; each frame reads its image back and shows it as a
texture, scaled up with nearest filtering so what is seen is the device's pixels. A thread has
one current GL context, so the window's (GLX) context is released around each render.
"""
from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np

from ..errors import VisMobileError
from ..render.context import make_current, release_current
from . import keys
from .layout import PANEL, layout, view_size, window_size

HUD_COLOUR = (255, 255, 160, 255)
HELP_COLOUR = (200, 220, 255, 255)


def run(session, scale=2, script=None, screenshot=None, frame_rate=60.0) -> int:
    """Open a window on the session and run until Esc or the window closes; frames drawn.

    script     : keys.parse_script events; the run then steps 1/30 s per frame and ends one
                 frame after the last event
    screenshot : with a script: PNG of the last frame's window, plus a JSON beside it holding
                 the camera, the triangles sent and the view's rectangle (for tests)
    Raises VisMobileError when no window can be opened (no display).
    """
    try:
        import pyglet
    except ImportError as error:
        raise VisMobileError(f"the viewer needs pyglet ({error}); pip install pyglet") from None
    pyglet.options["shadow_window"] = False  # one GL context fewer to create at start
    fill = session.profile.name == "desktop"
    session.background_builds = script is None  # a person waits for no build; a script does
    size = window_size(session.profile.resolution, 1 if fill else int(scale))
    try:  # importing pyglet.gl already opens the display
        from pyglet import gl
        from pyglet.gl import glx
        from pyglet.window import key as pyglet_keys

        window = pyglet.window.Window(*size, caption=f"vismobile view {session.world.name}",
                                      resizable=True, vsync=False)
    except Exception as error:  # pyglet's NoSuchDisplayException and GL config errors
        raise VisMobileError(f"cannot open a window ({type(error).__name__}: {error}); "
                             "set DISPLAY, or run under xvfb-run") from None
    # Nearest filtering for every texture: device pixels stay sharp squares.
    pyglet.image.Texture.default_min_filter = gl.GL_NEAREST
    pyglet.image.Texture.default_mag_filter = gl.GL_NEAREST

    def to_renderer():
        glx.glXMakeContextCurrent(window.context.x_display, 0, 0, None)
        make_current()

    def to_window():
        release_current()
        window.switch_to()

    @window.event
    def on_key_press(symbol, modifiers):
        session.key_down(pyglet_keys.symbol_string(symbol))
        return pyglet.event.EVENT_HANDLED  # Esc quits through the session, not pyglet

    @window.event
    def on_key_release(symbol, modifiers):
        session.key_up(pyglet_keys.symbol_string(symbol))

    @window.event
    def on_mouse_drag(x, y, dx, dy, buttons, modifiers):
        session.drag(dx, dy)

    @window.event
    def on_close():
        session.running = False

    hud = pyglet.text.Label("", font_size=10, multiline=True, width=PANEL - 16,
                            color=HUD_COLOUR, anchor_y="top")
    help_label = pyglet.text.Label("\n".join(keys.HELP), font_size=8, multiline=True,
                                   width=PANEL - 16, color=HELP_COLOUR, anchor_y="top")
    events = sorted(script or [], key=lambda e: e[0])
    last = events[-1][0] + 1 if events else None
    tick, clock = 0, time.perf_counter()
    try:
        while session.running and not window.has_exit:
            window.dispatch_events()
            while events and events[0][0] == tick:
                _, kind, name = events.pop(0)
                window.dispatch_event("on_key_press" if kind == "down" else "on_key_release",
                                      getattr(pyglet_keys, name), 0)
            now = time.perf_counter()
            dt = 1.0 / 30.0 if last is not None else min(now - clock, 0.25)
            clock = now
            if fill:
                session.set_view_size(*view_size(window.get_framebuffer_size()))
            session.update(dt)
            to_renderer()
            frame = session.render()
            to_window()
            panels = layout(window.get_framebuffer_size(), session.profile.resolution, fill)
            _draw(pyglet, gl, window, panels, frame, hud, help_label if session.show_help
                  else None)
            if last is not None and tick >= last:
                if screenshot is not None:
                    _save_screenshot(pyglet, screenshot, frame, panels, window)
                break
            window.flip()
            tick += 1
            if last is None:  # leave the CPU to others between frames
                time.sleep(max(0.0, 1.0 / frame_rate - (time.perf_counter() - now)))
    finally:
        window.close()
    return tick


def _texture(pyglet, image):
    height, width = image.shape[:2]
    data = pyglet.image.ImageData(width, height, "RGB", np.ascontiguousarray(image).tobytes(),
                                  pitch=-width * 3)  # negative pitch: row 0 is the top
    return data.get_texture()


def _draw(pyglet, gl, window, panels, frame, hud, help_label) -> None:
    gl.glViewport(0, 0, *window.get_framebuffer_size())
    window.clear()
    x, y, w, h = panels.view
    _texture(pyglet, frame.image).blit(x, y, width=w, height=h)
    if frame.god is not None:
        gx, gy, gw, gh = panels.god
        _texture(pyglet, frame.god).blit(gx, gy, width=gw, height=gh)
    tx, ty, _, th = panels.text
    hud.text = "\n".join(frame.hud)
    hud.x, hud.y = tx + 8, ty + th - 6
    hud.draw()
    if help_label is not None:
        help_label.x, help_label.y = tx + 8, hud.y - hud.content_height - 8
        help_label.draw()


def _save_screenshot(pyglet, path, frame, panels, window) -> None:
    """The back buffer as PNG (row 0 = top) and a JSON of what the view shows."""
    from ..render.images import png_bytes
    from ..files.atomic import atomic_write_bytes

    buffer = pyglet.image.get_buffer_manager().get_color_buffer().get_image_data()
    pixels = np.frombuffer(buffer.get_data("RGB", buffer.width * 3), dtype=np.uint8)
    image = pixels.reshape(buffer.height, buffer.width, 3)[::-1]
    path = Path(path)
    atomic_write_bytes(path, png_bytes(image, optimize=False))
    camera = frame.camera
    x, y, w, h = panels.view
    sidecar = {
        "camera": {"position": list(camera.position), "yaw": camera.yaw, "pitch": camera.pitch,
                   "fov": camera.fov, "aspect": camera.aspect, "near": camera.near,
                   "far": camera.far},
        "triangles": [int(t) for t in frame.triangles],
        "cull_back": bool(frame.info.get("cull_back", False)),
        "view": [x, buffer.height - y - h, w, h],  # left, top, width, height in the PNG
        "scale": panels.scale, "hud": frame.hud,
    }
    atomic_write_bytes(path.with_suffix(".json"), json.dumps(sidecar).encode())

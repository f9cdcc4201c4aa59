"""The thesis's on-screen display: active algorithms, memory used, triangles sent and fps."""
from __future__ import annotations

import numpy as np


def hud_lines(stages, memory_bytes, triangles_sent, fps, structure="", heap_bytes=None,
              fps_label="") -> list:
    """Text lines of the HUD, as the thesis's runtime shows them: algorithms, memory used (of
    the heap budget when given), triangles sent, fps (with how it was obtained, e.g.
    "iPaq hx2490b model" or "measured here")."""
    algorithms = "+".join(s.upper() for s in stages) if stages else "none"
    memory = f"mem {memory_bytes / (1 << 20):.1f}"
    memory += f" of {heap_bytes / (1 << 20):.0f} MB" if heap_bytes else " MB"
    return [f"{algorithms}" + (f" / {structure}" if structure else ""), memory,
            f"tris {int(triangles_sent):,}",
            f"{fps:.1f} fps" + (f" ({fps_label})" if fps_label else "")]


def draw_hud(image, lines) -> np.ndarray:
    """(H, W, 3) uint8 copy of image with lines drawn top-left on a dark band (Pillow font)."""
    from PIL import Image, ImageDraw

    picture = Image.fromarray(np.ascontiguousarray(image))
    draw = ImageDraw.Draw(picture)
    height = 11 * len(lines) + 4
    draw.rectangle([0, 0, picture.width - 1, height - 1], fill=(0, 0, 0))
    for row, text in enumerate(lines):
        draw.text((3, 2 + 11 * row), text, fill=(255, 255, 160))
    return np.asarray(picture)

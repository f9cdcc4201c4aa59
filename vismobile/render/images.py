"""Image files: PNG frames, animated GIFs and labelled strips, written atomically (Pillow)."""
from __future__ import annotations

import io

import numpy as np

from ..world.world import atomic_write_bytes


def png_bytes(image, optimize=True) -> bytes:
    """PNG encoding of an (H, W, 3) uint8 image (deterministic: no timestamps)."""
    from PIL import Image

    buffer = io.BytesIO()
    Image.fromarray(np.ascontiguousarray(image)).save(buffer, format="PNG", optimize=optimize)
    return buffer.getvalue()


def save_gif(path, images, frame_ms=100) -> None:
    """Animated GIF of (H, W, 3) uint8 images, one adaptive palette per frame, looping."""
    from PIL import Image

    frames = [Image.fromarray(np.ascontiguousarray(img)).convert("P", palette=Image.ADAPTIVE)
              for img in images]
    if not frames:
        raise ValueError("no frames for the GIF")
    buffer = io.BytesIO()
    frames[0].save(buffer, format="GIF", save_all=True, append_images=frames[1:],
                   duration=int(frame_ms), loop=0)
    atomic_write_bytes(path, buffer.getvalue())


def labelled_strip(rows, gap=4, label_height=14) -> np.ndarray:
    """One (H, W, 3) uint8 picture of rows of labelled images.

    rows : list of (row_title, [(label, (h, w, 3) uint8 image), ...]); images share one size.
    Each row starts with its title band; each image carries its label in a band above it.
    """
    from PIL import Image, ImageDraw

    h, w = rows[0][1][0][1].shape[:2]
    columns = max(len(items) for _, items in rows)
    row_height = label_height + h + gap
    canvas = Image.new("RGB", (columns * (w + gap) + gap, len(rows) * (row_height + label_height)
                               + gap), (255, 255, 255))
    draw = ImageDraw.Draw(canvas)
    y = gap
    for title, items in rows:
        draw.text((gap, y), title, fill=(0, 0, 0))
        y += label_height
        for column, (label, image) in enumerate(items):
            x = gap + column * (w + gap)
            draw.text((x + 2, y), label, fill=(0, 0, 0))
            canvas.paste(Image.fromarray(np.ascontiguousarray(image)), (x, y + label_height))
        y += row_height
    return np.asarray(canvas)

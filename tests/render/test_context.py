"""Render targets: cached per size, the least recently used sizes freed."""
import numpy as np

from vismobile.render import context


def test_targets_are_reused_and_old_sizes_freed():
    first = context.render_target((64, 48), "rgb")
    assert context.render_target((64, 48), "rgb") is first
    ids = context.render_target((64, 48), "ids")
    for width in range(100, 100 + 3 * context.TARGETS_KEPT):   # a window being resized
        target = context.render_target((width, 50), "rgb")
        assert target.size == (width, 50)
    rgb_sizes = [size for size, kind in context._TARGETS if kind == "rgb"]
    assert len(rgb_sizes) == context.TARGETS_KEPT
    assert rgb_sizes[-1] == (99 + 3 * context.TARGETS_KEPT, 50) and (64, 48) not in rgb_sizes
    assert context.render_target((64, 48), "ids") is ids      # other kinds are kept apart


def test_a_freed_size_renders_again():
    target = context.render_target((32, 16), "rgb")
    for width in range(200, 200 + 2 * context.TARGETS_KEPT):
        context.render_target((width, 8), "rgb")
    again = context.render_target((32, 16), "rgb")
    again.use()
    context.gl_context().clear(1.0, 0.0, 0.0, 1.0)
    pixels = np.frombuffer(again.read(components=4), np.uint8).reshape(16, 32, 4)
    assert again is not target and (pixels[..., 0] == 255).all() and (pixels[..., 1] == 0).all()

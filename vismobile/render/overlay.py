"""Viewer overlays drawn over the last shaded frame (never timed, never in playback):
triangles in one flat colour (the culled set, x-ray) and wire boxes (partition nodes)."""
from __future__ import annotations

import numpy as np

from .context import gl_context, render_target
from .world_buffers import program

# The 12 edges of a box as pairs of corner numbers; corner bit k picks max on axis k.
_EDGES = np.array([(a, a | bit) for bit in (1, 2, 4) for a in range(8) if not a & bit])


def _begin(renderer, camera, prog, rgba, depth_test):
    ctx = gl_context()
    render_target(renderer.profile.resolution, "rgb").use()
    ctx.viewport = (0, 0, *renderer.profile.resolution)
    ctx.enable_only(ctx.BLEND | (ctx.DEPTH_TEST if depth_test else 0))
    ctx.blend_func = ctx.SRC_ALPHA, ctx.ONE_MINUS_SRC_ALPHA
    ctx.depth_func = "<="
    prog["u_mvp"].write(camera.view_projection().T.astype(np.float32).tobytes())
    prog["u_color"].value = tuple(float(c) for c in rgba)
    return ctx


def draw_flat(renderer, triangles, camera, rgba=(1.0, 0.1, 0.1, 0.08), xray=True) -> None:
    """Blend triangles (sorted unique ids) in one colour over the renderer's last shaded draw.

    xray: no depth test, so triangles behind what was drawn show through (culled geometry
    sits behind the visible surface when culling is conservative).
    """
    prog = program("flat", renderer.profile.vertex_format)
    ctx = _begin(renderer, camera, prog, rgba, depth_test=not xray)
    starts = renderer.buffers.upload_indices(np.asarray(triangles, dtype=np.int64))
    counts = np.diff(starts)
    arrays = renderer.buffers.vertex_arrays("flat")
    for batch in np.flatnonzero(counts):  # a handful of uint16 batches
        arrays[batch].render(vertices=3 * int(counts[batch]), first=3 * int(starts[batch]))
    ctx.finish()


def flat_mask(renderer, triangles, camera) -> np.ndarray:
    """(H, W) bool: the pixels the triangles cover, depth ignored (the culled set's footprint
    for the viewer's one-layer tint). Overwrites the renderer's last image: read it first."""
    render_target(renderer.profile.resolution, "rgb").clear(0.0, 0.0, 0.0, 0.0)
    draw_flat(renderer, triangles, camera, rgba=(1.0, 1.0, 1.0, 1.0))
    return renderer.read_rgb()[..., 0] > 0


def tint(image, mask, rgb=(255, 40, 40), amount=0.3) -> np.ndarray:
    """image (H, W, 3) uint8 with the masked pixels mixed toward rgb by amount, once: however
    many culled layers lie behind a pixel, the scene stays readable through the tint."""
    out = image.astype(np.float32)
    out[mask] = (1.0 - amount) * out[mask] + amount * np.asarray(rgb, np.float32)
    return np.rint(out).astype(np.uint8)


def box_lines(boxes) -> np.ndarray:
    """(N * 24, 3) float32 line-list vertices of the 12 edges of each (N, 2, 3) box."""
    boxes = np.asarray(boxes, dtype=np.float64).reshape(-1, 2, 3)
    bits = (np.arange(8)[:, None] >> np.arange(3)) & 1              # (8, 3) low/high per axis
    corners = boxes[:, bits, np.arange(3)]                           # (N, 8, 3)
    return corners[:, _EDGES.ravel()].reshape(-1, 3).astype(np.float32)


def draw_boxes(renderer, boxes, camera, rgba=(1.0, 0.85, 0.1, 0.8)) -> None:
    """Wire boxes (N, 2, 3) over the renderer's last shaded draw, not depth tested."""
    lines = box_lines(boxes)
    if not len(lines):
        return
    prog = program("flat", "float32")  # box corners are not world vertices: always float
    ctx = _begin(renderer, camera, prog, rgba, depth_test=False)
    vbo = ctx.buffer(lines.tobytes())
    vao = ctx.vertex_array(prog, [(vbo, "3f", "in_position")])
    vao.render(mode=ctx.LINES)
    ctx.finish()
    vao.release()
    vbo.release()

"""An independent dense check of the terrain methods' screen-space error (issue 30).

It shares nothing with the methods' bounds: the drawn triangles are scan-converted by our own
rasteriser onto a lattice `fine` times finer than the samples (every lattice point of a
triangle, edges included, gets its linear interpolation), the reference surface is evaluated
at the same points (`Heightmap.height_at`: the grid, or the 4-8 mesh for Röttger and ROAM), and
both points are projected with our own pinhole projection from the camera's basis and field
of view (not the renderer's matrices). A lattice point counts when both its points are in
front of the near plane and before the far plane, and at least one projects onto the screen;
its error is the screen distance between them in pixels. Between samples this sees what a
per-sample check cannot: errors of edges that cut across the full-resolution triangles, and
triangles that reach into the view from outside it.
"""
from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def _rasterise(heights, tris, fine, out):
    """out[a, b] = the drawn height at lattice point (a / fine, b / fine) (sample units) of the
    triangles (T, 3) of sample ids; NaN stays where none covers it."""
    n = heights.shape[0]
    for t in range(tris.shape[0]):
        r0, c0 = tris[t, 0] // n, tris[t, 0] % n
        r1, c1 = tris[t, 1] // n, tris[t, 1] % n
        r2, c2 = tris[t, 2] // n, tris[t, 2] % n
        h0, h1, h2 = heights[r0, c0], heights[r1, c1], heights[r2, c2]
        R0, C0, R1, C1, R2, C2 = r0 * fine, c0 * fine, r1 * fine, c1 * fine, r2 * fine, c2 * fine
        area = (R1 - R0) * (C2 - C0) - (C1 - C0) * (R2 - R0)
        if area == 0:
            continue
        for a in range(min(R0, R1, R2), max(R0, R1, R2) + 1):
            for b in range(min(C0, C1, C2), max(C0, C1, C2) + 1):
                w0 = (R2 - R1) * (b - C1) - (C2 - C1) * (a - R1)
                w1 = (R0 - R2) * (b - C2) - (C0 - C2) * (a - R2)
                w2 = (R1 - R0) * (b - C0) - (C1 - C0) * (a - R0)
                if area > 0:
                    if w0 < 0 or w1 < 0 or w2 < 0:
                        continue
                elif w0 > 0 or w1 > 0 or w2 > 0:
                    continue
                out[a, b] = (w0 * h0 + w1 * h1 + w2 * h2) / area


def rasterise(heightmap, triangles, fine: int = 4) -> np.ndarray:
    """((N-1) fine + 1)^2 float64 drawn heights on the fine lattice (NaN: nothing drawn)."""
    m = (heightmap.size - 1) * fine + 1
    out = np.full((m, m), np.nan)
    _rasterise(heightmap.heights.astype(np.float64),
               np.ascontiguousarray(np.asarray(triangles, np.int64).reshape(-1, 3)), fine, out)
    return out


def reference(heightmap, fine: int = 4, alternating: bool = False) -> np.ndarray:
    """The full-resolution surface on the same lattice."""
    m = (heightmap.size - 1) * fine + 1
    step = heightmap.spacing / fine
    x = np.arange(m) * step
    xx, zz = np.meshgrid(x, x)
    return heightmap.height_at(xx, zz, alternating)


def screen_points(points, camera, resolution) -> tuple:
    """(..., 2) pixel coordinates, (...,) depth along the view axis, from the camera's basis:
    x_px = W/2 (1 + (p.r) / ((p.f) tan hx)), y_px = H/2 (1 - (p.u) / ((p.f) tan hy))."""
    r, u, f = camera.basis()
    p = np.asarray(points, np.float64) - camera.eye
    depth = p @ f
    ty = np.tan(np.radians(camera.fov) / 2)
    tx = ty * camera.aspect
    safe = np.where(depth > 0, depth, 1.0)
    w, h = resolution
    px = w / 2 * (1 + (p @ r) / (safe * tx))
    py = h / 2 * (1 - (p @ u) / (safe * ty))
    return np.stack([px, py], -1), depth


def screen_errors(heightmap, drawn, truth, camera, resolution, fine: int = 4) -> np.ndarray:
    """(M,) pixel gaps at the lattice points drawn and counted (module doc)."""
    a, b = np.nonzero(np.isfinite(drawn))
    step = heightmap.spacing / fine
    x, z = b * step, a * step
    pd, dd = screen_points(np.stack([x, drawn[a, b], z], -1), camera, resolution)
    pt, dt = screen_points(np.stack([x, truth[a, b], z], -1), camera, resolution)
    w, h = resolution

    def on_screen(p):
        return (p[:, 0] >= 0) & (p[:, 0] <= w) & (p[:, 1] >= 0) & (p[:, 1] <= h)

    ok = (dd >= camera.near) & (dt >= camera.near) & (dd <= camera.far) & (dt <= camera.far)
    ok &= on_screen(pd) | on_screen(pt)
    return np.linalg.norm(pd[ok] - pt[ok], axis=1)


def worst_ratio(heightmap, triangles, camera, resolution, tau, truth, fine: int = 4) -> tuple:
    """(largest screen error / tau, lattice points counted) of one method's frame."""
    drawn = rasterise(heightmap, triangles, fine)
    errors = screen_errors(heightmap, drawn, truth, camera, resolution, fine)
    return (float(errors.max()) / tau if len(errors) else 0.0), int(len(errors))


def tile_triangles(pyramid, selection) -> np.ndarray:
    """(T, 3) int64 sample ids of a tile selection's triangles."""
    from ..terrain.tiles import selection_mesh

    rows, cols, tris = selection_mesh(pyramid, selection)
    n = pyramid.heightmap.size
    ids = rows * n + cols
    if not len(tris):
        return np.zeros((0, 3), np.int64)
    return np.concatenate([ids[k][t] for k, t in enumerate(tris)]).astype(np.int64)


def takagi(size: int = 257, relief: float = 0.25, spacing: float = 1.0):
    """A Takagi (blancmange)-like map: sum over octaves k of 2^-k tent(2^k x) in x and in z.
    Every octave adds the same one-level change at its own scale, so an error that is only
    checked one level at a time accumulates over the levels."""
    from ..terrain.heightmap import quantize

    t = np.linspace(0.0, 1.0, size)
    wave = np.zeros(size)
    k = 0
    while (1 << k) < size:
        phase = (t * (1 << k)) % 1.0
        wave += 2.0 ** -k * (1 - np.abs(2 * phase - 1))
        k += 1
    h = wave[None, :] + wave[:, None]
    h = (h - h.min()) / np.ptp(h) * relief * (size - 1) * spacing
    return quantize(h, spacing, f"takagi-{size}")

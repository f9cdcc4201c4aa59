"""Ray-triangle intersection (Moller & Trumbore 1997, "Fast, minimum storage ray-triangle
intersection"), vectorised over rays x triangles."""
from __future__ import annotations

import numpy as np
from numba import njit

# Barycentric slack: rays this far (in barycentric units) outside an edge still hit.
EDGE_TOLERANCE = 1e-9


def ray_triangle(origins, directions, corners, t_min=0.0, tolerance=EDGE_TOLERANCE,
                 cull_back=False) -> np.ndarray:
    """Ray parameter t of every ray against every triangle, inf where it misses.

    Errs toward hitting: rays up to `tolerance` (barycentric) outside an edge hit; rays with
    det == 0 (parallel to the plane, or zero-area triangles) never hit.
    origins    : (R, 3) float64 ray origins
    directions : (R, 3) float64, need not be unit; t is in units of |direction|
    corners    : (T, 3, 3) float64 triangle corners, counter-clockwise = front
    t_min      : hits with t < t_min are ignored
    cull_back  : ignore triangles seen from the back (direction . normal >= 0)
    returns (R, T) float64, t >= t_min or inf
    """
    origins = np.asarray(origins, dtype=np.float64).reshape(-1, 3)
    directions = np.asarray(directions, dtype=np.float64).reshape(-1, 3)
    corners = np.asarray(corners, dtype=np.float64).reshape(-1, 3, 3)
    v0 = corners[None, :, 0]                       # (1, T, 3)
    e1 = corners[None, :, 1] - v0
    e2 = corners[None, :, 2] - v0
    d = directions[:, None]                        # (R, 1, 3)
    pvec = np.cross(d, e2)                         # (R, T, 3)
    det = np.sum(e1 * pvec, axis=-1)                # (R, T)
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / det
        tvec = origins[:, None] - v0
        u = np.sum(tvec * pvec, axis=-1) * inv
        qvec = np.cross(tvec, e1)
        v = np.sum(d * qvec, axis=-1) * inv
        t = np.sum(e2 * qvec, axis=-1) * inv
        front = det > 0 if cull_back else det != 0
        # det == 0 makes u, v, t inf or nan (0 x inf): those pairs never hit, quietly.
        hit = (front & (u >= -tolerance) & (v >= -tolerance) & (u + v <= 1.0 + tolerance)
               & (t >= t_min) & np.isfinite(t))
    return np.where(hit, t, np.inf)


def first_hit(origins, directions, corners, t_min=0.0, tolerance=EDGE_TOLERANCE,
              cull_back=False) -> tuple:
    """Nearest triangle along each ray: ids (R,) int64 (-1 on a miss), t (R,) float64 (inf).

    Errs as ray_triangle; ties between triangles at equal t go to the lowest id.
    """
    t = ray_triangle(origins, directions, corners, t_min, tolerance, cull_back)
    if t.shape[1] == 0:
        return np.full(len(t), -1, dtype=np.int64), np.full(len(t), np.inf)
    ids = np.argmin(t, axis=1)
    best = t[np.arange(len(t)), ids]
    return np.where(np.isfinite(best), ids, -1).astype(np.int64), best


@njit(cache=True, nogil=True)
def ray_hit_t(ox, oy, oz, dx, dy, dz, corners, tolerance):
    """ray_triangle for one ray and one triangle (t_min 0, no back-face culling), compiled:
    its t or inf, with the same operations in the same order, so the same bits.

    Errs as ray_triangle: toward hitting by `tolerance` (barycentric); det == 0 never hits.
    corners : (3, 3) float64
    """
    ax, ay, az = corners[0, 0], corners[0, 1], corners[0, 2]
    e1x, e1y, e1z = corners[1, 0] - ax, corners[1, 1] - ay, corners[1, 2] - az
    e2x, e2y, e2z = corners[2, 0] - ax, corners[2, 1] - ay, corners[2, 2] - az
    px, py, pz = dy * e2z - dz * e2y, dz * e2x - dx * e2z, dx * e2y - dy * e2x
    det = e1x * px + e1y * py + e1z * pz
    if det == 0.0:
        return np.inf
    inv = 1.0 / det
    tx, ty, tz = ox - ax, oy - ay, oz - az
    u = (tx * px + ty * py + tz * pz) * inv
    qx, qy, qz = ty * e1z - tz * e1y, tz * e1x - tx * e1z, tx * e1y - ty * e1x
    v = (dx * qx + dy * qy + dz * qz) * inv
    t = (e2x * qx + e2y * qy + e2z * qz) * inv
    if u >= -tolerance and v >= -tolerance and u + v <= 1.0 + tolerance and t >= 0.0 \
            and np.isfinite(t):
        return t
    return np.inf

"""Per-triangle data of the `occlusion` stage (areas, unit normals, first corners, centroids,
bounding radii) computed from the corners of the triangles asked for, so that a memory-mapped
world (mapped.MappedWorld, float32 vertices) needs no table of the whole world: the node lists
are built at prepare from each leaf's references, a frame computes its candidates' rows.

The arithmetic repeats the World's numpy operations in numpy's order (np.cross's products,
norms summed x + y then + z, corners summed 0 + 1 then + 2 and divided by 3), so each row holds
the bits of World.areas, normals, corners[:, 0], centroids and of the stage's radius table
(tests compare them). Float32 vertices widen to float64 exactly.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from .facing import _corners


@njit(cache=True, nogil=True, inline="always")
def triangle_area(vertices, triangles, t):
    """Area of triangle t: World.areas[t] (half the norm of its cross product), same bits."""
    x0, y0, z0, x1, y1, z1, x2, y2, z2 = _corners(vertices, triangles, t)
    ax, ay, az = x1 - x0, y1 - y0, z1 - z0
    bx, by, bz = x2 - x0, y2 - y0, z2 - z0
    cx = ay * bz - az * by
    cy = az * bx - ax * bz
    cz = ax * by - ay * bx
    return 0.5 * np.sqrt(cx * cx + cy * cy + cz * cz)


@njit(cache=True, nogil=True, inline="always")
def _row(vertices, triangles, t):
    """Triangle t's unit normal (zero when degenerate), first corner, centroid, radius and area
    (World's bits: module docstring), as 11 floats."""
    x0, y0, z0, x1, y1, z1, x2, y2, z2 = _corners(vertices, triangles, t)
    ax, ay, az = x1 - x0, y1 - y0, z1 - z0
    bx, by, bz = x2 - x0, y2 - y0, z2 - z0
    cx = ay * bz - az * by
    cy = az * bx - ax * bz
    cz = ax * by - ay * bx
    length = np.sqrt(cx * cx + cy * cy + cz * cz)
    nx = ny = nz = 0.0
    if length > 0:
        nx, ny, nz = cx / length, cy / length, cz / length
    mx, my, mz = (x0 + x1 + x2) / 3.0, (y0 + y1 + y2) / 3.0, (z0 + z1 + z2) / 3.0
    r = 0.0
    for px, py, pz in ((x0, y0, z0), (x1, y1, z1), (x2, y2, z2)):
        dx, dy, dz = px - mx, py - my, pz - mz
        r = max(r, np.sqrt(dx * dx + dy * dy + dz * dz))
    return nx, ny, nz, x0, y0, z0, mx, my, mz, r, 0.5 * length


@njit(cache=True, nogil=True, inline="always")
def solid_angle(nx, ny, nz, vx, vy, vz, cx, cy, cz, radius, area, planes, eye, grazing):
    """Estimated solid angle A |n.d| / |d|^3 of a triangle (unit normal n, first corner v,
    centroid c, bounding radius about it, area A; d eye to centroid): 0 when it faces away, is
    seen more edge-on than `grazing` or its bounding sphere is outside a frustum plane. Only
    ranks occluder candidates: the facing test that matters comes after."""
    dx, dy, dz = cx - eye[0], cy - eye[1], cz - eye[2]
    dist2 = dx * dx + dy * dy + dz * dz
    towards = nx * (eye[0] - vx) + ny * (eye[1] - vy) + nz * (eye[2] - vz)
    if not towards > grazing * np.sqrt(dist2):
        return 0.0
    for p in range(len(planes)):
        if planes[p, 0] * cx + planes[p, 1] * cy + planes[p, 2] * cz + planes[p, 3] < -radius:
            return 0.0
    return area * towards / max(dist2 ** 1.5, 1e-300)


@njit(cache=True, nogil=True)
def score_corners(ids, vertices, triangles, planes, eye, grazing):
    """(n,) float64 hiz.score_candidates of triangle ids with each row computed from its
    corners on the way (same bits as the rows of triangle_rows), in one pass."""
    out = np.zeros(len(ids))
    for k in range(len(ids)):
        nx, ny, nz, x0, y0, z0, mx, my, mz, r, area = _row(vertices, triangles, ids[k])
        out[k] = solid_angle(nx, ny, nz, x0, y0, z0, mx, my, mz, r, area, planes, eye, grazing)
    return out


@njit(cache=True, nogil=True)
def triangle_rows(ids, vertices, triangles):
    """Per triangle id: (normals (n, 3) unit, zero when degenerate; v0 (n, 3) first corners;
    centroids (n, 3); radius (n,) largest corner distance from the centroid; areas (n,)), all
    float64, the bits of World.normals, corners[:, 0], centroids, areas (exact copies)."""
    n = len(ids)
    normals, v0, centroids = np.empty((n, 3)), np.empty((n, 3)), np.empty((n, 3))
    radius, areas = np.empty(n), np.empty(n)
    for k in range(n):
        (normals[k, 0], normals[k, 1], normals[k, 2], v0[k, 0], v0[k, 1], v0[k, 2],
         centroids[k, 0], centroids[k, 1], centroids[k, 2], radius[k], areas[k]) = \
            _row(vertices, triangles, ids[k])
    return normals, v0, centroids, radius, areas

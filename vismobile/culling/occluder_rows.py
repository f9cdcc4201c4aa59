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


@njit(cache=True, nogil=True)
def triangle_rows(ids, vertices, triangles):
    """Per triangle id: (normals (n, 3) unit, zero when degenerate; v0 (n, 3) first corners;
    centroids (n, 3); radius (n,) largest corner distance from the centroid; areas (n,)), all
    float64, the bits of World.normals, corners[:, 0], centroids, areas (exact copies)."""
    n = len(ids)
    normals, v0, centroids = np.empty((n, 3)), np.empty((n, 3)), np.empty((n, 3))
    radius, areas = np.empty(n), np.empty(n)
    for k in range(n):
        x0, y0, z0, x1, y1, z1, x2, y2, z2 = _corners(vertices, triangles, ids[k])
        ax, ay, az = x1 - x0, y1 - y0, z1 - z0
        bx, by, bz = x2 - x0, y2 - y0, z2 - z0
        cx = ay * bz - az * by
        cy = az * bx - ax * bz
        cz = ax * by - ay * bx
        length = np.sqrt(cx * cx + cy * cy + cz * cz)
        if length > 0:
            normals[k, 0], normals[k, 1], normals[k, 2] = cx / length, cy / length, cz / length
        else:
            normals[k, 0] = normals[k, 1] = normals[k, 2] = 0.0
        areas[k] = 0.5 * length
        v0[k, 0], v0[k, 1], v0[k, 2] = x0, y0, z0
        mx, my, mz = (x0 + x1 + x2) / 3.0, (y0 + y1 + y2) / 3.0, (z0 + z1 + z2) / 3.0
        centroids[k, 0], centroids[k, 1], centroids[k, 2] = mx, my, mz
        r = 0.0
        for px, py, pz in ((x0, y0, z0), (x1, y1, z1), (x2, y2, z2)):
            dx, dy, dz = px - mx, py - my, pz - mz
            r = max(r, np.sqrt(dx * dx + dy * dy + dz * dz))
        radius[k] = r
    return normals, v0, centroids, radius, areas

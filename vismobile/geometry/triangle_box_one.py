"""Triangle-box overlap for one (triangle, box) pair, compiled (numba): the separating axis test of
triangle_box.py (Akenine-Moller, JGT 2001) written out per pair, with the same operations in the
same order, so its answer is bit for bit the vectorised one's (the octree build relies on it:
tests/geometry/test_triangle_box.py compares both on random and grazing pairs)."""
from __future__ import annotations

import numpy as np
from numba import njit

from .triangle_box import EPS


@njit(cache=True, nogil=True, inline="always")
def _separates(p0, p1, p2, r, a0, a1, a2, o0, o1, o2, eps):
    """True when the axis with |components| (a0, a1, a2) separates corners projected to
    p0..p2 from a box of projected radius r whose centre has |components| o0..o2."""
    big = max(max(abs(p0), abs(p1)), abs(p2))
    slack = eps * (r + big + ((a0 * o0 + a1 * o1) + a2 * o2))
    low = min(min(p0, p1), p2)
    high = max(max(p0, p1), p2)
    return low > r + slack or high < -r - slack


@njit(cache=True, nogil=True)
def triangle_overlaps_box(x0, y0, z0, x1, y1, z1, x2, y2, z2, lo, hi, eps=EPS):
    """triangles_overlap_boxes for one pair: errs toward overlap by the same relative slack.

    x0..z2 : float64 corners; lo, hi : (3,) float64 box corners
    returns: True where the triangle meets the closed box (touching counts)
    """
    c0 = (lo[0] + hi[0]) * 0.5
    c1 = (lo[1] + hi[1]) * 0.5
    c2 = (lo[2] + hi[2]) * 0.5
    h0 = (hi[0] - lo[0]) * 0.5
    h1 = (hi[1] - lo[1]) * 0.5
    h2 = (hi[2] - lo[2]) * 0.5
    o0, o1, o2 = abs(c0), abs(c1), abs(c2)
    # Corners about the box centre: (ua, va, wa) is corner a.
    u0, v0, w0 = x0 - c0, y0 - c1, z0 - c2
    u1, v1, w1 = x1 - c0, y1 - c1, z1 - c2
    u2, v2, w2 = x2 - c0, y2 - c1, z2 - c2
    # The box's own normals: the AABB test.
    if _separates(u0, u1, u2, h0, 1.0, 0.0, 0.0, o0, o1, o2, eps):
        return False
    if _separates(v0, v1, v2, h1, 0.0, 1.0, 0.0, o0, o1, o2, eps):
        return False
    if _separates(w0, w1, w2, h2, 0.0, 0.0, 1.0, o0, o1, o2, eps):
        return False
    # Edges e0 = c1 - c0, e1 = c2 - c1, e2 = c0 - c2 (corners about the centre).
    e0x, e0y, e0z = u1 - u0, v1 - v0, w1 - w0
    e1x, e1y, e1z = u2 - u1, v2 - v1, w2 - w1
    e2x, e2y, e2z = u0 - u2, v0 - v2, w0 - w2
    # The triangle's plane: normal = e0 x (-e2), np.cross's products.
    bx, by, bz = -e2x, -e2y, -e2z
    nx = e0y * bz - e0z * by
    ny = e0z * bx - e0x * bz
    nz = e0x * by - e0y * bx
    ax, ay, az = abs(nx), abs(ny), abs(nz)
    if _separates((u0 * nx + v0 * ny) + w0 * nz, (u1 * nx + v1 * ny) + w1 * nz,
                  (u2 * nx + v2 * ny) + w2 * nz, (h0 * ax + h1 * ay) + h2 * az,
                  ax, ay, az, o0, o1, o2, eps):
        return False
    for k in range(3):
        if k == 0:
            ex, ey, ez = e0x, e0y, e0z
        elif k == 1:
            ex, ey, ez = e1x, e1y, e1z
        else:
            ex, ey, ez = e2x, e2y, e2z
        ax, ay, az = abs(ex), abs(ey), abs(ez)
        # e x (1,0,0) = (0, ez, -ey)
        if _separates(v0 * ez - w0 * ey, v1 * ez - w1 * ey, v2 * ez - w2 * ey,
                      h1 * az + h2 * ay, 0.0, az, ay, o0, o1, o2, eps):
            return False
        # e x (0,1,0) = (-ez, 0, ex)
        if _separates(w0 * ex - u0 * ez, w1 * ex - u1 * ez, w2 * ex - u2 * ez,
                      h0 * az + h2 * ax, az, 0.0, ax, o0, o1, o2, eps):
            return False
        # e x (0,0,1) = (ey, -ex, 0)
        if _separates(u0 * ey - v0 * ex, u1 * ey - v1 * ex, u2 * ey - v2 * ex,
                      h0 * ay + h1 * ax, ay, ax, 0.0, o0, o1, o2, eps):
            return False
    return True

"""Compiled per-triangle kernels of the back-face stages (numba, cached on disk) that read each
candidate's corners straight from the world's vertices and triangles, so no table of the whole
world is needed: a memory-mapped world (mapped.MappedWorld, float32 vertices) and an in-memory
World (float64) take the same path, and a frame costs what it gathers.

The arithmetic repeats numpy's, operation for operation (np.cross's products, norms summed
x + y then + z, left-to-right products), so each kernel gives the bits its numpy reference
gives (triangle_backface.triangle_cross, geometry.tilt.tilt_coefficients; tests compare them).
Float32 vertices widen to float64 exactly.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

# geometry/tilt.py's slack on the coefficients' own evaluation.
from ..geometry.tilt import _SLACK as TILT_SLACK
from .kernels import backface_threshold


@njit(cache=True, nogil=True, inline="always")
def _corners(vertices, triangles, t):
    """The nine float64 coordinates of triangle t's corners."""
    i0, i1, i2 = triangles[t, 0], triangles[t, 1], triangles[t, 2]
    return (np.float64(vertices[i0, 0]), np.float64(vertices[i0, 1]), np.float64(vertices[i0, 2]),
            np.float64(vertices[i1, 0]), np.float64(vertices[i1, 1]), np.float64(vertices[i1, 2]),
            np.float64(vertices[i2, 0]), np.float64(vertices[i2, 1]), np.float64(vertices[i2, 2]))


@njit(cache=True, nogil=True, inline="always")
def _edges_cross(x0, y0, z0, x1, y1, z1, x2, y2, z2):
    """Edges a = v1 - v0, b = v2 - v0 and their cross product a x b (9 floats), as
    triangle_backface.triangle_cross computes them (same bits)."""
    ax, ay, az = x1 - x0, y1 - y0, z1 - z0
    bx, by, bz = x2 - x0, y2 - y0, z2 - z0
    return (ax, ay, az, bx, by, bz,
            ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx)


@njit(cache=True, nogil=True, inline="always")
def _det_bound(vertices, triangles, t, eye, delta, gamma8):
    """(det, bound) of triangle t: det = ((v1 - v0) x (v2 - v0)) . (e - v0) and how far det may
    move for corners and eye moved by up to delta per coordinate plus its float64 rounding."""
    x0, y0, z0, x1, y1, z1, x2, y2, z2 = _corners(vertices, triangles, t)
    ax, ay, az, bx, by, bz, cx, cy, cz = _edges_cross(x0, y0, z0, x1, y1, z1, x2, y2, z2)
    wx, wy, wz = eye[0] - x0, eye[1] - y0, eye[2] - z0
    det = cx * wx + cy * wy + cz * wz
    # The bound for every candidate, without a branch on the sign of det: about half the
    # candidates face away, and the unpredictable branch cost more than the bound (20 M
    # world, one frame's 1.88 M candidates: 38 -> 34 ms).
    ea = np.sqrt(ax * ax + ay * ay + az * az)
    eb = np.sqrt(bx * bx + by * by + bz * bz)
    lw = np.sqrt(wx * wx + wy * wy + wz * wz)
    abs_x = abs(ay) * abs(bz) + abs(az) * abs(by)
    abs_y = abs(az) * abs(bx) + abs(ax) * abs(bz)
    abs_z = abs(ax) * abs(by) + abs(ay) * abs(bx)
    rounding = gamma8 * (abs_x * abs(wx) + abs_y * abs(wy) + abs_z * abs(wz))
    return det, backface_threshold(delta, lw, ea, eb, rounding)


@njit(cache=True, nogil=True)
def backfacing(ids, vertices, triangles, eye, delta, gamma8):
    """(n,) bool: triangle ids certainly face away from the eye, also after any move of corners
    and eye by up to delta per coordinate, and despite float64 rounding (triangle_backface's
    bound, evaluated per triangle). Errs toward False by that bound; edge-on is never True.

    ids : (n,) int64;  vertices : (V, 3) float32 or float64;  triangles : (T, 3) int32
    eye : (3,) float64;  delta >= 0;  gamma8 : float64 rounding factor (GAMMA_8)
    """
    out = np.zeros(len(ids), dtype=np.bool_)
    for k in range(len(ids)):
        det, bound = _det_bound(vertices, triangles, ids[k], eye, delta, gamma8)
        out[k] = (det < 0) & (det < -bound)
    return out


@njit(cache=True, nogil=True)
def not_backfacing(ids, vertices, triangles, eye, delta, gamma8, out):
    """tbfc's kept candidates: writes to out (>= n,) int64, in order, the ids that backfacing
    does not flag (same bound, same bits) and returns their count. Errs toward keeping."""
    count = 0
    for k in range(len(ids)):
        t = ids[k]
        det, bound = _det_bound(vertices, triangles, t, eye, delta, gamma8)
        out[count] = t  # written always, counted when kept: no branch on the data
        count += not ((det < 0) & (det < -bound))
    return count


@njit(cache=True, nogil=True)
def frontfacing(ids, vertices, triangles, eye, delta, gamma8):
    """(n,) bool: triangle ids certainly face the eye, also after any move of corners and eye by
    up to delta per coordinate, and despite float64 rounding: backfacing of the triangle with its
    winding reversed (-det, the same bound). Errs toward False by that bound; edge-on is never
    True. Arguments as for backfacing."""
    out = np.zeros(len(ids), dtype=np.bool_)
    for k in range(len(ids)):
        det, bound = _det_bound(vertices, triangles, ids[k], eye, delta, gamma8)
        flipped = -det  # exact: the reversed triangle's cross product is -c
        out[k] = (flipped < 0) & (flipped < -bound)
    return out


@njit(cache=True, nogil=True)
def tilt_of(vertices, triangles, t):
    """(k1, k2) of triangle t: geometry.tilt.tilt_coefficients for one triangle, same bits
    (inf for zero-area triangles). Errs large by 2^-40 relative."""
    x0, y0, z0, x1, y1, z1, x2, y2, z2 = _corners(vertices, triangles, t)
    e0x, e0y, e0z = x1 - x0, y1 - y0, z1 - z0  # edges: corner i+1 - corner i
    e1x, e1y, e1z = x2 - x1, y2 - y1, z2 - z1
    e2x, e2y, e2z = x0 - x2, y0 - y2, z0 - z2
    l0 = np.sqrt(e0x * e0x + e0y * e0y + e0z * e0z)
    l1 = np.sqrt(e1x * e1x + e1y * e1y + e1z * e1z)
    l2 = np.sqrt(e2x * e2x + e2y * e2y + e2z * e2z)
    # The two shortest edges (their sum does not depend on their order).
    if l0 >= l1 and l0 >= l2:
        short = l1 + l2
    elif l1 >= l2:
        short = l0 + l2
    else:
        short = l0 + l1
    cx, cy, cz = _edges_cross(x0, y0, z0, x1, y1, z1, x2, y2, z2)[6:]  # e0 x -e2
    cross = np.sqrt(cx * cx + cy * cy + cz * cz)
    inv = 1.0 / cross if cross > 0 else np.inf
    return 2.0 * short * inv * TILT_SLACK, 4.0 * inv * TILT_SLACK


# A triangle's tilt scale byte e (tilt_scales): 2^(e - TILT_BIAS) bounds its k1 and the square
# root of its k2; TILT_EXACT (zero-area triangles, scales out of range) means "compute the tilt".
TILT_BIAS = 127
TILT_EXACT = 255


@njit(cache=True, nogil=True)
def tilt_scales(vertices, triangles, start, out):
    """Fills out[k] for triangle start + k with the smallest byte e < TILT_EXACT such that
    K = 2^(e - TILT_BIAS) >= k1 and K^2 >= k2 of tilt_of (so k1 m + k2 m^2 <= K m + K^2 m^2 for
    every move m, also as float64 rounds them), or TILT_EXACT when k1 or k2 is not finite or
    K would need e > 254. Errs large (a larger K only means computing the tilt more often)."""
    for k in range(len(out)):
        k1, k2 = tilt_of(vertices, triangles, start + k)
        if not (k1 < np.inf and k2 < np.inf):
            out[k] = TILT_EXACT
            continue
        e1 = math.frexp(k1)[1]  # k1 < 2^e1
        e2 = (math.frexp(k2)[1] + 1) // 2  # k2 < 2^(2 e2)
        e = max(e1, e2, -TILT_BIAS) + TILT_BIAS
        out[k] = e if e < TILT_EXACT else TILT_EXACT


@njit(cache=True, nogil=True)
def region_spare(centers, need, radii, rays, spare):
    """cbfc's per-frame table: spare[r] = sin(asin(min_i m_r.c_i) - rho_r) - 1e-12 for each
    region r whose cap (centre m_r, radius rho_r) faces away from every unit corner ray c_i
    (m_r.c_i >= need[r] = sin(rho_r) + 1e-12 for all four), -1 for the others and for the last
    entry (degenerate normals); returns how many regions passed. The droppable and spare of
    ConservativeBackface in one pass (dot products summed left to right, not by the BLAS: the
    bits may differ by an ulp, far inside the 1e-12 they err by).
    centers : (R, 3) unit;  need, radii : (R,);  rays : (4, 3) unit;  spare : (R + 1,) out"""
    dropped = 0
    for r in range(len(centers)):
        low = np.inf
        facing_away = True
        for i in range(len(rays)):
            c = centers[r, 0] * rays[i, 0] + centers[r, 1] * rays[i, 1] \
                + centers[r, 2] * rays[i, 2]
            facing_away = facing_away and c >= need[r]
            low = min(low, c)
        spare[r] = -1.0
        if facing_away:
            dropped += 1
            room = min(max(np.arcsin(min(max(low, -1.0), 1.0)) - radii[r], 0.0), np.pi / 2)
            spare[r] = np.sin(room) - 1e-12
    spare[len(centers)] = -1.0
    return dropped


@njit(cache=True, nogil=True)
def tilt_select(ids, regions, scales, spare, vertices, triangles, move, out):
    """cbfc's per-candidate test: writes to out (>= n,) int64, in order, the ids it keeps and
    returns their count. A candidate is dropped when spare[region] >= its tilt sine for
    corners moved by `move`; the tilt is computed only where the region is droppable (spare
    >= 0) and the triangle's scale bound K m + K^2 m^2 (tilt_scales) does not already fit in
    the spare. Errs toward keeping exactly as geometry.tilt.tilt_sine: the bound is never below
    the tilt, so the answer is the tilt's.

    ids : (n,) int64;  regions : (T,) small ints (direction region per triangle)
    scales : (T,) uint8 (tilt_scales);  spare : (R + 1,) float64 (ConservativeBackface.spare)
    move >= 0 (Euclidean)
    """
    bound = np.empty(TILT_EXACT)  # K m + K^2 m^2 per scale byte: powers of two scale exactly
    square = move * move
    scale = math.ldexp(1.0, -TILT_BIAS)
    for e in range(TILT_EXACT):
        bound[e] = scale * move + (scale * scale) * square
        scale *= 2.0
    count = 0
    for k in range(len(ids)):
        t = ids[k]
        room = spare[regions[t]]
        if room >= 0.0:
            e = scales[t]
            if e != TILT_EXACT and room >= bound[e]:
                continue
            k1, k2 = tilt_of(vertices, triangles, t)
            tilt = k1 * move + k2 * square
            if np.isnan(tilt):  # inf * 0 for zero-area triangles, move 0
                tilt = np.inf
            if room >= tilt:
                continue
        out[count] = t
        count += 1
    return count


@njit(cache=True, nogil=True)
def keep_unmarked(ids, refs, starts, ends, clusters, bits):
    """(n,) bool keep: ids (sorted or not) that no culled cluster holds, where cluster c holds
    refs[starts[c]:ends[c]]. Exact. bits : (T // 64 + 1,) uint64 scratch, all zero on entry
    and on return, so the cost follows the culled clusters' references and the ids."""
    for c in clusters:
        for r in range(starts[c], ends[c]):
            t = refs[r]
            bits[t >> 6] |= np.uint64(1) << np.uint64(t & 63)
    out = np.empty(len(ids), dtype=np.bool_)
    for k in range(len(ids)):
        t = ids[k]
        out[k] = ((bits[t >> 6] >> np.uint64(t & 63)) & np.uint64(1)) == 0
    for c in clusters:
        for r in range(starts[c], ends[c]):
            bits[refs[r] >> 6] = 0
    return out

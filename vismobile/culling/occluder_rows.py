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

from .facing import _corners, _edges_cross


@njit(cache=True, nogil=True, inline="always")
def _row(vertices, triangles, t):
    """Triangle t's unit normal (zero when degenerate), first corner, centroid, radius and area
    (World's bits: module docstring), as 11 floats."""
    x0, y0, z0, x1, y1, z1, x2, y2, z2 = _corners(vertices, triangles, t)
    cx, cy, cz = _edges_cross(x0, y0, z0, x1, y1, z1, x2, y2, z2)[6:]
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


@njit(cache=True, nogil=True, inline="always")
def _before(keys, i, j):
    """Row i of keys is lexicographically before row j (by value: -0.0 == 0.0)."""
    for c in range(keys.shape[1]):
        if keys[i, c] < keys[j, c]:
            return True
        if keys[i, c] > keys[j, c]:
            return False
    return False


@njit(cache=True, nogil=True)
def _lex_order(keys):
    """(n,) int64 stable order of the rows of keys (n, m) float64 by column 0, then 1, ...:
    np.lexsort(keys.T[::-1]) (a bottom-up merge sort comparing whole rows)."""
    n = keys.shape[0]
    order = np.arange(n)
    spare = np.empty(n, dtype=np.int64)
    width = 1
    while width < n:
        for lo in range(0, n, 2 * width):
            mid, hi = min(lo + width, n), min(lo + 2 * width, n)
            i, j, k = lo, mid, lo
            while i < mid and j < hi:
                if _before(keys, order[j], order[i]):  # strictly before: ties keep i first
                    spare[k] = order[j]
                    j += 1
                else:
                    spare[k] = order[i]
                    i += 1
                k += 1
            while i < mid:
                spare[k] = order[i]
                i += 1
                k += 1
            while j < hi:
                spare[k] = order[j]
                j += 1
                k += 1
        order, spare = spare, order
        width *= 2
    return order


@njit(cache=True, nogil=True)
def _runs(keys, order):
    """(n,) int64 per row of keys (in any order) the rank of its distinct value: runs of equal
    rows along `order` (a lexicographic order) numbered from 0."""
    n, m = keys.shape
    label = np.empty(n, dtype=np.int64)
    run = -1
    for i in range(n):
        r = order[i]
        new = i == 0
        if not new:
            p = order[i - 1]
            for c in range(m):
                if keys[r, c] != keys[p, c]:
                    new = True
                    break
        if new:
            run += 1
        label[r] = run
    return label


@njit(cache=True, nogil=True)
def _partners(tri, a, b, groups, points):
    """occluder_mesh.piece_partners: per piece a -> b of triangle tri, the triangle of the first
    piece (lowest index) of the same group holding b -> a, or -1. Pieces are grouped by one
    int64 key (group, low, high point) sorted; within a key, lowest index first as lexsort's
    stable order has it. points : the number of distinct points (key radix)."""
    s = len(tri)
    key = np.empty(s, dtype=np.int64)
    for i in range(s):
        key[i] = (groups[tri[i]] * points + min(a[i], b[i])) * points + max(a[i], b[i])
    order = np.argsort(key)
    first_fwd = np.full(s, -1, dtype=np.int64)  # per run head (a position in order)
    first_bwd = np.full(s, -1, dtype=np.int64)
    head = np.empty(s, dtype=np.int64)
    h = 0
    for i in range(s):
        p = order[i]
        if i == 0 or key[p] != key[order[i - 1]]:
            h = i
        head[p] = h
        if a[p] < b[p]:
            if first_fwd[h] < 0 or p < first_fwd[h]:
                first_fwd[h] = p
        elif first_bwd[h] < 0 or p < first_bwd[h]:
            first_bwd[h] = p
    out = np.full(s, -1, dtype=np.int64)
    for p in range(s):
        q = first_bwd[head[p]] if a[p] < b[p] else first_fwd[head[p]]
        if q >= 0:
            out[p] = tri[q]
    return out


@njit(cache=True, nogil=True)
def occluder_mesh_of(ids, vertices, triangles):
    """occluder_mesh.occluder_mesh of the triangles ids (K,) alone, local ids 0..K-1, in one
    compiled pass: (points, tri_points, normals, offsets, groups, piece_start, piece_end, piece_a,
    piece_b, partner, partner_any), the same arrays (bits included) as occluder_mesh of their
    corners with unit_normals (tests). Exact: points and planes match by value."""
    k = len(ids)
    rows = np.empty((3 * k, 3))
    normals = np.empty((k, 3))
    for j in range(k):
        x0, y0, z0, x1, y1, z1, x2, y2, z2 = _corners(vertices, triangles, ids[j])
        rows[3 * j, 0], rows[3 * j, 1], rows[3 * j, 2] = x0, y0, z0
        rows[3 * j + 1, 0], rows[3 * j + 1, 1], rows[3 * j + 1, 2] = x1, y1, z1
        rows[3 * j + 2, 0], rows[3 * j + 2, 1], rows[3 * j + 2, 2] = x2, y2, z2
        nx, ny, nz, _, _, _, _, _, _, _, _ = _row(vertices, triangles, ids[j])
        normals[j, 0], normals[j, 1], normals[j, 2] = nx, ny, nz
    order = _lex_order(rows)
    index = _runs(rows, order)
    count = index.max() + 1 if k else 0
    points = np.empty((count, 3))
    last = -1
    for i in range(3 * k):  # the first row of each run, as unique_rows keeps it
        r = order[i]
        if index[r] != last:
            last = index[r]
            points[last, 0], points[last, 1], points[last, 2] = rows[r, 0], rows[r, 1], rows[r, 2]
    tri_points = index.reshape(k, 3).copy()
    planes = np.empty((k, 4))
    offsets = np.empty(k)
    for j in range(k):
        p = tri_points[j, 0]
        # np.einsum("ij,ij->i")'s order for rows of 3: (x + z) + y (tests compare the bits)
        offsets[j] = (normals[j, 0] * points[p, 0] + normals[j, 2] * points[p, 2]
                      + normals[j, 1] * points[p, 1])
        planes[j, 0], planes[j, 1], planes[j, 2] = normals[j, 0], normals[j, 1], normals[j, 2]
        planes[j, 3] = offsets[j]
    groups = _runs(planes, _lex_order(planes))
    tri = np.empty(3 * k, dtype=np.int64)
    a = np.empty(3 * k, dtype=np.int64)
    b = np.empty(3 * k, dtype=np.int64)
    for j in range(k):
        for c in range(3):
            tri[3 * j + c] = j
            a[3 * j + c] = tri_points[j, c]
            b[3 * j + c] = tri_points[j, (c + 1) % 3]
    start = 3 * np.arange(k)
    return (points, tri_points, normals, offsets, groups, start, start + 3, a, b,
            _partners(tri, a, b, groups, count),
            _partners(tri, a, b, np.zeros(k, dtype=np.int64), count))

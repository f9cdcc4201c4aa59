"""Nearest triangle of a set, for many query points, through a uniform grid (numba): offline.

Used to tie the original triangles of an object to the triangles of its levels (lod/
simplify.py), so culling's per-triangle verdicts carry over to a level, and to measure a
level's distance from the original surface. A grid of about one triangle per cell keeps the
search near linear where brute force would be quadratic in the object's size.
"""
from __future__ import annotations

import numba
import numpy as np


def _cell_of(xyz, low, size, dims):
    cell = np.floor((xyz - low) / size).astype(np.int64)
    return np.clip(cell, 0, dims - 1)


@numba.njit(cache=True)
def _beyond(p, c, ring, low, size, dims):
    """A lower bound on the distance from p to every cell farther than `ring` (Chebyshev)
    from cell c, inf when there is none: along each axis, the nearest side of the shell's box
    beyond which cells remain (a query outside the grid is clamped to its edge cell)."""
    gap = np.inf
    for a in range(3):
        if c[a] - ring - 1 >= 0:
            gap = min(gap, p[a] - (low[a] + (c[a] - ring) * size))
        if c[a] + ring + 1 <= dims[a] - 1:
            gap = min(gap, (low[a] + (c[a] + ring + 1) * size) - p[a])
    return max(gap, 0.0)


def nearest_triangle(corners, queries) -> tuple:
    """((Q,) int64 index of the triangle of corners (M, 3, 3) float64 nearest to each query
    point (Q, 3), (Q,) float64 its distance): exact point-to-triangle distance, ties to the
    lower index.

    Triangles are listed in every grid cell their box meets; the search grows in shells of
    cells around the query until the shell is farther than the best distance found.
    """
    corners = np.ascontiguousarray(corners, dtype=np.float64).reshape(-1, 3, 3)
    queries = np.ascontiguousarray(queries, dtype=np.float64).reshape(-1, 3)
    if not len(corners):
        raise ValueError("nearest_triangle needs at least one triangle")
    low_t, high_t = corners.min(axis=1), corners.max(axis=1)
    low = low_t.min(axis=0)
    span = np.maximum(high_t.max(axis=0) - low, 1e-300)
    # Cells about a typical triangle's size, but no more than 8 per triangle in all.
    volume = float(np.prod(np.maximum(span, span.max() * 1e-3)))
    size = max(float(np.median((high_t - low_t).max(axis=1))),
               (volume / (8.0 * len(corners))) ** (1.0 / 3.0), float(span.max()) * 1e-4)
    dims = np.maximum(np.ceil(span / size).astype(np.int64), 1)
    a = _cell_of(low_t, low, size, dims)
    b = _cell_of(high_t, low, size, dims)
    counts = np.prod(b - a + 1, axis=1)
    tri = np.repeat(np.arange(len(corners)), counts)
    offset = np.arange(int(counts.sum())) - np.repeat(np.cumsum(counts) - counts, counts)
    extent = (b - a + 1)[tri]
    i = a[tri, 0] + offset // (extent[:, 1] * extent[:, 2])
    j = a[tri, 1] + (offset // extent[:, 2]) % extent[:, 1]
    k = a[tri, 2] + offset % extent[:, 2]
    flat = (i * dims[1] + j) * dims[2] + k
    order = np.argsort(flat, kind="stable")
    starts = np.searchsorted(flat[order], np.arange(int(np.prod(dims)) + 1))
    return _search_triangles(corners, tri[order], starts, low, size, dims, queries)


@numba.njit(cache=True)
def _dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@numba.njit(cache=True)
def _point_triangle_sq(p, t):
    """Squared distance from point p (3,) to triangle t (3, 3) (Ericson, closest point)."""
    ab = t[1] - t[0]
    ac = t[2] - t[0]
    ap = p - t[0]
    d1 = _dot(ab, ap)
    d2 = _dot(ac, ap)
    if d1 <= 0 and d2 <= 0:
        q = t[0]
    else:
        bp = p - t[1]
        d3 = _dot(ab, bp)
        d4 = _dot(ac, bp)
        if d3 >= 0 and d4 <= d3:
            q = t[1]
        else:
            vc = d1 * d4 - d3 * d2
            if vc <= 0 and d1 >= 0 and d3 <= 0:
                q = t[0] + d1 / (d1 - d3) * ab
            else:
                cp = p - t[2]
                d5 = _dot(ab, cp)
                d6 = _dot(ac, cp)
                if d6 >= 0 and d5 <= d6:
                    q = t[2]
                else:
                    vb = d5 * d2 - d1 * d6
                    if vb <= 0 and d2 >= 0 and d6 <= 0:
                        q = t[0] + d2 / (d2 - d6) * ac
                    else:
                        va = d3 * d6 - d5 * d4
                        if va <= 0 and (d4 - d3) >= 0 and (d5 - d6) >= 0:
                            q = t[1] + (d4 - d3) / ((d4 - d3) + (d5 - d6)) * (t[2] - t[1])
                        else:
                            denom = va + vb + vc
                            if denom == 0:  # degenerate triangle: its first corner
                                q = t[0]
                            else:
                                q = t[0] + (vb / denom) * ab + (vc / denom) * ac
    e = p - q
    return _dot(e, e)


@numba.njit(cache=True)
def _search_triangles(corners, tris, starts, low, size, dims, queries):
    out = np.empty(len(queries), np.int64)
    dist = np.empty(len(queries), np.float64)
    seen = np.full(len(corners), -1, np.int64)  # a triangle in several cells is tested once
    for q in range(len(queries)):
        p = queries[q]
        c = np.empty(3, np.int64)
        for a in range(3):
            v = int(np.floor((p[a] - low[a]) / size))
            c[a] = min(max(v, 0), dims[a] - 1)
        best, best_d = -1, np.inf
        ring = 0
        while True:
            for i in range(max(c[0] - ring, 0), min(c[0] + ring + 1, dims[0])):
                for j in range(max(c[1] - ring, 0), min(c[1] + ring + 1, dims[1])):
                    for k in range(max(c[2] - ring, 0), min(c[2] + ring + 1, dims[2])):
                        if max(abs(i - c[0]), max(abs(j - c[1]), abs(k - c[2]))) != ring:
                            continue
                        f = (i * dims[1] + j) * dims[2] + k
                        for s in range(starts[f], starts[f + 1]):
                            t = tris[s]
                            if seen[t] == q:
                                continue
                            seen[t] = q
                            d = _point_triangle_sq(p, corners[t])
                            if d < best_d or (d == best_d and t < best):
                                best_d, best = d, t
            if best >= 0 and _beyond(p, c, ring, low, size, dims) ** 2 >= best_d:
                break
            ring += 1
        out[q] = best
        dist[q] = np.sqrt(best_d)
    return out, dist


def triangle_samples(corners, counts) -> tuple:
    """Points spread over triangles: triangle i gets g_i^2 points (g_i = ceil(sqrt(counts[i])),
    the centroids of its g_i x g_i sub-triangles). Returns (points (S, 3) float64, owner (S,)
    int64 triangle of each point)."""
    corners = np.asarray(corners, dtype=np.float64).reshape(-1, 3, 3)
    g = np.maximum(np.ceil(np.sqrt(np.asarray(counts, dtype=np.float64))), 1).astype(np.int64)
    points, owners = [], []
    for size in np.unique(g):
        which = np.flatnonzero(g == size)
        i, j = np.meshgrid(np.arange(size), np.arange(size), indexing="ij")
        up = (i + j <= size - 1)
        down = (i + j <= size - 2)
        u = np.r_[(i[up] + 1 / 3) / size, (i[down] + 2 / 3) / size]
        v = np.r_[(j[up] + 1 / 3) / size, (j[down] + 2 / 3) / size]
        c = corners[which]
        p = (c[:, None, 0] + u[None, :, None] * (c[:, None, 1] - c[:, None, 0])
             + v[None, :, None] * (c[:, None, 2] - c[:, None, 0]))
        points.append(p.reshape(-1, 3))
        owners.append(np.repeat(which, len(u)))
    return np.concatenate(points), np.concatenate(owners)

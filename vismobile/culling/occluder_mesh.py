"""The rasteriser's occluder mesh (hiz.rasterise's tables): each corner value once, exact plane
groups, directed edge pieces and their partners, for the whole world or any triangles (numpy;
occluder_rows.occluder_mesh_of builds the same bits for a frame's occluders in numba).
"""
from __future__ import annotations

import numpy as np


def world_tables(world) -> tuple:
    """An in-memory world's whole-world tables: occluder_mesh's, then areas, centroids, first
    corners and bounding radii about the centroids (T,)."""
    centroids = np.ascontiguousarray(world.centroids, dtype=np.float64)
    corners = world.corners
    return (*occluder_mesh(world.vertices, world.triangles, world.normals),
            np.ascontiguousarray(world.areas, dtype=np.float64), centroids,
            np.ascontiguousarray(corners[:, 0]),
            np.linalg.norm(corners - centroids[:, None], axis=2).max(1))


def unique_rows(rows) -> tuple:
    """(distinct rows in increasing lexicographic order, inverse (n,) int64 into them) of rows
    (n, m) float64, compared by value as np.unique(axis=0) does (-0.0 == 0.0), by one lexsort
    of the columns instead of a sort of structured records (10x faster on a frame's 1,500
    occluder corners)."""
    rows = np.asarray(rows, dtype=np.float64)
    order = np.lexsort(rows.T[::-1])
    ranked = rows[order]
    new = np.ones(len(rows), dtype=bool)
    new[1:] = (ranked[1:] != ranked[:-1]).any(axis=1)
    inverse = np.empty(len(rows), dtype=np.int64)
    inverse[order] = np.cumsum(new) - 1
    return ranked[new], inverse


def piece_partners(tri, a, b, groups) -> np.ndarray:
    """(S,) int64 for each directed edge piece a -> b of triangle tri, a triangle of the same
    plane group holding the reverse piece b -> a, or -1 (exact: matched by vertex index)."""
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    g = groups[tri]
    order = np.lexsort((lo, hi, g))
    key = np.column_stack([g[order], lo[order], hi[order]])
    new = np.ones(len(order), dtype=bool)
    new[1:] = (key[1:] != key[:-1]).any(axis=1)
    run = np.cumsum(new) - 1
    forward = (a < b)[order]
    count = run.max() + 1 if len(run) else 0
    # First forward and first backward piece of each run of equal undirected keys.
    first_fwd = np.full(count, -1, dtype=np.int64)
    first_bwd = np.full(count, -1, dtype=np.int64)
    idx = np.arange(len(order))
    f, k = run[forward][::-1], idx[forward][::-1]
    first_fwd[f] = order[k]  # reversed: the first one written last wins
    f, k = run[~forward][::-1], idx[~forward][::-1]
    first_bwd[f] = order[k]
    partner_piece = np.where(forward, first_bwd[run], first_fwd[run])
    out = np.full(len(tri), -1, dtype=np.int64)
    out[order] = np.where(partner_piece >= 0, tri[np.maximum(partner_piece, 0)], -1)
    return out


def occluder_mesh(vertices, triangles, normals) -> tuple:
    """The rasteriser's tables (hiz.rasterise) for triangles (T, 3) int64 over vertices (V, 3)
    with unit normals (T, 3): (points (P, 3) each value once, tri_points (T, 3), normals,
    offsets (T,), groups (T,) exact-plane labels, piece_start, piece_end (T,), piece_a,
    piece_b (3T,) the directed edges, partner (3T,) the triangle holding the reverse edge in
    the same group or -1, partner_any (3T,) the same in any group).

    Edges pair only when both triangles hold both endpoints (the same two points): the GPU
    fills such a shared edge without a crack, but not a T-junction (an edge passing through
    another triangle's corner), where a pixel centre may fall between the two sides, so a
    T-junction stays a boundary. Each point once, so shared corners match by index."""
    points, index = unique_rows(vertices)
    tri_points = np.ascontiguousarray(index[np.asarray(triangles)], dtype=np.int64)
    normals = np.ascontiguousarray(normals, dtype=np.float64)
    offsets = np.einsum("ij,ij->i", normals, points[tri_points[:, 0]])
    groups = unique_rows(np.column_stack([normals, offsets]))[1]
    count = len(tri_points)
    tri = np.repeat(np.arange(count, dtype=np.int64), 3)
    a = tri_points.ravel().copy()
    b = tri_points[:, [1, 2, 0]].ravel()
    start = 3 * np.arange(count, dtype=np.int64)
    return (points, tri_points, normals, offsets, groups, start, start + 3, a, b,
            piece_partners(tri, a, b, groups), piece_partners(tri, a, b, np.zeros_like(groups)))

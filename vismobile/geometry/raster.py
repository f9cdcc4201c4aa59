"""Camera-space projection and the exact edge pieces of a triangle mesh (split at T-junctions),
which the occlusion stage's rasteriser (culling/hiz.py) pairs with their reverse so shared edges
and T-junctions leave no cracks in the union of occluders.

Camera space here: x right, y up, z = depth along the view direction (positive in front).
"""
from __future__ import annotations

import numpy as np


def to_camera(points, eye, rotation) -> np.ndarray:
    """(..., 3) float64 camera-space coordinates of world points.

    points : (..., 3) float64;  eye : (3,);  rotation : (3, 3) rows right, up, forward
    """
    return (np.asarray(points, dtype=np.float64) - eye) @ np.asarray(rotation).T


def split_edges(vertices, triangles) -> tuple:
    """Directed edge pieces of triangles, each edge split at every vertex lying exactly on it
    (axis-parallel edges; others are left whole): (tri (S,) int64, a (S,) int64, b (S,) int64).

    Exact: pieces a -> b follow each triangle's winding and cover exactly its edges; a vertex
    is a split point only when it matches the edge's two fixed coordinates bit for bit.
    vertices  : (V, 3) float64 unique points;  triangles : (T, 3) int64 indices into vertices
    """
    v = np.asarray(vertices, dtype=np.float64)
    tri = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    ea, eb = tri.ravel(), np.roll(tri, -1, axis=1).ravel()  # edge k of triangle t at 3t + k
    owner = np.repeat(np.arange(len(tri)), 3)
    splits_e, splits_p = [np.zeros(0, np.int64)], [np.zeros(0, np.int64)]
    for axis in range(3):
        o1, o2 = [k for k in range(3) if k != axis]
        edges = np.flatnonzero((v[ea, o1] == v[eb, o1]) & (v[ea, o2] == v[eb, o2])
                               & (v[ea, axis] != v[eb, axis]))
        if not len(edges):
            continue
        # Lines keyed by their two fixed coordinates; split points strictly inside each edge.
        keys = np.concatenate([v[:, [o1, o2]], v[ea[edges]][:, [o1, o2]]])
        _, line = np.unique(keys, axis=0, return_inverse=True)
        line = line.ravel()
        vline, eline = line[:len(v)], line[len(v):]
        coords = np.unique(v[:, axis])
        rank = np.searchsorted(coords, v[:, axis])
        lo = np.minimum(v[ea[edges], axis], v[eb[edges], axis])
        hi = np.maximum(v[ea[edges], axis], v[eb[edges], axis])
        step = len(coords) + 1
        vkey = vline * step + rank
        order = np.argsort(vkey, kind="stable")
        start = np.searchsorted(vkey[order], eline * step + np.searchsorted(coords, lo), "right")
        stop = np.searchsorted(vkey[order], eline * step + np.searchsorted(coords, hi), "left")
        count = np.maximum(stop - start, 0)
        if not count.sum():
            continue
        first = np.repeat(start - np.concatenate([[0], np.cumsum(count)[:-1]]), count)
        splits_p.append(order[first + np.arange(count.sum())])
        splits_e.append(np.repeat(edges, count))
    e, p = np.concatenate(splits_e), np.concatenate(splits_p)
    # Order split points along each edge from a to b, then chain a -> p1 -> ... -> b.
    along = np.einsum("ij,ij->i", v[p] - v[ea[e]], v[eb[e]] - v[ea[e]])
    order = np.lexsort((along, e))
    e, p = e[order], p[order]
    counts = np.bincount(e, minlength=len(ea))
    total = len(ea) + len(p)
    slot = np.arange(len(ea)) + np.concatenate([[0], np.cumsum(counts)[:-1]])  # first piece
    points = np.empty(total + len(ea), dtype=np.int64)  # per edge: a, splits..., then b
    pos = slot + np.arange(len(ea))
    points[pos] = ea
    inner = np.repeat(pos, counts) + 1 + (np.arange(len(p)) - np.repeat(
        np.concatenate([[0], np.cumsum(counts)[:-1]]), counts))
    points[inner] = p
    points[pos + counts + 1] = eb
    is_start = np.ones(total + len(ea), dtype=bool)
    is_start[pos + counts + 1] = False  # b ends its edge's chain
    starts = np.flatnonzero(is_start)
    piece_edge = np.repeat(np.arange(len(ea)), counts + 1)
    return owner[piece_edge], points[starts], points[starts + 1]

"""Each node's largest triangles: the occluder candidates the `occlusion` stage
(culling/occlusion.py) takes from the nodes around the eye. Computed from a tree's references
and the triangles' corners (areas with World.areas' bits), so the out-of-core build stores them
in its .vmp (extras "occluders", (N, STORED) int32) and a stage culling such a file, mapped,
has nothing to compute: its k largest are the first k columns of the STORED largest (one
order: area down, then id up). Files without them (older builds, in-memory partitions) get
them computed when the stage prepares. One pass over the references; tables of (N, k) only.
"""
from __future__ import annotations

import numpy as np
from numba import njit

# The occlusion stage's default `candidates`.
CANDIDATES = 4
# Lists of this length are stored at build: a stage with candidates <= STORED reads them.
STORED = 8


@njit(cache=True, nogil=True, inline="always")
def triangle_area(vertices, triangles, t):
    """Area of triangle t: World.areas[t] (half the norm of its cross product, np.cross's
    products, the norm summed x + y then + z), same bits; float32 vertices widen exactly."""
    i0, i1, i2 = triangles[t, 0], triangles[t, 1], triangles[t, 2]
    x0 = np.float64(vertices[i0, 0])
    y0 = np.float64(vertices[i0, 1])
    z0 = np.float64(vertices[i0, 2])
    ax = np.float64(vertices[i1, 0]) - x0
    ay = np.float64(vertices[i1, 1]) - y0
    az = np.float64(vertices[i1, 2]) - z0
    bx = np.float64(vertices[i2, 0]) - x0
    by = np.float64(vertices[i2, 1]) - y0
    bz = np.float64(vertices[i2, 2]) - z0
    cx = ay * bz - az * by
    cy = az * bx - ax * bz
    cz = ax * by - ay * bx
    return 0.5 * np.sqrt(cx * cx + cy * cy + cz * cz)


@njit(cache=True, nogil=True)
def node_candidates(order, first_child, child_count, ref_start, ref_end, tri_refs, vertices,
                    triangles, k):
    """(N, k) int64 per node the ids of the k largest triangles (by area, > 0; ties by smaller
    id) of its subtree, -1 padded. order : (N,) int64 nodes, every child before its parent.
    Areas are computed from the corners (triangle_area: World.areas' bits), once
    per reference of a leaf and once per child's listed id, so the tables stay (N, k)."""
    n = len(first_child)
    out = np.full((n, k), -1, dtype=np.int64)
    out_area = np.zeros((n, k))
    buf = np.empty(k * 64 + 64, dtype=np.int64)
    buf_area = np.empty(k * 64 + 64)
    for node in order:
        m = 0
        if child_count[node] == 0:
            for r in range(ref_start[node], ref_end[node]):
                t = np.int64(tri_refs[r])
                area = triangle_area(vertices, triangles, t)
                if area > 0:
                    if m == len(buf):
                        buf = np.concatenate((buf, np.empty(len(buf), dtype=np.int64)))
                        buf_area = np.concatenate((buf_area, np.empty(len(buf_area))))
                    buf[m] = t
                    buf_area[m] = area
                    m += 1
        else:
            for c in range(first_child[node], first_child[node] + child_count[node]):
                for j in range(k):
                    if out[c, j] >= 0:
                        if m == len(buf):
                            buf = np.concatenate((buf, np.empty(len(buf), dtype=np.int64)))
                            buf_area = np.concatenate((buf_area, np.empty(len(buf_area))))
                        buf[m] = out[c, j]
                        buf_area[m] = out_area[c, j]
                        m += 1
        # Distinct ids in increasing order, then the largest areas first (stable: ties keep
        # the smaller id first).
        by_id = np.argsort(buf[:m], kind="mergesort")
        ids = np.empty(m, dtype=np.int64)
        areas = np.empty(m)
        u = 0
        for j in range(m):
            t = buf[by_id[j]]
            if u == 0 or ids[u - 1] != t:
                ids[u] = t
                areas[u] = buf_area[by_id[j]]
                u += 1
        best = np.argsort(-areas[:u], kind="mergesort")[:k]
        for j in range(len(best)):
            out[node, j] = ids[best[j]]
            out_area[node, j] = areas[best[j]]
    return out


def candidate_lists(first_child, child_count, ref_start, ref_end, tri_refs, vertices, triangles,
                    k: int = CANDIDATES) -> np.ndarray:
    """(N, k) int64 node_candidates of a breadth-first tree (base.py layout; tri_refs int32 or
    int64, perhaps mapped; vertices float32 or float64)."""
    n = len(child_count)
    as64 = [np.ascontiguousarray(a, dtype=np.int64)
            for a in (first_child, child_count, ref_start, ref_end)]
    return node_candidates(np.arange(n - 1, -1, -1, dtype=np.int64), *as64, tri_refs,
                           vertices, triangles, int(k))

"""Node boxes shrunk to what the nodes reference: each leaf's box becomes the union of its
triangles' boxes clipped to it, each inner node's the union of its children's, never larger
than the box it had. Octree and grid cells are regions: most of an octree leaf cell at depth 8
of a city is empty, and a culling walk tests (and descends into) the cell, not the content.

Conservative: a point of a triangle that lies in a leaf's box lies in that triangle's box
clipped to the leaf's box, so it stays inside the shrunk box; every point the partition covers
(a triangle's points inside the boxes of the leaves referencing it) keeps a box around it.
One pass over the references (compiled), tables of (N, 2, 3) only: vertices are read per
reference, so a memory-mapped world keeps nothing per triangle.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from .layout import outward_f32


@njit(cache=True, nogil=True)
def _shrunk(bounds, first_child, child_count, ref_start, ref_end, tri_refs, vertices,
            triangles):
    n = len(first_child)
    out = np.empty((n, 2, 3))
    for node in range(n - 1, -1, -1):  # breadth-first layout: children after their parent
        lo0 = lo1 = lo2 = np.inf
        hi0 = hi1 = hi2 = -np.inf
        if child_count[node] == 0:
            for r in range(ref_start[node], ref_end[node]):
                t = tri_refs[r]
                c0 = c1 = c2 = np.inf
                d0 = d1 = d2 = -np.inf
                for k in range(3):
                    v = triangles[t, k]
                    x = np.float64(vertices[v, 0])
                    y = np.float64(vertices[v, 1])
                    z = np.float64(vertices[v, 2])
                    c0, d0 = min(c0, x), max(d0, x)
                    c1, d1 = min(c1, y), max(d1, y)
                    c2, d2 = min(c2, z), max(d2, z)
                # The triangle's box clipped to the leaf's (empty: it only touches the leaf
                # within the overlap test's slack; its points lie in other leaves).
                c0, d0 = max(c0, bounds[node, 0, 0]), min(d0, bounds[node, 1, 0])
                c1, d1 = max(c1, bounds[node, 0, 1]), min(d1, bounds[node, 1, 1])
                c2, d2 = max(c2, bounds[node, 0, 2]), min(d2, bounds[node, 1, 2])
                if c0 <= d0 and c1 <= d1 and c2 <= d2:
                    lo0, hi0 = min(lo0, c0), max(hi0, d0)
                    lo1, hi1 = min(lo1, c1), max(hi1, d1)
                    lo2, hi2 = min(lo2, c2), max(hi2, d2)
        else:
            for c in range(first_child[node], first_child[node] + child_count[node]):
                lo0, hi0 = min(lo0, out[c, 0, 0]), max(hi0, out[c, 1, 0])
                lo1, hi1 = min(lo1, out[c, 0, 1]), max(hi1, out[c, 1, 1])
                lo2, hi2 = min(lo2, out[c, 0, 2]), max(hi2, out[c, 1, 2])
        # Clipped to the node's own box; an empty node (or content wholly outside its box,
        # which a valid partition never has) keeps its box.
        a0, a1, a2 = max(lo0, bounds[node, 0, 0]), max(lo1, bounds[node, 0, 1]), max(
            lo2, bounds[node, 0, 2])
        b0, b1, b2 = min(hi0, bounds[node, 1, 0]), min(hi1, bounds[node, 1, 1]), min(
            hi2, bounds[node, 1, 2])
        if a0 <= b0 and a1 <= b1 and a2 <= b2:
            out[node, 0, 0], out[node, 0, 1], out[node, 0, 2] = a0, a1, a2
            out[node, 1, 0], out[node, 1, 1], out[node, 1, 2] = b0, b1, b2
        else:
            for j in range(3):
                out[node, 0, j] = bounds[node, 0, j]
                out[node, 1, j] = bounds[node, 1, j]
    return out


def shrunk_bounds(partition) -> np.ndarray:
    """(N, 2, 3) float64 node boxes shrunk to their references (module docstring), rounded
    outward to float32 like every partition's node_bounds; within partition.node_bounds.

    partition : a base.Partition (breadth-first layout); its world may be memory-mapped
    """
    p = partition
    bounds = np.ascontiguousarray(p.node_bounds, dtype=np.float64)
    out = _shrunk(bounds, np.ascontiguousarray(p.first_child, dtype=np.int64),
                  np.ascontiguousarray(p.child_count, dtype=np.int64),
                  np.ascontiguousarray(p.ref_start, dtype=np.int64),
                  np.ascontiguousarray(p.ref_end, dtype=np.int64), p.tri_refs,
                  p.world.vertices, p.world.triangles)
    # Rounding outward may step past the float32 box it shrank: clip back to that box.
    out = outward_f32(out)
    np.maximum(out[:, 0], bounds[:, 0], out=out[:, 0])
    np.minimum(out[:, 1], bounds[:, 1], out=out[:, 1])
    return out

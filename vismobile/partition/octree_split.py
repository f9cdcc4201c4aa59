"""One octree level, compiled (numba): which octants of its box each (box, triangle) reference
reaches, then the children's references in the order the tree keeps them. The decisions are
octree.subdivide's (a triangle whose box meets one octant only is kept there; otherwise each
octant its box meets is kept when the exact SAT test says so), with no array per candidate
pair: one byte per reference, then the next level's references, written in place of a sort.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from ..geometry.triangle_box import EPS
from ..geometry.triangle_box_one import triangle_overlaps_box

# Set bits of a byte (a reference's octant mask).
_POPCOUNT = np.array([bin(i).count("1") for i in range(256)], dtype=np.int64)


@njit(cache=True, nogil=True)
def octant_masks(boxes, pair_node, pair_tri, vertices, triangles, eps=EPS):
    """Octants of its box each reference reaches.

    boxes     : (M, 2, 3) float64 boxes of the level
    pair_node : (P,) int64 box of each reference; pair_tri : (P,) int64 its triangle
    vertices  : (V, 3) float32/float64; triangles : (T, 3) int
    returns   : masks (P,) uint8 (bit o: octant o keeps the triangle), and the candidate pairs
                (octants the triangle's box meets), the count the exact tests ran on
    """
    count = len(pair_node)
    masks = np.zeros(count, dtype=np.uint8)
    lo = np.empty(3)
    hi = np.empty(3)
    low_ok = np.empty(3, dtype=np.bool_)
    high_ok = np.empty(3, dtype=np.bool_)
    centre = np.empty(3)
    candidates = 0
    for p in range(count):
        node = pair_node[p]
        t = pair_tri[p]
        i0, i1, i2 = triangles[t, 0], triangles[t, 1], triangles[t, 2]
        x0, y0, z0 = (np.float64(vertices[i0, 0]), np.float64(vertices[i0, 1]),
                      np.float64(vertices[i0, 2]))
        x1, y1, z1 = (np.float64(vertices[i1, 0]), np.float64(vertices[i1, 1]),
                      np.float64(vertices[i1, 2]))
        x2, y2, z2 = (np.float64(vertices[i2, 0]), np.float64(vertices[i2, 1]),
                      np.float64(vertices[i2, 2]))
        for j in range(3):
            a = boxes[node, 0, j]
            b = boxes[node, 1, j]
            c = (a + b) / 2.0  # boxes.mean(axis=1)
            centre[j] = c
            if j == 0:
                t_lo, t_hi = min(min(x0, x1), x2), max(max(x0, x1), x2)
            elif j == 1:
                t_lo, t_hi = min(min(y0, y1), y2), max(max(y0, y1), y2)
            else:
                t_lo, t_hi = min(min(z0, z1), z2), max(max(z0, z1), z2)
            low_ok[j] = t_lo <= c
            # A box of zero extent on an axis (a flat world) is not split there.
            high_ok[j] = t_hi >= c and b > a
        cand = 0
        n = 0
        for o in range(8):
            ok = True
            for j in range(3):
                if not (high_ok[j] if (o >> j) & 1 else low_ok[j]):
                    ok = False
            if ok:
                cand |= 1 << o
                n += 1
        candidates += n
        if n <= 1:  # one octant only: the triangle overlaps it, no SAT needed
            masks[p] = cand
            continue
        keep = 0
        for o in range(8):
            if (cand >> o) & 1:
                for j in range(3):
                    if (o >> j) & 1:
                        lo[j], hi[j] = centre[j], boxes[node, 1, j]
                    else:
                        lo[j], hi[j] = boxes[node, 0, j], centre[j]
                if triangle_overlaps_box(x0, y0, z0, x1, y1, z1, x2, y2, z2, lo, hi, eps):
                    keep |= 1 << o
        masks[p] = keep
    return masks, candidates


@njit(cache=True, nogil=True)
def kept_count(masks, popcount):
    """Number of kept (reference, octant) pairs: the next level's references."""
    total = 0
    for m in masks:
        total += popcount[m]
    return total


@njit(cache=True, nogil=True)
def children_refs(pair_node, pair_tri, masks, total, popcount):
    """The next level from the masks, in octree.subdivide's order (children by box then octant,
    references by ascending triangle within a child).

    pair_node : (P,) int64, sorted; pair_tri : (P,) int64, ascending within a box
    returns   : child_key (C,) int64 box * 8 + octant of each child (ascending),
                node (total,) int64 child of each new reference, tri (total,) int64
    """
    count = len(pair_node)
    children = 0
    s = 0
    while s < count:
        if s > 0 and pair_node[s] < pair_node[s - 1]:
            raise ValueError("octree references must be sorted by box")
        e, union = s, 0
        while e < count and pair_node[e] == pair_node[s]:
            union |= masks[e]
            e += 1
        children += popcount[union]
        s = e
    child_key = np.empty(children, dtype=np.int64)
    node = np.empty(total, dtype=np.int64)
    tri = np.empty(total, dtype=np.int64)
    child, out, s = 0, 0, 0
    while s < count:
        e, union = s, 0
        while e < count and pair_node[e] == pair_node[s]:
            union |= masks[e]
            e += 1
        for o in range(8):
            if (union >> o) & 1:
                child_key[child] = pair_node[s] * 8 + o
                for p in range(s, e):
                    if (masks[p] >> o) & 1:
                        node[out] = child
                        tri[out] = pair_tri[p]
                        out += 1
                child += 1
        s = e
    return child_key, node, tri


def split_level(boxes, pair_node, pair_tri, vertices, triangles, check, level):
    """One octree level: child_key (C,), the children's (node (R,), tri (R,)) references.
    check(count, what, candidates=...) refuses a level over the memory limit before the
    references are allocated."""
    masks, candidates = octant_masks(boxes, pair_node, pair_tri, vertices, triangles)
    check(int(candidates), f"octree level {level}", candidates=True)
    total = int(kept_count(masks, _POPCOUNT))
    check(total, f"octree level {level}")
    return children_refs(pair_node, pair_tri, masks, total, _POPCOUNT)

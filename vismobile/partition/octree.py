"""Octree: boxes halved on every axis down to a fixed depth; a triangle is referenced by every
leaf it overlaps (exact SAT), never split; empty children are not stored (thesis §4.4)."""
from __future__ import annotations

import numpy as np

from .layout import check_references, make_partition
from .octree_split import split_level

DEFAULT_DEPTH = 5
MAX_DEPTH = 8
# Octant o takes the high half on axis j when bit j of o is set.
OCTANT_BITS = ((np.arange(8)[:, None] >> np.arange(3)[None, :]) & 1).astype(bool)  # (8, 3)


def check_depth(depth, low=1, high=MAX_DEPTH, what="octree depth") -> int:
    """depth as an int in [low, high], else ValueError."""
    if isinstance(depth, bool) or not isinstance(depth, (int, np.integer)) or not low <= depth <= high:
        raise ValueError(f"{what} must be an integer from {low} to {high}, got {depth!r}")
    return int(depth)


def subdivide(world, boxes, pair_node, pair_tri, levels, progress=None):
    """Split boxes into octants `levels` times, keeping the children some triangle overlaps.

    boxes     : (M, 2, 3) float64 starting boxes
    pair_node : (P,) int64 box of each (box, triangle) reference, sorted
    pair_tri  : (P,) int64 triangle of each reference, ascending within a box
    returns   : list of (boxes (Mk, 2, 3), parent (Mk,) int64 index into the level above,
                octant (Mk,) int8), one per new level, and the last level's (pair_node, pair_tri)
    """
    out = []
    for level in range(levels):
        child_key, pair_node, pair_tri = split_level(boxes, pair_node, pair_tri, world.vertices,
                                                     world.triangles, check_references,
                                                     level + 1)
        parent = child_key // 8
        octant = (child_key % 8).astype(np.int8)
        boxes = child_boxes(boxes, parent, octant)
        out.append((boxes, parent, octant))
        if progress is not None:
            progress(level + 1, levels)
    return out, (pair_node, pair_tri)


def build(world, depth=DEFAULT_DEPTH, progress=None):
    """Octree over the world's box (halved per axis, not a cube) down to `depth` (1..8).

    returns : Partition with node_bounds = octree cells (rounded outward to float32) and
              extras octant (N,) int8, each node's octant in its parent (bit j = high on axis j)
    """
    depth = check_depth(depth)
    root = world.extent[None].astype(np.float64)
    tris = np.arange(world.triangle_count, dtype=np.int64)
    levels, (last_node, last_tri) = subdivide(world, root, np.zeros_like(tris), tris, depth,
                                              progress)
    parent, region, starts = chain_levels([root] + [b for b, _, _ in levels],
                                          [np.array([-1])] + [p for _, p, _ in levels])
    octant = np.concatenate([[-1]] + [o for _, _, o in levels]).astype(np.int8)
    result, _ = make_partition("octree", {"depth": depth}, world, parent,
                               last_node + starts[-1], last_tri, region,
                               node_extras={"octant": octant})
    return result


def child_boxes(boxes, parent, octant):
    """(M, 2, 3) float64 octant `octant` (M,) of boxes[parent] (M,): the halves at the centre."""
    centre = boxes.mean(axis=1)[parent]
    bits = OCTANT_BITS[octant]
    lo = np.where(bits, centre, boxes[parent, 0])
    hi = np.where(bits, boxes[parent, 1], centre)
    return np.stack([lo, hi], axis=1)


def octant_regions(anchor, anchor_level, octant, child_count, level_start):
    """(N, 2, 3) float64 octree cells rebuilt from the anchor level's boxes and the octant codes
    of the levels below (NaN above the anchor level); the store uses it instead of saving them.

    anchor : (M, 2, 3) float64 boxes of the nodes of level anchor_level, in node order
    octant : (N,) int8 octant of each node within its parent (any value above/at the anchor)
    """
    n = len(child_count)
    parent = np.concatenate([[-1], np.repeat(np.arange(n), child_count)])
    out = np.full((n, 2, 3), np.nan)
    a0, a1 = level_start[anchor_level], level_start[anchor_level + 1]
    out[a0:a1] = anchor
    for k in range(anchor_level + 1, len(level_start) - 1):
        nodes = np.arange(level_start[k], level_start[k + 1])
        top = level_start[k - 1]
        out[nodes] = child_boxes(out[top:nodes[0]], parent[nodes] - top,
                                 np.asarray(octant[nodes], dtype=np.int64))
    return out


def chain_levels(level_boxes, level_parent):
    """Build-order arrays of a tree given level by level.

    level_boxes  : list of (Mk, 2, 3) float64 boxes of each level (level 0 the root)
    level_parent : list of (Mk,) int parent indices local to the level above (-1 for the root)
    returns      : parent (N,) int64, region (N, 2, 3) float64, starts (L,) first id per level
    """
    sizes = np.array([len(b) for b in level_boxes], dtype=np.int64)
    starts = np.cumsum(sizes) - sizes
    parent = np.concatenate([np.asarray(level_parent[0], dtype=np.int64)]
                            + [np.asarray(p, dtype=np.int64) + starts[k - 1]
                               for k, p in enumerate(level_parent) if k > 0])
    return parent, np.concatenate(level_boxes), starts

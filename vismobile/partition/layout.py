"""Flatten a tree built in any node order into the breadth-first layout of base.py."""
from __future__ import annotations

import os

import numpy as np

from .base import gather_ranges

# Build arrays per triangle reference of one level (ids, boxes, masks, sort keys), measured
# order of magnitude; 4 Mi references take about 0.5 GiB.
BYTES_PER_REFERENCE = 128


def host_reference_limit(memory_fraction: float = 0.25) -> int:
    """References one level may hold on this host: a quarter of physical memory's worth,
    never below 4 Mi (the limit on any machine)."""
    try:
        memory = os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):  # no sysconf: the portable floor
        return 1 << 22
    return max(1 << 22, int(memory * memory_fraction) // BYTES_PER_REFERENCE)


# Checked before allocating, so a duplicate-heavy world or an extreme parameter is refused
# with a message instead of exhausting memory.
MAX_REFERENCES = host_reference_limit()


def check_references(count, what, candidates=False) -> None:
    """ValueError when a build step would hold more than MAX_REFERENCES references (or test
    more than twice as many candidate pairs, a bound on the exact tests' arrays)."""
    limit = MAX_REFERENCES * (2 if candidates else 1)
    if count > limit:
        held = "test" if candidates else "hold"
        raise ValueError(f"{what} would {held} {int(count):,} triangle references, over the "
                         f"limit of {limit:,} for this machine's memory; use fewer cells or a "
                         f"smaller depth, or for a world of millions of triangles the streamed "
                         f"octree build (`vismobile partition WORLD_DIR --jobs N`, docs/scale.md)")


def flatten(parent, ref_node, ref_tri) -> dict:
    """Breadth-first node order, contiguous children, subtree ranges of depth-first leaf refs.

    parent   : (N,) int parent of each node in build order; node 0 is the root (parent -1).
               Siblings keep their build order.
    ref_node : (R,) int node (a leaf) holding each reference, build order ids
    ref_tri  : (R,) int triangle id of each reference; kept in this order within a leaf
    returns  : dict with order (N,) int64 (new -> build id), new_of_old (N,) int64,
               parent, first_child, child_count (int32), ref_start, ref_end, level_start
               (int64) and tri_refs (int32), all in the new order
    """
    parent = np.asarray(parent, dtype=np.int64)
    n = len(parent)
    kids = np.argsort(parent[1:], kind="stable").astype(np.int64) + 1
    counts = np.bincount(parent[1:], minlength=n).astype(np.int64)
    cstart = np.cumsum(counts) - counts
    levels, level = [], np.zeros(1, dtype=np.int64)
    while len(level):
        levels.append(level)
        level = gather_ranges(kids, cstart[level], cstart[level] + counts[level])
    order = np.concatenate(levels)
    if len(order) != n:
        raise ValueError("parent array does not describe one tree rooted at node 0")
    new_of_old = np.empty(n, dtype=np.int64)
    new_of_old[order] = np.arange(n)
    child_count = counts[order]
    first_child = np.where(child_count > 0, 1 + np.cumsum(child_count) - child_count, -1)
    level_start = np.concatenate([[0], np.cumsum([len(x) for x in levels])]).astype(np.int64)
    new_parent = np.full(n, -1, dtype=np.int64)
    new_parent[1:] = new_of_old[parent[order[1:]]]

    # Depth-first preorder numbers: subtree sizes bottom-up, then offsets top-down.
    size = np.ones(n, dtype=np.int64)
    for k in range(len(levels) - 1, 0, -1):
        nodes = np.arange(level_start[k], level_start[k + 1])
        np.add.at(size, new_parent[nodes], size[nodes])
    pre = np.zeros(n, dtype=np.int64)
    for k in range(1, len(levels)):
        nodes = np.arange(level_start[k], level_start[k + 1])
        before = np.cumsum(size[nodes]) - size[nodes]
        first = first_child[new_parent[nodes]] - level_start[k]
        pre[nodes] = pre[new_parent[nodes]] + 1 + before - before[first]

    ref_node = new_of_old[np.asarray(ref_node, dtype=np.int64)]
    if len(ref_node) and np.any(child_count[ref_node] > 0):
        raise ValueError("references must sit on leaves")
    keys = pre[ref_node]
    ref_order = np.argsort(keys, kind="stable")
    # Subtree ranges from counts per preorder number: no search of each node in the keys.
    below = np.zeros(n + 1, dtype=np.int64)
    np.cumsum(np.bincount(keys, minlength=n), out=below[1:])
    return {
        "order": order,
        "new_of_old": new_of_old,
        "parent": new_parent,
        "first_child": first_child.astype(np.int32),
        "child_count": child_count.astype(np.int32),
        "ref_start": below[pre],
        "ref_end": below[pre + size],
        "level_start": level_start,
        "tri_refs": np.asarray(ref_tri, dtype=np.int32)[ref_order],
    }


def subtree_bounds(tri_bounds, tri_refs, ref_start, ref_end, child_count, parent, level_start):
    """(N, 2, 3) float64 AABB of the referenced triangles of each subtree (NaN when empty).

    tri_bounds : (T, 2, 3) float64 per-triangle AABBs
    """
    n = len(ref_start)
    out = np.full((n, 2, 3), np.nan)
    leaves = np.flatnonzero((ref_end > ref_start) & (child_count == 0))
    leaves = leaves[np.argsort(ref_start[leaves], kind="stable")]
    if len(leaves):
        b = tri_bounds[tri_refs]
        # Leaf ranges in depth-first order are disjoint and increasing: one reduceat each.
        starts = ref_start[leaves]
        # Non-empty leaf ranges tile tri_refs in depth-first order: one reduceat each.
        out[leaves, 0] = np.minimum.reduceat(b[:, 0], starts)
        out[leaves, 1] = np.maximum.reduceat(b[:, 1], starts)
    for k in range(len(level_start) - 2, 0, -1):
        nodes = np.arange(level_start[k], level_start[k + 1])
        p = parent[nodes]
        np.fmin.at(out[:, 0], p, out[nodes, 0])
        np.fmax.at(out[:, 1], p, out[nodes, 1])
    return out


def outward_f32(bounds) -> np.ndarray:
    """(..., 2, 3) float64 boxes rounded outward to float32-representable values (never shrink)."""
    bounds = np.asarray(bounds, dtype=np.float64)
    low = bounds[..., 0, :].astype(np.float32)
    high = bounds[..., 1, :].astype(np.float32)
    low = np.where(low.astype(np.float64) > bounds[..., 0, :], np.nextafter(low, np.float32(-np.inf)), low)
    high = np.where(high.astype(np.float64) < bounds[..., 1, :], np.nextafter(high, np.float32(np.inf)), high)
    return np.stack([low, high], axis=-2).astype(np.float64)


def make_partition(kind, params, world, parent, ref_node, ref_tri, region=None,
                   node_extras=None, extras=None):
    """Partition from a tree in build order.

    region      : (N, 2, 3) float64 node regions in build order (octree cells, grid cells) or
                  None; node_bounds are the regions, or the subtree AABB when None
    node_extras : dict name -> (N, ...) per-node arrays in build order, reordered here
    extras      : dict name -> array stored as is
    """
    from .base import Partition

    flat = flatten(parent, ref_node, ref_tri)
    order = flat["order"]
    if region is None:
        bounds = subtree_bounds(world.bounds, flat["tri_refs"], flat["ref_start"],
                                flat["ref_end"], flat["child_count"], flat["parent"],
                                flat["level_start"])
        bounds = np.where(np.isnan(bounds), world.extent[None], bounds)
    else:
        bounds = np.asarray(region, dtype=np.float64)[order]
    all_extras = {name: np.ascontiguousarray(np.asarray(value)[order])
                  for name, value in (node_extras or {}).items()}
    all_extras.update(extras or {})
    result = Partition(kind=kind, params=dict(params), world=world,
                       node_bounds=outward_f32(bounds),
                       first_child=flat["first_child"], child_count=flat["child_count"],
                       ref_start=flat["ref_start"], ref_end=flat["ref_end"],
                       level_start=flat["level_start"], tri_refs=flat["tri_refs"],
                       extras=all_extras)
    result.check()
    return result, flat

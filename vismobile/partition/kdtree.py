"""kd-tree (thesis future work): axis-aligned binary splits chosen by the surface area heuristic
(binned SAH with a traversal/intersection cost ratio) or at the median; triangles referenced by
both children when they straddle a split, never split. Built level by level: the bins of every
node of a level are filled and scored in one vectorised pass.

Each node's cell is shrunk to the box of what it references (its triangles' boxes clipped to the
cell), so empty space is cut off for free and the node box is that tight cell. SAH stops on its
own: a node stays a leaf when no split costs less than intersecting its references,
    ratio + (A_left n_left + A_right n_right) / A_node  >=  n_node,
with A the children's surface areas; `max_depth` (8 + 1.3 log2 T by default) only guards
degenerate worlds.

Conservativeness: a reference goes left when its clipped box starts below the plane and right
when it ends at or above it, so every point of a triangle lies in a leaf that references it and
whose box holds that point; culling a leaf box never hides a point of a triangle it alone holds.
"""
from __future__ import annotations

import numpy as np

from .layout import check_references, make_partition

SPLITS = ("sah", "median")
DEFAULTS = {"split": "sah", "ratio": 16.0, "bins": 16, "min_leaf": 1}
MAX_BINS = 256
MAX_DEPTH_LIMIT = 64


def auto_depth(triangles: int) -> int:
    """The depth guard of an automatic build: 8 + 1.3 log2 T (PBRT's rule), at most 64."""
    return int(min(MAX_DEPTH_LIMIT, round(8 + 1.3 * np.log2(max(triangles, 1)))))


def _surface(lo, hi):
    """(...,) float64 surface area of boxes lo/hi (..., 3)."""
    d = np.maximum(hi - lo, 0.0)
    return 2.0 * (d[..., 0] * d[..., 1] + d[..., 1] * d[..., 2] + d[..., 2] * d[..., 0])


def sah_planes(box_lo, box_hi, ref_lo, ref_hi, owner, counts, bins, ratio):
    """Best binned-SAH plane of each node, or none.

    box_lo, box_hi : (n, 3) float64 node cells (tight); ref_lo, ref_hi : (P, 3) float64 clipped
    reference boxes; owner : (P,) int64 node of each reference; counts : (n,) int64
    returns        : axis (n,) int64 (-1: stay a leaf), plane (n,) float64; a split is kept
                     only when its cost beats n (the leaf's) and both children shrink
    """
    n = len(counts)
    width = (box_hi - box_lo) / bins  # (n, 3)
    best_cost = np.full(n, np.inf)
    best_axis = np.full(n, -1, dtype=np.int64)
    best_plane = np.zeros(n)
    area = _surface(box_lo, box_hi)
    k = np.arange(1, bins)  # planes between bins
    for axis in range(3):
        w = width[:, axis]
        live = w > 0
        safe = np.where(live, w, 1.0)[owner]
        lo_bin = np.clip(((ref_lo[:, axis] - box_lo[owner, axis]) / safe).astype(np.int64),
                         0, bins - 1)
        hi_bin = np.clip(((ref_hi[:, axis] - box_lo[owner, axis]) / safe).astype(np.int64),
                         0, bins - 1)
        lo_hist = np.bincount(owner * bins + lo_bin, minlength=n * bins).reshape(n, bins)
        hi_hist = np.bincount(owner * bins + hi_bin, minlength=n * bins).reshape(n, bins)
        left = np.cumsum(lo_hist, axis=1)[:, :-1]  # refs starting below plane k: bins < k
        right = np.cumsum(hi_hist[:, ::-1], axis=1)[:, ::-1][:, 1:]  # refs ending in bins >= k
        plane = box_lo[:, axis, None] + w[:, None] * k[None]  # (n, bins - 1)
        l_hi = np.repeat(box_hi[:, None], bins - 1, axis=1)
        l_hi[..., axis] = plane
        r_lo = np.repeat(box_lo[:, None], bins - 1, axis=1)
        r_lo[..., axis] = plane
        a_left = _surface(box_lo[:, None], l_hi)
        a_right = _surface(r_lo, box_hi[:, None])
        with np.errstate(divide="ignore", invalid="ignore"):
            cost = ratio + (a_left * left + a_right * right) / area[:, None]
        shrinks = (left < counts[:, None]) & (right < counts[:, None])
        cost = np.where(live[:, None] & shrinks & (area[:, None] > 0), cost, np.inf)
        pick = np.argmin(cost, axis=1)
        c = cost[np.arange(n), pick]
        better = c < best_cost
        best_cost[better] = c[better]
        best_axis[better] = axis
        best_plane[better] = plane[np.arange(n), pick][better]
    best_axis[~(best_cost < counts)] = -1
    return best_axis, best_plane


def median_planes(box_lo, box_hi, ref_lo, ref_hi, owner, counts, starts):
    """Plane at the median clipped-box centre on each node's longest axis (-1: no axis)."""
    axis = np.argmax(box_hi - box_lo, axis=1)
    centre = 0.5 * (ref_lo + ref_hi)[np.arange(len(owner)), axis[owner]]
    order = np.lexsort((centre, owner))
    plane = centre[order][starts + counts // 2]
    live = (box_hi - box_lo)[np.arange(len(counts)), axis] > 0
    return np.where(live, axis, -1), plane


def build(world, split="sah", ratio=16.0, bins=16, min_leaf=1, max_depth=None, progress=None):
    """kd-tree; the left child (low side of the plane) is first_child, the right the next.

    split     : "sah" (default; stops on its own) or "median" (stops at min_leaf/max_depth)
    ratio     : SAH traversal / intersection cost ratio; higher gives fewer, larger leaves
    bins      : SAH bins per axis and node (2..256)
    min_leaf  : nodes with at most this many references stay leaves
    max_depth : deepest level (default auto_depth(T))
    returns   : Partition; node_bounds = tight cells (clipped reference boxes), extras
                split_axis (N,) int8 (-1 for leaves) and split_value (N,) float64 (NaN for leaves)
    """
    if split not in SPLITS:
        raise ValueError(f"unknown kd-tree split {split!r}; expected one of {', '.join(SPLITS)}")
    for name, value in (("bins", bins), ("min_leaf", min_leaf)):
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
            raise ValueError(f"kd-tree {name} must be an integer, got {value!r}")
    if not 2 <= bins <= MAX_BINS or min_leaf < 1:
        raise ValueError(f"kd-tree bins must be from 2 to {MAX_BINS} and min_leaf >= 1")
    if isinstance(ratio, bool) or not isinstance(ratio, (int, float)) or not 0 <= ratio <= 1e6:
        raise ValueError(f"kd-tree ratio must be a number from 0 to 1e6, got {ratio!r}")
    if max_depth is None:
        max_depth = auto_depth(world.triangle_count)
    if (isinstance(max_depth, bool) or not isinstance(max_depth, (int, np.integer))
            or not 0 <= max_depth <= MAX_DEPTH_LIMIT):
        raise ValueError(f"kd-tree max_depth must be an integer from 0 to {MAX_DEPTH_LIMIT}, "
                         f"got {max_depth!r}")
    tri_bounds = world.bounds
    pair_node = np.zeros(world.triangle_count, dtype=np.int64)
    pair_tri = np.arange(world.triangle_count, dtype=np.int64)
    ref_lo = tri_bounds[:, 0].copy()
    ref_hi = tri_bounds[:, 1].copy()
    parent = [np.array([-1])]
    cells = [world.extent[None].astype(np.float64)]
    axes = [np.full(1, -1, dtype=np.int8)]
    values = [np.full(1, np.nan)]
    leaf_node, leaf_tri = [], []
    base, next_id = 0, 1
    for depth in range(int(max_depth) + 1):
        if not len(pair_node):
            break
        # pair_node is sorted (children are laid out in order): runs are the level's nodes.
        starts = np.flatnonzero(np.r_[True, pair_node[1:] != pair_node[:-1]])
        counts = np.diff(np.r_[starts, len(pair_node)])
        nodes = pair_node[starts]
        owner = np.repeat(np.arange(len(nodes)), counts)
        box_lo = np.minimum.reduceat(ref_lo, starts, axis=0)
        box_hi = np.maximum.reduceat(ref_hi, starts, axis=0)
        cells[-1][nodes - base] = np.stack([box_lo, box_hi], axis=1)  # shrink to the refs
        axis = np.full(len(nodes), -1, dtype=np.int64)
        plane = np.zeros(len(nodes))
        can = (counts > min_leaf) & (depth < max_depth)
        if can.any():
            if split == "sah":
                a, p = sah_planes(box_lo, box_hi, ref_lo, ref_hi, owner, counts, int(bins),
                                  float(ratio))
            else:
                a, p = median_planes(box_lo, box_hi, ref_lo, ref_hi, owner, counts, starts)
            axis = np.where(can, a, -1)
            plane = p
        # Exact classification at the chosen planes (the bins only estimated the counts).
        ra = axis[owner]
        inner = ra >= 0
        coord_lo = ref_lo[np.arange(len(owner)), np.maximum(ra, 0)]
        coord_hi = ref_hi[np.arange(len(owner)), np.maximum(ra, 0)]
        to_left = inner & (coord_lo < plane[owner])
        to_right = inner & (coord_hi >= plane[owner])
        left_n = np.bincount(owner[to_left], minlength=len(nodes))
        right_n = np.bincount(owner[to_right], minlength=len(nodes))
        # A split that moves every reference to one side would loop: such nodes stay leaves.
        stuck = (axis >= 0) & ((left_n == counts) | (right_n == counts) | (left_n == 0)
                               | (right_n == 0))
        axis[stuck] = -1
        inner = axis[owner] >= 0
        to_left &= inner
        to_right &= inner
        leaf = ~inner
        leaf_node.append(pair_node[leaf])
        leaf_tri.append(pair_tri[leaf])
        split_nodes = np.flatnonzero(axis >= 0)
        axes[-1][nodes - base] = np.where(axis >= 0, axis, -1)
        values[-1][nodes - base] = np.where(axis >= 0, plane, np.nan)
        if not len(split_nodes):
            break
        rank = np.full(len(nodes), -1, dtype=np.int64)
        rank[split_nodes] = np.arange(len(split_nodes))
        child_base = next_id
        parent.append(np.repeat(nodes[split_nodes], 2))
        child_cells = np.repeat(np.stack([box_lo, box_hi], axis=1)[split_nodes], 2, axis=0)
        sa = axis[split_nodes]
        child_cells[0::2, 1, :][np.arange(len(sa)), sa] = plane[split_nodes]
        child_cells[1::2, 0, :][np.arange(len(sa)), sa] = plane[split_nodes]
        cells.append(child_cells)
        axes.append(np.full(2 * len(split_nodes), -1, dtype=np.int8))
        values.append(np.full(2 * len(split_nodes), np.nan))
        next_id += 2 * len(split_nodes)
        base = child_base
        # Children: left = child_base + 2 rank, right = + 1; refs clipped to the child cell.
        left_i, right_i = np.flatnonzero(to_left), np.flatnonzero(to_right)
        check_references(len(left_i) + len(right_i), f"kd-tree level {depth + 1}")
        # Counting placement (no sort): child 2r + side of split node r, each child's
        # references in their parent's (ascending triangle) order.
        rl, rr = rank[owner[left_i]], rank[owner[right_i]]
        sizes = np.zeros(2 * len(split_nodes), dtype=np.int64)
        sizes[0::2] = np.bincount(rl, minlength=len(split_nodes))
        sizes[1::2] = np.bincount(rr, minlength=len(split_nodes))
        first = np.cumsum(sizes) - sizes
        pos_l = first[2 * rl] + np.arange(len(rl)) - (np.cumsum(sizes[0::2]) - sizes[0::2])[rl]
        pos_r = (first[2 * rr + 1] + np.arange(len(rr))
                 - (np.cumsum(sizes[1::2]) - sizes[1::2])[rr])
        total = len(rl) + len(rr)
        new_node = np.empty(total, dtype=np.int64)
        new_tri = np.empty(total, dtype=np.int64)
        new_lo = np.empty((total, 3))
        new_hi = np.empty((total, 3))
        new_node[pos_l] = child_base + 2 * rl
        new_node[pos_r] = child_base + 2 * rr + 1
        new_tri[pos_l], new_tri[pos_r] = pair_tri[left_i], pair_tri[right_i]
        lo_l, hi_l = ref_lo[left_i], ref_hi[left_i]
        lo_r, hi_r = ref_lo[right_i], ref_hi[right_i]
        cut_l, cut_r = plane[owner[left_i]], plane[owner[right_i]]
        ax_l, ax_r = axis[owner[left_i]], axis[owner[right_i]]
        il, ir = np.arange(len(rl)), np.arange(len(rr))
        hi_l[il, ax_l] = np.minimum(hi_l[il, ax_l], cut_l)  # clipped to the child cell
        lo_r[ir, ax_r] = np.maximum(lo_r[ir, ax_r], cut_r)
        new_lo[pos_l], new_hi[pos_l], new_lo[pos_r], new_hi[pos_r] = lo_l, hi_l, lo_r, hi_r
        pair_node, pair_tri, ref_lo, ref_hi = new_node, new_tri, new_lo, new_hi
        if progress is not None:
            progress(depth + 1, int(max_depth) + 1)
    parent = np.concatenate(parent)
    region = np.concatenate(cells)  # each node's cell shrunk to its clipped references
    leaf_node = np.concatenate(leaf_node)
    params = {"split": split, "ratio": float(ratio), "bins": int(bins),
              "min_leaf": int(min_leaf), "max_depth": int(max_depth)}
    result, _ = make_partition("kdtree", params, world, parent, leaf_node,
                               np.concatenate(leaf_tri), region,
                               node_extras={"split_axis": np.concatenate(axes),
                                            "split_value": np.concatenate(values)})
    return result

"""BSP tree (thesis §4.4): split planes are the world's own triangle planes, sampled per node and
chosen for balance; straddlers are referenced on both sides, never split. Built level by level:
the candidates of every node of a level are scored in one vectorised pass.

Two stopping rules:
- "thesis": a node stays a leaf when no sampled plane gives 0.8 <= h+/h- <= 1.25 (SPEC §3).
  On real worlds this stops early (W1 ends with a handful of leaves).
- "balanced" (default): a node above min_leaf references and above max_depth is split by the
  best in-range candidate, else by the best-scoring one, among candidates whose split pays off:
  both children keep at least min_leaf references, straddlers are at most MAX_STRADDLE_SHARE of
  the node and the larger child at most MAX_CHILD_SHARE of it. With none, the node is a leaf
  (so every leaf below the root holds at least min_leaf references)."""
from __future__ import annotations

import numpy as np

from .layout import check_references, make_partition

DEFAULTS = {"min_leaf": 8, "max_depth": 32, "candidates": 64, "balance": (0.8, 1.25),
            "straddle_weight": 2.0, "seed": 0, "rule": "balanced"}
RULES = ("balanced", "thesis")
MAX_CANDIDATES = 4096  # planes scored per node: (nodes x candidates) arrays per level
# Corners within this fraction of the world's size of a plane count as on it.
PLANE_TOLERANCE = 1e-7
# Rows of the final per-reference classification handled at once.
CHUNK = 1 << 16
# Float64 values per candidate-scoring batch: (blocks x block x 3 corners x K) distances.
SCORE_BATCH = 1 << 22
# Balanced rule: a split pays off when its straddlers are at most this share of the node
# (each is referenced twice) and its larger child holds at most this share (no long chains
# that peel off a few triangles per level). Tuned on W1-W6: refs/triangle vs leaf size.
MAX_STRADDLE_SHARE = 0.25
MAX_CHILD_SHARE = 0.85


def _classify(corners, planes, tol):
    """Side codes of each corner set against each candidate plane.

    corners : (P, 3, 3) float64; planes : (P, K, 4) float64 (n, d)
    returns : front (P, K) bool (all corners on the n.x + d >= -tol side), back (P, K) bool
              (all corners <= tol and not front); neither = straddles
    """
    dist = np.einsum("pvc,pkc->pkv", corners, planes[..., :3]) + planes[..., 3:4]
    front = (dist >= -tol).all(axis=2)
    back = (dist <= tol).all(axis=2) & ~front
    return front, back


def side_counts(corners, owner, counts, planes, tol):
    """Front-only and back-only reference counts of every node against each of its K planes.

    corners : (R, 3, 3) float64 corners of the references, grouped by node (owner sorted)
    owner   : (R,) int64 node (0..n-1) of each reference, non-decreasing
    counts  : (n,) int64 references per node (>= 1 each, bincount of owner)
    planes  : (n, K, 4) float64 candidate planes (unit n, d) of each node
    returns : front (n, K) int64, back (n, K) int64 as _classify counts them (straddlers =
              counts - front - back)

    References are packed into fixed-size blocks of one node each (NaN padding classifies as
    neither side), so one batched (block x 3) @ (3 x K) product replaces a per-reference plane
    gather; batches bound the memory to SCORE_BATCH distances.
    """
    n, k = planes.shape[:2]
    total = len(owner)
    block = int(np.clip(2 ** np.floor(np.log2(max(total / max(n, 1) / 2, 1))), 4, 512))
    nblocks = -(-counts // block)
    block_first = np.cumsum(nblocks) - nblocks
    node_first = np.cumsum(counts) - counts
    rank = np.arange(total) - node_first[owner]
    slot_block = block_first[owner] + rank // block
    padded = np.full((int(nblocks.sum()), block, 3, 3), np.nan)
    padded[slot_block, rank % block] = corners
    block_node = np.repeat(np.arange(n), nblocks)
    normals_t = np.ascontiguousarray(planes[..., :3].transpose(0, 2, 1))  # (n, 3, K)
    low = -planes[..., 3] - tol  # front: n.c >= low for every corner
    high = -planes[..., 3] + tol  # back: n.c <= high for every corner
    front_b = np.empty((len(block_node), k), dtype=np.int64)
    back_b = np.empty_like(front_b)
    step = max(1, SCORE_BATCH // (block * 3 * k))
    for s in range(0, len(block_node), step):
        nodes = block_node[s:s + step]
        dist = (padded[s:s + step].reshape(len(nodes), block * 3, 3) @ normals_t[nodes])
        dist = dist.reshape(len(nodes), block, 3, k)
        lo = np.minimum(np.minimum(dist[:, :, 0], dist[:, :, 1]), dist[:, :, 2])
        hi = np.maximum(np.maximum(dist[:, :, 0], dist[:, :, 1]), dist[:, :, 2])
        front = lo >= low[nodes][:, None, :]
        back = (hi <= high[nodes][:, None, :]) & ~front
        front_b[s:s + step] = front.sum(axis=1)
        back_b[s:s + step] = back.sum(axis=1)
    return (np.add.reduceat(front_b, block_first, axis=0),
            np.add.reduceat(back_b, block_first, axis=0))


def choose(front, back, counts, rule, balance, straddle_weight, min_leaf):
    """Index of the chosen candidate per node, -1 to stay a leaf.

    front, back : (n, K) int64 side counts (side_counts); counts : (n,) int64
    rule        : "thesis" (only 0.8 <= h+/h- <= 1.25 splits) or "balanced" (see module doc)
    min_leaf    : smallest child of a balanced split
    returns     : (n,) int64 in -1..K-1; lowest score |h+ - h-| + straddle_weight * straddlers
                  wins, ties to the lowest index
    """
    m = counts[:, None]
    straddle = m - front - back
    hp, hm = m - back, m - front
    separates = (front > 0) & (back > 0)  # both children smaller than the node
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = hp / hm
    in_range = separates & (ratio >= balance[0]) & (ratio <= balance[1])
    score = np.abs(hp - hm) + float(straddle_weight) * straddle
    if rule == "thesis":
        usable = in_range
    else:
        big = ((np.minimum(hp, hm) >= min_leaf) & (straddle <= MAX_STRADDLE_SHARE * m)
               & (np.maximum(hp, hm) <= MAX_CHILD_SHARE * m))
        usable = np.where((in_range & big).any(axis=1, keepdims=True), in_range & big,
                          separates & big)
    score = np.where(usable, score, np.inf)
    best = np.argmin(score, axis=1)
    return np.where(np.isfinite(score[np.arange(len(best)), best]), best, -1)


def build(world, min_leaf=8, max_depth=32, candidates=64, balance=(0.8, 1.25),
          straddle_weight=2.0, seed=0, rule="balanced", progress=None):
    """BSP tree; front child = first_child (n.x + d >= 0), back child = first_child + 1.

    min_leaf        : nodes with at most this many references stay leaves; "balanced" also
                      keeps at least this many in each child of a split
    max_depth       : deepest level
    candidates      : triangle planes sampled per node (seeded, with replacement)
    balance         : (low, high) h+/h- range of a balanced split
    straddle_weight : score = |h+ - h-| + straddle_weight * straddlers, lowest wins
    rule            : "balanced" (default) or "thesis" (stop when no candidate is in range)
    returns         : Partition; extras split_planes (N, 4) float64 (NaN rows for leaves),
                      node_bounds = AABB of the subtree's referenced triangles
    """
    if not 1 <= int(candidates) <= MAX_CANDIDATES:
        raise ValueError(f"BSP candidates must be from 1 to {MAX_CANDIDATES:,}, got {candidates}")
    if int(min_leaf) < 1 or int(max_depth) < 0 or int(candidates) < 1:
        raise ValueError("min_leaf and candidates must be >= 1 and max_depth >= 0")
    if rule not in RULES:
        raise ValueError(f"unknown BSP rule {rule!r}; expected one of {', '.join(RULES)}")
    low_ratio, high_ratio = float(balance[0]), float(balance[1])
    rng = np.random.default_rng(int(seed))
    corners_all = world.corners
    normals = world.normals
    plane_d = -np.einsum("tc,tc->t", normals, corners_all[:, 0])
    tol = PLANE_TOLERANCE * max(float(np.ptp(world.extent, axis=0).max()), 1e-300)

    parent = [np.array([-1])]
    plane_of = [np.full(1, -1)]
    next_id = 1
    pair_node = np.zeros(world.triangle_count, dtype=np.int64)
    pair_tri = np.arange(world.triangle_count, dtype=np.int64)
    leaf_node, leaf_tri = [], []
    for depth in range(int(max_depth) + 1):
        if not len(pair_node):
            break
        nodes, start, count = np.unique(pair_node, return_index=True, return_counts=True)
        split_ok = (count > int(min_leaf)) & (depth < int(max_depth))
        chosen = np.full(len(nodes), -1, dtype=np.int64)
        if split_ok.any():
            idx = np.flatnonzero(split_ok)
            k = int(candidates)
            pick = start[idx, None] + (rng.random((len(idx), k)) * count[idx, None]).astype(np.int64)
            cand_tri = pair_tri[pick]  # (n, K)
            planes = np.concatenate([normals[cand_tri], plane_d[cand_tri][..., None]], axis=2)
            local = np.full(len(nodes), -1, dtype=np.int64)
            local[idx] = np.arange(len(idx))
            in_split = local[np.searchsorted(nodes, pair_node)]
            sel = np.flatnonzero(in_split >= 0)
            front, back = side_counts(corners_all[pair_tri[sel]], in_split[sel], count[idx],
                                      planes, tol)
            best = choose(front, back, count[idx], rule, (low_ratio, high_ratio),
                          straddle_weight, int(min_leaf))
            has = best >= 0
            chosen[idx[has]] = cand_tri[has, best[has]]
        # Leaves: every node of this level without a chosen plane.
        is_leaf = chosen[np.searchsorted(nodes, pair_node)] < 0
        leaf_node.append(pair_node[is_leaf])
        leaf_tri.append(pair_tri[is_leaf])
        split_nodes = nodes[chosen >= 0]
        if not len(split_nodes):
            break
        plane_tri = chosen[chosen >= 0]
        plane_of_node = np.full(next_id, -1, dtype=np.int64)
        plane_of_node[split_nodes] = plane_tri
        plane_of.append(plane_of_node)
        # Children: front = base + 2i, back = base + 2i + 1, in the order of split_nodes.
        rank = np.full(next_id, -1, dtype=np.int64)
        rank[split_nodes] = np.arange(len(split_nodes))
        base = next_id
        parent.append(np.repeat(split_nodes, 2))
        next_id += 2 * len(split_nodes)
        pn, pt = pair_node[~is_leaf], pair_tri[~is_leaf]
        ptri = plane_of_node[pn]
        planes = np.concatenate([normals[ptri], plane_d[ptri][:, None]], axis=1)[:, None, :]
        front = np.empty(len(pn), dtype=bool)
        back = np.empty(len(pn), dtype=bool)
        for s in range(0, len(pn), CHUNK):
            f, b = _classify(corners_all[pt[s:s + CHUNK]], planes[s:s + CHUNK], tol)
            front[s:s + CHUNK], back[s:s + CHUNK] = f[:, 0], b[:, 0]
        child = base + 2 * rank[pn]
        to_front, to_back = ~back, ~front  # straddlers go both ways
        pair_node = np.concatenate([child[to_front], child[to_back] + 1])
        pair_tri = np.concatenate([pt[to_front], pt[to_back]])
        order = np.lexsort((pair_tri, pair_node))
        pair_node, pair_tri = pair_node[order], pair_tri[order]
        check_references(len(pair_node), f"BSP level {depth + 1}")
        if progress is not None:
            progress(depth + 1, int(max_depth) + 1)
    parent = np.concatenate(parent)
    plane_tri = np.full(len(parent), -1, dtype=np.int64)
    for p in plane_of:
        plane_tri[:len(p)] = np.maximum(plane_tri[:len(p)], p)
    split = np.full((len(parent), 4), np.nan)
    inner = plane_tri >= 0
    split[inner, :3] = normals[plane_tri[inner]]
    split[inner, 3] = plane_d[plane_tri[inner]]
    params = {"min_leaf": int(min_leaf), "max_depth": int(max_depth),
              "candidates": int(candidates), "balance": [low_ratio, high_ratio],
              "straddle_weight": float(straddle_weight), "seed": int(seed), "rule": rule}
    result, _ = make_partition("bsp", params, world, parent, np.concatenate(leaf_node),
                               np.concatenate(leaf_tri), None,
                               node_extras={"split_planes": split})
    return result


def front_to_back(partition, eye) -> np.ndarray:
    """(K,) int64 leaf node ids ordered front to back from eye: near side of each split first.

    eye : (3,) float64 viewpoint; a leaf straddled by the eye's plane keeps its tree position
    """
    eye = np.asarray(eye, dtype=np.float64)
    planes = partition.extras["split_planes"]
    first, count = partition.first_child, partition.child_count
    order = np.zeros(1, dtype=np.int64)
    while True:
        inner = count[order] > 0
        if not inner.any():
            return order
        side = planes[order, :3] @ eye + planes[order, 3] >= 0
        near = np.where(side, first[order], first[order] + 1)
        far = np.where(side, first[order] + 1, first[order])
        reps = np.where(inner, 2, 1)
        expanded = np.repeat(order, reps)
        slot = np.arange(len(expanded)) - np.repeat(np.cumsum(reps) - reps, reps)
        src = np.repeat(np.arange(len(order)), reps)
        expanded = np.where(~inner[src], expanded, np.where(slot == 0, near[src], far[src]))
        order = expanded

"""BSP tree (thesis §4.4): split planes are the world's own triangle planes, chosen for balance;
a node stays a leaf when no sampled plane gives 0.8 <= h+/h- <= 1.25; straddlers are referenced
on both sides, never split. Built level by level, all nodes of a level at once."""
from __future__ import annotations

import numpy as np

from .layout import make_partition

DEFAULTS = {"min_leaf": 8, "max_depth": 24, "candidates": 16, "balance": (0.8, 1.25),
            "straddle_weight": 1.0, "seed": 0}
# Corners within this fraction of the world's size of a plane count as on it.
PLANE_TOLERANCE = 1e-7
CHUNK = 1 << 16


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


def build(world, min_leaf=8, max_depth=24, candidates=16, balance=(0.8, 1.25),
          straddle_weight=1.0, seed=0, progress=None):
    """BSP tree; front child = first_child (n.x + d >= 0), back child = first_child + 1.

    min_leaf        : nodes with at most this many references stay leaves
    max_depth       : deepest level
    candidates      : triangle planes sampled per node (seeded)
    balance         : (low, high) allowed h+/h- of a split
    straddle_weight : score = |h+ - h-| + straddle_weight * straddlers, lowest wins
    returns         : Partition; extras split_planes (N, 4) float64 (NaN rows for leaves),
                      node_bounds = AABB of the subtree's referenced triangles
    """
    if int(min_leaf) < 1 or int(max_depth) < 0 or int(candidates) < 1:
        raise ValueError("min_leaf and candidates must be >= 1 and max_depth >= 0")
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
            hp = np.zeros((len(idx), k), dtype=np.int64)
            hm = np.zeros_like(hp)
            st = np.zeros_like(hp)
            for s in range(0, len(sel), CHUNK):
                part = sel[s:s + CHUNK]
                front, back = _classify(corners_all[pair_tri[part]], planes[in_split[part]], tol)
                straddle = ~front & ~back
                owner = in_split[part]
                np.add.at(hp, owner, (front | straddle).astype(np.int64))
                np.add.at(hm, owner, (back | straddle).astype(np.int64))
                np.add.at(st, owner, straddle.astype(np.int64))
            m = count[idx, None]
            with np.errstate(divide="ignore", invalid="ignore"):
                ratio = hp / hm
            valid = (hp > 0) & (hm > 0) & (hp < m) & (hm < m) & (ratio >= low_ratio) & (ratio <= high_ratio)
            score = np.where(valid, np.abs(hp - hm) + float(straddle_weight) * st, np.inf)
            best = np.argmin(score, axis=1)
            has = np.isfinite(score[np.arange(len(idx)), best])
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
              "straddle_weight": float(straddle_weight), "seed": int(seed)}
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

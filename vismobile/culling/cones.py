"""`cone`: per-leaf normal cones with meshoptimizer's apex test (see geometry/cones.py).

Leaves of a spatial partition mix triangles facing every way, so a leaf's single cone is often
too wide to cull. With clusters="octant" each leaf's references are grouped by the octant of
their normal (signs of x, y, z), giving up to 8 tighter cones per leaf; a cluster that tests
back-facing drops its triangles (the proof is per triangle, so the drop holds in every leaf).
"""
from __future__ import annotations

import numpy as np

from ..geometry.cones import cluster_cones, cone_rounding, cones_backfacing
from ..world.mapped import triangle_corners
from ..partition.base import gather_ranges
from ..world.world import unit_normals
from .facing import keep_unmarked
from .precision import device_move, world_scale
from .shared import per_object
from .state import CullState
from .tree import Tree

GROUPS = {"leaf": 1, "octant": 8}
# References per group of leaves when prepare builds the cones (bounds its memory).
CHUNK = 1 << 18


def leaf_groups(counts, size: int):
    """Yield (lo, hi) ranges of consecutive leaves whose reference counts sum to about `size`
    (a leaf with more stays alone in its group); together they cover every leaf once."""
    ends = np.cumsum(counts)
    lo = 0
    while lo < len(counts):
        base = ends[lo - 1] if lo else 0
        hi = max(lo + 1, int(np.searchsorted(ends, base + size, side="right")))
        yield lo, hi
        lo = hi


class NormalConeStage:
    """`cone`: precomputed (apex, axis, cutoff) per leaf cluster; drops back-facing clusters.

    clusters : "leaf" (one cone per leaf) or "octant" (one per leaf and normal octant)
    Contract: never drops a triangle that faces the eye (margins 1e-9 relative, see
    geometry.cones), wherever it is, also after the device moves corners and eye by
    device_move(arithmetic); whole leaves go when all their clusters are back-facing.
    """

    name = "cone"
    cost = 30
    arithmetic = "float64"  # the Culler sets its mode: the device-rounding margin follows it

    def __init__(self, clusters: str = "octant"):
        if clusters not in GROUPS:
            raise ValueError(f"cone clusters must be one of {sorted(GROUPS)}, got {clusters!r}")
        self.clusters = clusters

    def prepare(self, tree: Tree) -> None:
        self.tree = tree
        self.per_leaf = GROUPS[self.clusters]
        (self.cluster_refs, self.apex, self.axis, self.cutoff, self.rounding, self.starts,
         self.ends) = per_object(tree.partition, ("cones", self.clusters),
                                 lambda: leaf_cones(tree, self.per_leaf))
        self.magnitude = world_scale(tree.world.vertices)
        self._bits = np.zeros(tree.world.triangle_count // 64 + 1, dtype=np.uint64)

    def apply(self, state: CullState) -> None:
        tree, k = self.tree, self.per_leaf
        ranks = tree.leaves_under(state.nodes)
        clusters = (ranks[:, None] * k + np.arange(k)).ravel()
        clusters = clusters[self.ends[clusters] > self.starts[clusters]]
        eye = state.camera.eye
        move = np.sqrt(3.0) * device_move(self.arithmetic,
                                          max(self.magnitude, float(np.abs(eye).max())))
        back = cones_backfacing(self.apex[clusters], self.axis[clusters], self.cutoff[clusters],
                                eye, self.rounding[clusters], move)
        state.count(f"{self.name}.clusters_tested", len(clusters))
        state.count(f"{self.name}.clusters_culled", back.sum())
        # Leaves with a front (or unknown) cluster stay; the rest go whole.
        front_leaf = np.zeros(len(tree.leaf_order), dtype=bool)
        front_leaf[clusters[~back] // k] = True
        kept = ranks[front_leaf[ranks]]
        state.count(f"{self.name}.leaves_culled", len(ranks) - len(kept))
        state.nodes = tree.leaf_order[kept]
        culled = clusters[back]
        if k > 1 and len(culled):
            def keep_of(ids):
                return keep_unmarked(np.ascontiguousarray(ids, dtype=np.int64), self.cluster_refs,
                                     self.starts, self.ends, culled, self._bits)

            state.filters.append(keep_of)


def leaf_cones(tree: Tree, k: int) -> tuple:
    """(cluster_refs (R,) triangle ids grouped by (leaf rank, octant), apex, axis (C, 3), cutoff
    (C,), rounding (C, 5), starts, ends (C,)): cluster c of k per leaf (leaf_order) holds
    cluster_refs[starts[c]:ends[c]]. Built in groups of consecutive leaves of about CHUNK
    references: a cluster never spans leaves, so each group's cones are those of the whole,
    and only a group's corners and normals are in memory at once (a memory-mapped world is
    read group by group)."""
    world = tree.world
    leaves = tree.leaf_order
    counts = tree.ref_end[leaves] - tree.ref_start[leaves]
    total = int(counts.sum())
    wide = world.triangle_count > np.iinfo(np.int32).max
    cluster_refs = np.empty(total, dtype=np.int64 if wide else np.int32)
    bounds = np.zeros(len(leaves) * k + 1, dtype=np.int64)
    apex, axis = np.zeros((len(leaves) * k, 3)), np.zeros((len(leaves) * k, 3))
    cutoff, rounding = np.zeros(len(leaves) * k), np.zeros((len(leaves) * k, 5))
    done = 0
    for lo, hi in leaf_groups(counts, CHUNK):
        group = leaves[lo:hi]
        ids = gather_ranges(tree.tri_refs, tree.ref_start[group],
                            tree.ref_end[group]).astype(np.int64)
        corners = triangle_corners(world, ids)
        normals, _ = unit_normals(corners)
        rank = np.repeat(np.arange(hi - lo), counts[lo:hi])
        if k == 8:
            octant = (normals[:, 0] > 0) * 1 + (normals[:, 1] > 0) * 2 + (normals[:, 2] > 0) * 4
        else:
            octant = np.zeros(len(ids), dtype=np.int64)
        key = rank * k + octant
        order = np.argsort(key, kind="stable")
        normals, corners = normals[order], corners[order]
        local = np.searchsorted(key[order], np.arange((hi - lo) * k + 1))
        starts, ends = local[:-1], local[1:]
        rows = slice(lo * k, hi * k)
        apex[rows], axis[rows], cutoff[rows] = cluster_cones(normals, corners, starts, ends,
                                                             scale=tree.scale)
        rounding[rows] = cone_rounding(normals, corners, apex[rows], starts, ends)
        cluster_refs[done:done + len(ids)] = ids[order]
        bounds[lo * k + 1:hi * k + 1] = done + ends
        done += len(ids)
    return cluster_refs, apex, axis, cutoff, rounding, bounds[:-1], bounds[1:]

"""`cone`: per-leaf normal cones with meshoptimizer's apex test (see geometry/cones.py).

Leaves of a spatial partition mix triangles facing every way, so a leaf's single cone is often
too wide to cull. With clusters="octant" each leaf's references are grouped by the octant of
their normal (signs of x, y, z), giving up to 8 tighter cones per leaf; a cluster that tests
back-facing drops its triangles (the proof is per triangle, so the drop holds in every leaf).
"""
from __future__ import annotations

import numpy as np

from ..geometry.cones import cluster_cones, cone_rounding, cones_backfacing
from ..partition.base import gather_ranges
from .precision import device_move
from .state import CullState
from .tree import Tree

GROUPS = {"leaf": 1, "octant": 8}


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
        world = tree.world
        k = GROUPS[self.clusters]
        leaves = tree.leaf_order
        counts = tree.ref_end[leaves] - tree.ref_start[leaves]
        positions = gather_ranges(np.arange(len(tree.tri_refs)), tree.ref_start[leaves],
                                  tree.ref_end[leaves])
        ids = tree.tri_refs[positions]
        rank = np.repeat(np.arange(len(leaves)), counts)
        if k == 8:
            n = world.normals[ids]
            octant = (n[:, 0] > 0) * 1 + (n[:, 1] > 0) * 2 + (n[:, 2] > 0) * 4
        else:
            octant = np.zeros(len(ids), dtype=np.int64)
        key = rank * k + octant
        order = np.argsort(key, kind="stable")
        self.cluster_refs = ids[order]  # (R,) triangle ids grouped by (leaf rank, octant)
        bounds = np.searchsorted(key[order], np.arange(len(leaves) * k + 1))
        self.starts, self.ends = bounds[:-1], bounds[1:]
        self.per_leaf = k
        self.apex, self.axis, self.cutoff = cluster_cones(
            world.normals[self.cluster_refs], world.corners[self.cluster_refs],
            self.starts, self.ends, scale=tree.scale)
        self.rounding = cone_rounding(world.normals[self.cluster_refs],
                                      world.corners[self.cluster_refs], self.apex, self.starts,
                                      self.ends)
        self.magnitude = float(np.abs(world.vertices).max()) if world.vertices.size else 0.0

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
            dropped = np.zeros(tree.world.triangle_count, dtype=bool)
            dropped[gather_ranges(self.cluster_refs, self.starts[culled], self.ends[culled])] = True
            state.filters.append(lambda ids: ~dropped[ids])

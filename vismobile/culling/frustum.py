"""View-frustum culling of the partition tree, one tree level per step.

`vfc`: the AABB p-vertex/n-vertex test with plane masking (Assarsson & Moller 2000): each node
carries the planes its parent straddled, nodes wholly inside are accepted whole (their subtree's
ref range), straddling inner nodes are expanded, straddling leaves are accepted.

`vfc_thesis`: the thesis's test (SPEC 2): a node is kept when one of its 8 corners is inside
the frustum, else unless its bounding sphere (centre, r = sqrt(3) * l, l its longest edge) is
outside a plane. The sphere holds the box, so the test is conservative, but loose: a node is
never accepted whole, so every kept node is expanded down to its leaves.
"""
from __future__ import annotations

import numpy as np

from ..geometry.boxes import box_centers, box_corners, box_sizes
from ..geometry.planes import points_inside, spheres_outside
from .state import CullState
from .tree import Tree

# FrustumStage's default: walk to the leaves (the thesis's exact node set).
WHOLE_BELOW = -1


def frustum_traverse(tree: Tree, roots, plane_sets, root_sets, state: CullState,
                     prefix: str, whole_below: int = -1, covering: bool = False) -> np.ndarray:
    """Hierarchical p/n-vertex culling from `roots`: (A,) int64 accepted nodes.

    roots      : (K,) int64 start nodes
    plane_sets : (S, P, 4) float64 inward planes; root k is tested against plane_sets[root_sets[k]]
    root_sets  : (K,) int64
    whole_below: a node straddling a plane whose gather reads at most this many references is
                 accepted whole instead of walked (-1: never; see kernels.frustum_walk)
    covering   : a straddling node below which no node would be rejected is accepted whole
                 (the same triangles, fewer nodes; see kernels.inner_records)
    Errs toward keeping by tree.tol (never rejects a box touching the frustum).
    Counts nodes_visited, plane_tests and <prefix>.nodes_culled/.nodes_accepted in state,
    <prefix>.nodes_straddling (inner nodes accepted whole across a plane) when whole_below >= 0
    and <prefix>.nodes_covered (accepted by their cover) when covering.
    """
    result, visited, tests, culled, straddling, covered = tree.walk(
        roots, root_sets, plane_sets, whole_below, covering)
    state.count("nodes_visited", visited)
    state.count("plane_tests", tests)
    state.count(f"{prefix}.nodes_culled", culled)
    state.count(f"{prefix}.nodes_accepted", len(result))
    if whole_below >= 0:
        state.count(f"{prefix}.nodes_straddling", straddling)
    if covering:
        state.count(f"{prefix}.nodes_covered", covered)
    return result


def frustum_refine(tree: Tree, state: CullState, prefix: str, whole_below: int = -1,
                   covering: bool = False) -> np.ndarray:
    """(A,) int64 nodes: state.nodes culled against the camera frustum state.planes (see
    frustum_traverse)."""
    roots = state.nodes
    return frustum_traverse(tree, roots, state.planes[None], np.zeros(len(roots), dtype=np.int64),
                            state, prefix, whole_below, covering)


class FrustumStage:
    """`vfc`: hierarchical AABB frustum culling with plane masks; refines state.nodes.

    whole_below : a node straddling a frustum plane whose gather reads at most this many
               references (Tree.read_size) is accepted whole rather than walked down (-1:
               walk to the leaves, the default). Conservative: it sends a superset. At 64 the
               tiled W2 (5.0 M triangles, octree 8) visits 6x fewer nodes for 0.8% more
               triangles; W2 itself (octree 5) 6.5x fewer for 3.5% more.
    cover    : accept whole a straddling node below which no node would be rejected (its
               cover: kernels.inner_records), instead of walking it to the leaves the walk
               would accept anyway: the same triangles from fewer nodes (on by default). Used
               only when no later node stage tests vfc's nodes (Culler._cover sets covering)
    deferred : set by the Culler when the next node stage (`occlusion`) tests the frustum in its
               own walk (Culler._fuse): apply then only marks state.frustum_pending
    absorbed : set by the Culler when `pvs` walks the frustum in its own compiled call
               (Culler._fuse, culling/pvs_frame.py): apply then does nothing
    """

    name = "vfc"
    cost = 10
    deferred = False
    absorbed = False

    def __init__(self, whole_below: int = WHOLE_BELOW, cover: bool = True):
        if isinstance(whole_below, bool) or not isinstance(whole_below, (int, np.integer)) \
                or whole_below < -1:
            raise ValueError(f"vfc whole_below must be an integer >= -1, got {whole_below!r}")
        if not isinstance(cover, (bool, np.bool_)):
            raise ValueError(f"vfc cover must be True or False, got {cover!r}")
        self.whole_below = int(whole_below)
        self.cover = self.covering = bool(cover)

    def prepare(self, tree: Tree) -> None:
        self.tree = tree

    def apply(self, state: CullState) -> None:
        if self.deferred:
            state.frustum_pending = True
            return
        if not self.absorbed:
            self.walk(state)

    def walk(self, state: CullState) -> None:
        """The walk itself: state.nodes culled against the frustum."""
        state.nodes = frustum_refine(self.tree, state, self.name, self.whole_below,
                                     self.covering)


class ThesisFrustumStage:
    """`vfc_thesis`: the thesis's 8-corner test, then the r = sqrt(3) l sphere; refines state.nodes.

    Conservative (the sphere contains the box) but accepts nothing whole: kept nodes are
    expanded to their leaves. Counts 6 plane tests per corner and per sphere, as the thesis does.
    """

    name = "vfc_thesis"
    cost = 11

    def prepare(self, tree: Tree) -> None:
        self.tree = tree
        bounds = tree.node_bounds
        self.corners = box_corners(bounds)
        self.centers = box_centers(bounds)
        self.radii = np.sqrt(3.0) * box_sizes(bounds).max(axis=1)

    def apply(self, state: CullState) -> None:
        tree, planes = self.tree, state.planes
        active = state.nodes
        accepted, visited, tests, culled = [], 0, 0, 0
        while len(active):
            active = active[tree.nonempty[active]]
            if not len(active):
                break
            corner_in = points_inside(self.corners[active].reshape(-1, 3), planes, tree.tol)
            corner_in = corner_in.reshape(-1, 8).any(axis=1)
            sphere_out = spheres_outside(self.centers[active], self.radii[active], planes, tree.tol)
            keep = corner_in | ~sphere_out
            visited += len(active)
            tests += 6 * 8 * len(active) + 6 * int((~corner_in).sum())
            culled += int((~keep).sum())
            leaf = tree.child_count[active] == 0
            accepted.append(active[keep & leaf])
            active, _ = tree.children(active[keep & ~leaf])
        state.nodes = np.concatenate(accepted) if accepted else np.zeros(0, dtype=np.int64)
        state.count("nodes_visited", visited)
        state.count("plane_tests", tests)
        state.count(f"{self.name}.nodes_culled", culled)
        state.count(f"{self.name}.nodes_accepted", len(state.nodes))

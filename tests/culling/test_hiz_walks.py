"""The tiled depth buffer's node walks (culling/hiz/walks.py) under a budget: the fused walk
keeps the nodes it would expand once past its budget (deferred, never dropped), cull_nodes
from them against the same buffer keeps exactly what the unbounded walk keeps, and the stage
refines deferred nodes after its rounds without dropping anything the item buffer shows."""
from pathlib import Path

import numpy as np

from vismobile.culling import Culler
from vismobile.culling import occlusion_tests
from vismobile.culling.hiz import cull_nodes, frustum_cull_nodes
from vismobile.culling.hiz.walks import NO_BUDGET, walk_child_counts
from vismobile.culling.occlusion import ZBUFFER_MARGIN, DepthBufferOcclusion
from vismobile.partition import partition
from vismobile.world.trajectory import Trajectory

TRAJECTORY = Path(__file__).resolve().parents[2] / "trajectories" / "indoor.csv"


def fused_walk(stage, camera, budget):
    """(kept nodes, visited, deferred) of frustum_cull_nodes from the root over the stage's
    current buffer, with the arguments occlusion._node_pass gives it."""
    tree = stage.tree
    eye, rotation, tx, ty, move = stage._view(camera)[:5]
    margin, recede = ZBUFFER_MARGIN / camera.near, np.sqrt(3.0) * move
    size = tree.node_count + 64
    out, stack, masks = (np.empty(size, dtype=np.int64) for _ in range(3))
    kept, visited, *_, deferred = frustum_cull_nodes(
        tree.lo, tree.hi, tree.first_child, tree.child_count, tree.nonempty,
        np.zeros(1, dtype=np.int64), np.ascontiguousarray(stage._planes), tree.tol, eye,
        rotation, camera.near, tx, ty, stage.width, stage.height, move,
        stage.shift(camera, move), margin, recede, stage.depth, stage.tile_max, stage.tile_any,
        stage.tile_shift, *stage.tile, out, stack, masks, stage.nearest_far(margin, recede),
        *stage.samples(camera, move), budget)
    return out[:kept].copy(), visited, deferred


def refine(stage, camera, nodes):
    """cull_nodes from `nodes` themselves (from_root False) over the same buffer."""
    tree = stage.tree
    eye, rotation, tx, ty, move = stage._view(camera)[:5]
    margin, recede = ZBUFFER_MARGIN / camera.near, np.sqrt(3.0) * move
    size = tree.node_count + len(nodes) + 64
    out, stack = np.empty(size, dtype=np.int64), np.empty(size, dtype=np.int64)
    below = np.empty(size, dtype=np.uint8)
    marks = [np.full(tree.node_count, -1, dtype=np.int64) for _ in range(2)]
    kept, _, _ = cull_nodes(
        tree.lo, tree.hi, tree.first_child, tree.child_count, tree.nonempty, stage.parent,
        nodes, *marks, 1, eye, rotation, camera.near, tx, ty, stage.width, stage.height, move,
        stage.shift(camera, move), margin, recede, stage.depth, stage.tile_max, stage.tile_any,
        stage.tile_shift, *stage.tile, out, stack, below, stage.nearest_far(margin, recede),
        False, *stage.samples(camera, move))
    return out[:kept].copy()


def test_a_budgeted_walk_defers_and_the_refinement_keeps_what_the_unbounded_walk_keeps(kit):
    # Past its budget the fused walk keeps the nodes it would have expanded; cull_nodes over
    # them against the same buffer makes the same tests, so it keeps the same set of nodes.
    world = kit.world("w2")
    part = partition(world, "octree", depth=5)
    culler = Culler(part, "vfc,occlusion,tbfc", occlusion={"screen": (240, 320)})
    stage = culler.stages[1]
    traj = Trajectory.load(TRAJECTORY)
    checked = 0
    for f in (300, 310, 700, 1100):  # (frame 60: the walk expands only straddling nodes)
        camera = traj.camera(f, kit.ASPECT)
        culler.cull(camera)  # the stage's buffer and planes for this camera
        whole, visited_all, none = fused_walk(stage, camera, NO_BUDGET)
        assert none == 0
        assert fused_walk(stage, camera, visited_all)[2] == 0  # never past it
        for budget in (0, 16, visited_all // 3):
            nodes, visited, deferred = fused_walk(stage, camera, budget)
            assert deferred > 0 and visited < visited_all, (f, budget)
            assert np.array_equal(np.sort(refine(stage, camera, nodes)), np.sort(whole)), f
            checked += 1
    assert checked == 12


def test_the_stage_refines_deferred_nodes_and_drops_nothing_visible(kit, monkeypatch):
    # The stage's Python path with a tiny budget: the fused walk defers most of the tree, the
    # rounds' occluders come from the deferred nodes, and the nodes are refined after them (also
    # when no round follows); every triangle the item buffer shows is still sent.
    world = kit.world("w2")
    part = partition(world, "octree", depth=5)
    traj = Trajectory.load(TRAJECTORY)
    cullers = {}
    for name, options in (("two rounds", {}), ("one round", {"rounds": 1}),
                          ("screen", {"screen": (240, 320)})):
        for budget in (None, 8):
            culler = Culler(part, "vfc,occlusion,tbfc", occlusion=options)
            culler._chained = None  # stage by stage
            culler.stages[1].compiled = False
            cullers[name, budget] = culler
    visited = {key: 0 for key in cullers}
    for f in range(300, 330, 3):
        camera = traj.camera(f, kit.ASPECT)
        visible = kit.visible_ids(world, camera, True)
        for (name, budget), culler in cullers.items():
            with monkeypatch.context() as patch:
                if budget is not None:
                    patch.setattr(occlusion_tests, "WALK_BUDGET", budget)
                result = culler.cull(camera)
            missing = np.setdiff1d(visible, result.triangles)
            assert not len(missing), (f, name, budget, missing[:5])
            visited[name, budget] += result.stats["nodes_visited"]
    # one round: no budget (nothing would refine with a fuller buffer), the same walk
    assert visited["one round", 8] == visited["one round", None]
    assert visited["two rounds", 8] != visited["two rounds", None]
    assert visited["screen", 8] != visited["screen", None]


def test_small_subtrees_are_walked_whole_and_nothing_visible_is_dropped(kit, monkeypatch):
    # walk_child_counts makes a subtree of at most whole_refs references a leaf for the walks:
    # the stage visits fewer nodes, keeps such subtrees whole (their triangles go to the
    # triangle tests) and still sends every triangle the item buffer shows.
    world = kit.world("w2")
    part = partition(world, "octree", depth=5)
    traj = Trajectory.load(TRAJECTORY)
    cullers = {}
    for whole in (0, 32):
        monkeypatch.setattr(DepthBufferOcclusion, "whole_refs", whole)
        cullers[whole] = Culler(part, "vfc,occlusion,tbfc", occlusion={"screen": (240, 320)})
    tree, stage = cullers[32].tree, cullers[32].stages[1]
    refs = tree.ref_end - tree.ref_start
    small = (refs <= 32) & (tree.child_count > 0)
    assert small.any() and np.array_equal(cullers[0].stages[1].walk_children, tree.child_count)
    assert np.array_equal(stage.walk_children, np.where(refs <= 32, 0, tree.child_count))
    assert np.array_equal(walk_child_counts(tree.child_count, tree.ref_start, tree.ref_end, 0),
                          tree.child_count)
    visited = {whole: 0 for whole in cullers}
    whole_kept = 0
    for f in range(300, 340, 4):
        camera = traj.camera(f, kit.ASPECT)
        visible = kit.visible_ids(world, camera, True)
        for whole, culler in cullers.items():
            result = culler.cull(camera)
            missing = np.setdiff1d(visible, result.triangles)
            assert not len(missing), (f, whole, missing[:5])
            visited[whole] += result.stats["nodes_visited"]
            if whole:
                whole_kept += int(small[result.nodes].sum())
    assert visited[32] < 0.8 * visited[0], visited
    assert whole_kept > 0


def test_the_compiled_frame_defers_at_its_budget_and_drops_nothing_visible(kit):
    # W2 at octree 5 is the smallest world with frames visiting more than hiz.frame.WALK_BUDGET
    # (1,024) nodes: there the compiled frame (the Culler's usual path) may keep nodes whole for
    # the refinement after the rounds; it sends what the stage-by-stage path sends (the same
    # budget) and drops nothing.
    from vismobile.culling.hiz.frame import WALK_BUDGET

    world = kit.world("w2")
    part = partition(world, "octree", depth=5)
    traj = Trajectory.load(TRAJECTORY)
    compiled = Culler(part, "vfc,occlusion,tbfc", occlusion={"screen": (240, 320)})
    staged = Culler(part, "vfc,occlusion,tbfc", occlusion={"screen": (240, 320)})
    staged._chained = None
    staged.stages[1].compiled = False
    over = 0
    for f in range(300, 345, 3):
        camera = traj.camera(f, kit.ASPECT)
        visible = kit.visible_ids(world, camera, True)
        result = compiled.cull(camera)
        assert np.array_equal(result.triangles, staged.cull(camera).triangles), f
        missing = np.setdiff1d(visible, result.triangles)
        assert not len(missing), (f, missing[:5])
        over += result.stats["nodes_visited"] > WALK_BUDGET
    assert over > 0

"""`occlusion` (union depth buffer) and `occlusion_thesis` on literal scenes: a wall made of
quads with T-junctions around a door hides what is behind it, keeps what shows through the
door, never drops what the item buffer shows; the thesis stage skips grazing occluders."""
import numpy as np
import pytest

from vismobile.world.camera import Camera
from vismobile.culling import Culler
from vismobile.partition import partition


def wall_scene(kit):
    """A wall at z = -5 with a door [-0.5, 0.5] x [-1, 0.5] (4 quads meeting in T-junctions),
    a floor at y = -1 creasing with it, a patch behind the wall, a patch behind the door."""
    q = kit.quad
    parts = [q(-6, 6, 0.5, 4, -5), q(-6, -0.5, -1, 0.5, -5), q(0.5, 6, -1, 0.5, -5),
             q(-6, 6, -1, -5, -5),  # below the floor: completes the wall, hidden anyway
             ]
    floor_v = np.array([[-6.0, -1, -5], [6, -1, -5], [6, -1, 0.5], [-6, -1, 0.5]])
    parts.append((floor_v, np.array([[0, 2, 1], [0, 3, 2]])))  # facing +y
    parts.append(q(2.0, 2.6, -0.9, -0.3, -7))   # hidden behind the wall, near the crease
    parts.append(q(-0.2, 0.2, -0.8, 0.2, -9))   # seen through the door
    return kit.literal_world(parts, "wall")


def test_wall_hides_what_is_behind_and_keeps_the_door_view(kit):
    world = wall_scene(kit)
    part = partition(world, "octree", depth=3)
    cam = Camera((0.0, 0.2, 0.0), yaw=0.0, pitch=0.0, aspect=kit.ASPECT)
    sent = Culler(part, "vfc,occlusion").cull(cam).triangles
    visible = kit.visible_ids(world, cam, False)
    hidden_patch, door_patch = world.object_ids == 5, world.object_ids == 6
    assert not np.isin(np.flatnonzero(hidden_patch), visible).any()
    assert not np.isin(np.flatnonzero(hidden_patch), sent).any()
    assert np.isin(np.flatnonzero(door_patch), sent).all()
    assert np.isin(visible, sent).all()


def test_occlusion_never_drops_visible_triangles_from_many_cameras(kit):
    world = wall_scene(kit)
    part = partition(world, "octree", depth=3)
    rng = np.random.default_rng(5)
    cullers = [Culler(part, s) for s in ("occlusion", "vfc,occlusion", "vfc,occlusion_thesis")]
    cullers.append(Culler(part, "vfc,occlusion", occlusion={"first_reach": 2.0}))
    # the sample buffer (`samples`) at the item buffer's own resolution
    cullers.append(Culler(part, "vfc,occlusion", occlusion={
        "screen": tuple(kit.PROFILE.resolution), "samples": True}))
    for _ in range(12):
        pos = rng.uniform([-4, -0.9, -4.9], [4, 3, 0.4])
        cam = Camera(pos, yaw=rng.uniform(-60, 60), pitch=rng.uniform(-30, 30),
                     aspect=kit.ASPECT)
        visible = kit.visible_ids(world, cam, False)
        for culler in cullers:
            missing = np.setdiff1d(visible, culler.cull(cam).triangles)
            assert not len(missing), (culler.names, cam, missing)


def test_thesis_occlusion_skips_an_occluder_seen_edge_on(kit):
    # The eye 3e-11 off a wall's plane (at a 1e-4 world scale): the wall hides nothing.
    q = kit.quad
    world = kit.literal_world([q(-1e-4, 1e-4, -1e-4, 1e-4, 0.0), q(-2e-5, 2e-5, -2e-5, 2e-5, -3e-4)])
    part = partition(world, "octree", depth=2)
    cam = Camera((5e-5, 0.0, 3e-11), yaw=0.0, pitch=0.0, aspect=kit.ASPECT, near=1e-6, far=1.0)
    culler = Culler(part, "occlusion_thesis")
    culler.cull(cam)  # the first frame records the occluder candidates
    assert not np.isin([0, 1], culler.stages[0].select(cam)).any()  # the wall is skipped
    assert np.isin(kit.visible_ids(world, cam, False), culler.cull(cam).triangles).all()


def cube(x0, x1, y0, y1, z0, z1):
    """(8, 3) vertices and (12, 3) outward-facing triangles of a closed box."""
    v = np.array([[x, y, z] for x in (x0, x1) for y in (y0, y1) for z in (z0, z1)], dtype=float)
    faces = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    t = np.array([[a, b, c] for a, b, c, d in faces] + [[a, c, d] for a, b, c, d in faces])
    centre = v.mean(axis=0)
    n = np.cross(v[t[:, 1]] - v[t[:, 0]], v[t[:, 2]] - v[t[:, 0]])
    flip = np.einsum("ij,ij->i", n, v[t[:, 0]] - centre) < 0
    t[flip] = t[flip][:, ::-1]
    return v, t


def test_objects_near_sides_hide_what_is_behind_them(kit):
    # A floor (the one large occluder allowed), a box on it, a small patch hidden behind the box.
    floor_v = np.array([[-9.0, -1, -20], [9, -1, -20], [9, -1, 5], [-9, -1, 5]])
    parts = [(floor_v, np.array([[0, 2, 1], [0, 3, 2]])), cube(-1, 1, -1, 1, -6, -4),
             kit.quad(-0.3, 0.3, -0.6, 0.2, -8)]
    world = kit.literal_world(parts, "box")
    part = partition(world, "octree", depth=2)
    cam = Camera((0.0, 0.0, 0.0), yaw=0.0, pitch=0.0, aspect=kit.ASPECT)
    options = {"occluders": 1, "candidates": 1}
    alone = Culler(part, "vfc,occlusion", occlusion=options).cull(cam)
    both = Culler(part, "vfc,occlusion", occlusion={**options, "self_occluders": 8}).cull(cam)
    patch = np.flatnonzero(world.object_ids == 2)
    assert np.isin(patch, alone.triangles).all()
    assert not np.isin(patch, both.triangles).any()
    assert 0 < both.stats["occlusion.self_occluders"] <= 8
    assert np.isin(kit.visible_ids(world, cam, False), both.triangles).all()


def test_triangles_between_pixel_centres_are_dropped_only_when_no_centre_is_hit(kit):
    # A grid of tiny, non-overlapping triangles facing the eye: the item buffer shows exactly
    # those that hold a pixel centre; the sample test drops only (some of) the others.
    rng = np.random.default_rng(3)
    parts = []
    for gx in range(-12, 12):
        for gy in range(-12, 12):
            c = np.array([gx * 0.05, gy * 0.05, -4.0]) + rng.uniform(-0.01, 0.01, 3) * [1, 1, 0]
            size = rng.uniform(0.002, 0.02)
            v = c + np.array([[0.0, 0, 0], [size, 0, 0], [0.3 * size, size, 0]])
            parts.append((v, np.array([[0, 1, 2]])))
    world = kit.literal_world(parts, "specks")
    part = partition(world, "octree", depth=2)
    cam = Camera((0.01, 0.02, 0.0), yaw=0.0, pitch=0.0, aspect=kit.ASPECT)
    screen = tuple(kit.PROFILE.resolution)
    result = Culler(part, "vfc,occlusion", occlusion={"screen": screen}).cull(cam)
    visible = kit.visible_ids(world, cam, False)
    assert np.isin(visible, result.triangles).all()
    dropped = world.triangle_count - len(result.triangles)
    assert dropped == result.stats["occlusion.subpixel_culled"] > 50
    assert len(visible) > 50


def test_walls_nearer_than_the_near_plane_hide_nothing(kit):
    # The item buffer sees through a wall closer than near; a wall just beyond near is drawn
    # but too close to the clipping plane to trust: neither may hide the patch behind it.
    q = kit.quad
    for gap in (0.05, 0.1 * (1 + 1e-9), 0.1 * (1 + 1e-5)):
        world = kit.literal_world([q(-3, 3, -3, 3, -gap), q(-0.2, 0.2, -0.2, 0.2, -3.0)])
        part = partition(world, "octree", depth=2)
        cam = Camera((0.0, 0.0, 0.0), yaw=0.0, pitch=0.0, aspect=kit.ASPECT, near=0.1)
        sent = Culler(part, "vfc,occlusion").cull(cam).triangles
        assert np.isin([2, 3], sent).all(), gap
        assert np.isin(kit.visible_ids(world, cam, False), sent).all()
    world = kit.literal_world([q(-3, 3, -3, 3, -0.2), q(-0.2, 0.2, -0.2, 0.2, -3.0)])
    sent = Culler(partition(world, "octree", depth=2), "vfc,occlusion").cull(cam).triangles
    assert not np.isin([2, 3], sent).any()  # a wall safely beyond near does hide it


def test_thesis_occluder_nearer_than_the_near_plane_hides_nothing_there(kit):
    # Issue 17: the eye 0.0957 above a slab's top, looking down steeply with near 0.1: the GPU
    # clips the whole top face, so the item buffer shows the slab's bottom face; the top's
    # shadow volume must not hide it. The occluder is clipped by the near plane first.
    world = kit.literal_world([cube(20, 40, 3, 4, 10, 30)], "slab")
    part = partition(world, "octree", depth=5)
    cam = Camera((28.192, 4.0957, 19.414), yaw=0.0, pitch=-80.0, fov=10.0, aspect=1.0, near=0.1)
    culler = Culler(part, "vfc,occlusion_thesis")
    culler.cull(cam)  # the first frame records the occluder candidates
    visible = kit.visible_ids(world, cam, False)
    bottom = np.flatnonzero(world.normals[:, 1] < -0.5)
    assert np.isin(bottom, visible).any()
    sent = culler.cull(cam).triangles
    assert np.isin(visible, sent).all()
    # A camera well above the slab: the unclipped top still hides nodes holding only bottom.
    high = cam.with_(position=(28.192, 6.0, 19.414))
    culler.cull(high)
    result = culler.cull(high)
    assert result.stats["occlusion_thesis.nodes_culled"] > 0
    assert result.stats["occlusion_thesis.occluders_clipped"] == 0
    assert np.isin(kit.visible_ids(world, high, False), result.triangles).all()


def test_clip_near_keeps_the_part_beyond_the_plane():
    from vismobile.culling.occlusion_thesis import clip_near
    tri = np.array([[0.0, 0, -1], [1, 0, -3], [0, 1, -3]])  # depths 1, 3, 3 looking down -z
    eye, forward = np.zeros(3), np.array([0.0, 0, -1])
    cases = {0.5: 3, 2.0: 4, 2.999: 4, 3.5: 0}  # all, a quad, a thin quad, nothing
    for depth, count in cases.items():
        poly, counts = clip_near(tri[None], eye, forward, depth)
        assert counts[0] == count, depth
        if count:
            assert np.all(poly[0, :count] @ forward >= depth - 1e-12)
    poly, counts = clip_near(tri[None], eye, forward, 2.0)
    assert np.allclose(poly[0], [[0.5, 0, -2], [1, 0, -3], [0, 1, -3], [0, 0.5, -2]])
    assert clip_near(np.zeros((0, 3, 3)), eye, forward, 1.0)[1].shape == (0,)


def test_w2_indoor_frames_keep_everything_the_item_buffer_shows(kit):
    # W2 octree 5 (the benchmarks' tree) at the profile's 240 x 320, sampled indoor frames, with
    # and without the screen option, frames in order so last frame's candidates carry over.
    from pathlib import Path

    from vismobile.world.trajectory import Trajectory

    world = kit.world("w2")
    part = partition(world, "octree", depth=5)
    traj = Trajectory.load(Path(__file__).resolve().parents[2] / "trajectories" / "indoor.csv")
    frames = np.linspace(0, len(traj) - 1, 16).astype(int)
    screen = tuple(kit.PROFILE.resolution)
    assert screen == (240, 320)
    cullers = [Culler(part, "vfc,occlusion,tbfc"),
               Culler(part, "vfc,occlusion,tbfc", occlusion={"screen": screen}),
               Culler(part, "vfc,occlusion,tbfc", occlusion={"first_reach": 15.625}),
               Culler(part, "vfc,occlusion,tbfc", occlusion={"screen": screen, "samples": True})]
    culled = 0
    for f in frames:
        cam = traj.camera(int(f), kit.ASPECT)
        visible = kit.visible_ids(world, cam, True)
        for culler in cullers:
            result = culler.cull(cam)
            missing = np.setdiff1d(visible, result.triangles)
            assert not len(missing), (int(f), culler.stages[1].screen, missing[:5])
            culled += result.stats.get("occlusion.nodes_culled", 0)
    assert culled > 0  # the buffer did hide something


def test_fused_walk_sends_what_the_two_passes_send_and_visits_fewer_nodes(kit, monkeypatch):
    # vfc,occlusion walk the frustum and the buffer in one pass (Culler._fuse) unless occlusion's
    # fuse option is off or another node stage sits between them; same tests, same result.
    # (With small subtrees walked whole, hiz.walks.walk_child_counts, the fused walk tests a
    # whole subtree's box where vfc tests its leaves: equal only at the same granularity.)
    from pathlib import Path

    from vismobile.culling.occlusion import DepthBufferOcclusion
    from vismobile.world.trajectory import Trajectory

    monkeypatch.setattr(DepthBufferOcclusion, "whole_refs", 0)
    world = kit.world("w2")
    part = partition(world, "octree", depth=5)
    fused = Culler(part, "vfc,occlusion,tbfc")
    apart = Culler(part, "vfc,occlusion,tbfc", occlusion={"fuse": False})
    assert fused.stages[0].deferred and not apart.stages[0].deferred
    assert not Culler(part, "vfc,cone,occlusion").stages[0].deferred
    assert not Culler(part, "vfc").stages[0].deferred
    traj = Trajectory.load(Path(__file__).resolve().parents[2] / "trajectories" / "indoor.csv")
    visited = {True: 0, False: 0}
    for f in np.linspace(0, len(traj) - 1, 8).astype(int):
        cam = traj.camera(int(f), kit.ASPECT)
        one, two = fused.cull(cam), apart.cull(cam)
        assert np.array_equal(one.triangles, two.triangles), int(f)
        visited[True] += one.stats["nodes_visited"]
        visited[False] += two.stats["nodes_visited"]
        assert one.stats["plane_tests"] < two.stats["plane_tests"]
    assert visited[True] < visited[False]


def test_the_compiled_frame_decides_as_the_python_path(kit, monkeypatch):
    # hiz.frame.occlusion_frame runs the usual frame in one call; the Python path it mirrors
    # (compiled False) must send the same triangles with the same counters, in every mode; so
    # must the whole frame chained in one call (occlusion_chain.cull_chained: the frame, gather,
    # tbfc, the triangle test and observe's ranking), the Culler's default for these stages.
    from pathlib import Path

    from vismobile.culling import culler as culler_module
    from vismobile.culling.hiz.frame import top_scored
    from vismobile.world.trajectory import Trajectory

    world = kit.world("w2")
    part = partition(world, "octree", depth=5)
    traj = Trajectory.load(Path(__file__).resolve().parents[2] / "trajectories" / "indoor.csv")
    ran, chained = 0, []
    monkeypatch.setattr(culler_module, "cull_chained", lambda *a, run=culler_module.cull_chained:
                        chained.append(run(*a)) or chained[-1])  # (result or None, planes)
    for arithmetic, options in (("float32", {"screen": (240, 320)}), ("fixed16.16", {}),
                                ("float64", {"rounds": 3})):
        whole = Culler(part, "vfc,occlusion,tbfc", arithmetic, occlusion=options)
        compiled = Culler(part, "vfc,occlusion,tbfc", arithmetic, occlusion=options)
        python = Culler(part, "vfc,occlusion,tbfc", arithmetic, occlusion=options)
        assert whole._chained is not None
        compiled._chained = python._chained = None  # stage by stage
        python.stages[1].compiled = False
        calls = []
        compiled.stages[1]._apply_compiled = (
            lambda state, run=compiled.stages[1]._apply_compiled: calls.append(run(state)))
        for f in range(300, 324, 2):  # consecutive frames: last frame's candidates carry over
            cam = traj.camera(f, kit.ASPECT)
            one, two, three = compiled.cull(cam), python.cull(cam), whole.cull(cam)
            for result, culler in ((one, compiled), (three, whole)):
                assert np.array_equal(result.triangles, two.triangles), (arithmetic, f)
                assert np.array_equal(result.nodes, two.nodes), (arithmetic, f)
                assert result.stats == two.stats, (arithmetic, f)
                assert np.array_equal(culler.stages[1].frame_occluders,
                                      python.stages[1].frame_occluders)
                assert np.array_equal(culler.stages[1].history, python.stages[1].history)
        ran += len(calls)
        regular = len(chained)
        # Frames the chained call leaves to the stages: nothing to rasterise (looking up from
        # above the world), a near plane the device cannot order depths at (float32).
        for cam in (traj.camera(300, kit.ASPECT).with_(position=(0.0, 400.0, 0.0), pitch=89.0),
                    traj.camera(310, kit.ASPECT).with_(near=1e-6)):
            one, two, three = compiled.cull(cam), python.cull(cam), whole.cull(cam)
            for result in (one, three):
                assert np.array_equal(result.triangles, two.triangles), arithmetic
                assert result.stats == two.stats, arithmetic
            assert np.array_equal(whole.stages[1].history, python.stages[1].history)
        assert all(r is None for r, _ in chained[regular:])  # both went stage by stage
    assert ran == 36  # the compiled path ran on every frame
    assert len(chained) == 36 + 6 and sum(r is not None for r, _ in chained) == 36
    # top_scored: the best positive scores first, ties in the ids' order, count kept.
    ids = np.array([10, 11, 12, 13, 14, 15], dtype=np.int64)
    score = np.array([0.5, 0.0, 2.0, 0.5, -1.0, 0.5])
    assert top_scored(ids, score, 3).tolist() == [12, 10, 13]
    assert top_scored(ids, score, 9).tolist() == [12, 10, 13, 15]


def test_the_mesh_of_a_few_occluders_pairs_their_edges_as_the_worlds_mesh_does(kit):
    # A mapped world's frames build the rasteriser's tables for their occluders alone: same
    # planes, the same order of plane groups, and the same pieces paired among them.
    from vismobile.culling.occluder_mesh import occluder_mesh
    from vismobile.world.world import unit_normals

    world = kit.world("w2")
    whole = occluder_mesh(world.vertices, world.triangles, world.normals)
    groups, offsets, partner, partner_any = whole[4], whole[3], whole[9], whole[10]
    rng = np.random.default_rng(6)
    paired = 0
    for start in rng.integers(0, world.triangle_count - 400, 5):
        ids = np.concatenate([np.arange(start, start + 300),  # neighbours share edges
                              rng.integers(0, world.triangle_count, 100)])
        ids = np.unique(ids)
        corners = world.corners[ids]
        local = occluder_mesh(corners.reshape(-1, 3), np.arange(3 * len(ids)).reshape(-1, 3),
                              unit_normals(corners)[0])
        assert np.array_equal(local[2], world.normals[ids])
        assert np.array_equal(local[3], offsets[ids])
        assert np.array_equal(np.argsort(local[4], kind="stable"),
                              np.argsort(groups[ids], kind="stable"))
        assert np.array_equal(np.unique(local[4], return_inverse=True)[1].ravel(),
                              np.unique(groups[ids], return_inverse=True)[1].ravel())
        pieces = (3 * ids[:, None] + np.arange(3)).ravel()  # piece e of triangle t: 3 t + e
        for mine, worlds in ((local[9], partner), (local[10], partner_any)):
            assert np.array_equal(mine >= 0, np.isin(worlds[pieces], ids))
            paired += (mine >= 0).sum()
    assert paired > 100


def test_occlusion_on_a_mapped_world_culls_as_in_memory_and_drops_nothing_visible(
        kit, w2_streamed):
    # W2 streamed to a .vmp: mapped (per-frame rows and meshes, no world-sized table) and loaded
    # (the World's tables) send the same triangles with the same counters; nothing the item
    # buffer shows is dropped.
    from pathlib import Path

    from vismobile.world.mapped import MappedWorld
    from vismobile.partition import load_partition
    from vismobile.partition.store import map_partition
    from vismobile.world.trajectory import Trajectory

    mapped, loaded = map_partition(w2_streamed), load_partition(w2_streamed)
    assert isinstance(mapped.world, MappedWorld)
    traj = Trajectory.load(Path(__file__).resolve().parents[2] / "trajectories" / "indoor.csv")
    cameras = [traj.camera(int(f), kit.ASPECT) for f in np.linspace(0, len(traj) - 1, 6)]
    cameras += kit.random_cameras(loaded, 4, 9)
    screen = tuple(kit.PROFILE.resolution)
    culled = 0
    for stages, options, cull_back in (
            ("vfc,occlusion", {}, False),
            ("vfc,occlusion,tbfc", {"screen": screen, "self_occluders": 64}, True),
            ("vfc,occlusion", {"fuse": False, "first_reach": 15.625}, False),
            ("vfc,occlusion,tbfc", {"screen": screen, "samples": True}, True)):
        a = Culler(mapped, stages, occlusion=options)
        b = Culler(loaded, stages, occlusion=options)
        stage, kept = (c.stages[c.names.index("occlusion")] for c in (a, b))
        assert not stage.tables and kept.tables
        for camera in cameras:
            x, y = a.cull(camera), b.cull(camera)
            assert np.array_equal(x.triangles, y.triangles), (stages, options)
            assert np.array_equal(x.nodes, y.nodes) and x.stats == y.stats, (stages, options)
            missing = np.setdiff1d(kit.visible_ids(loaded.world, camera, cull_back), x.triangles)
            assert not len(missing), (stages, options, camera, missing[:5])
            culled += x.stats.get("occlusion.nodes_culled", 0)
        # Nothing per triangle but the 1-bit candidate map and views of the mapped file: the
        # stage's own arrays follow the nodes (`candidates` ids a node, scratch for the
        # frame's occluders).
        world = mapped.world
        bound = (mapped.node_count + 64) * stage.candidates + 2 * stage.occluders
        assert bound < 2 * world.triangle_count
        for name, value in vars(stage).items():
            if isinstance(value, np.ndarray) and name != "bits" and not any(
                    np.shares_memory(value, w) for w in (world.vertices, world.triangles)):
                assert value.size <= bound, (name, value.shape)
        assert stage.bits.nbytes <= mapped.world.triangle_count // 8 + 8
    assert culled > 0
    # The build stored the node lists and the stage read them; a file without them (an older
    # build) gets the same lists computed at prepare.
    import dataclasses

    stored = mapped.extras["occluders"][:, :stage.candidates]
    assert np.array_equal(stage.lists, stored)
    older = dataclasses.replace(mapped, extras={"octant": mapped.extras["octant"]})
    assert np.array_equal(Culler(older, "vfc,occlusion").stages[1].lists, stored)
    wide = mapped.extras["occluders"]  # any candidates up to the stored width read them too
    for k in (wide.shape[1], wide.shape[1] + 1):
        read = Culler(mapped, "vfc,occlusion", occlusion={"candidates": k}).stages[1].lists
        made = Culler(older, "vfc,occlusion", occlusion={"candidates": k}).stages[1].lists
        assert np.array_equal(read, made) and read.shape[1] == k


def test_unique_rows_are_numpys_unique_rows():
    from vismobile.culling.occluder_mesh import unique_rows

    rng = np.random.default_rng(2)
    rows = rng.integers(-2, 3, (500, 3)).astype(np.float64) * 0.5
    rows[7] = [0.0, -0.0, 1.0]
    rows[8] = [-0.0, 0.0, 1.0]  # equal to row 7 by value
    got, inverse = unique_rows(rows)
    expect, expect_inverse = np.unique(rows, axis=0, return_inverse=True)
    assert np.array_equal(got, expect) and np.array_equal(inverse, expect_inverse.ravel())
    assert inverse[7] == inverse[8] and np.array_equal(got[inverse], rows)
    assert unique_rows(np.zeros((0, 4)))[0].shape == (0, 4)


def test_first_round_candidates_come_from_the_nearest_shells(kit):
    # hiz.gather_shell_candidates: shells of distance from the eye, each sqrt(2) wider, until
    # `limit` ids were offered; a larger limit walks on (a superset), no limit is the frustum walk.
    from pathlib import Path

    from vismobile.culling.hiz import gather_candidates, gather_shell_candidates
    from vismobile.culling.occlusion import FIRST_CANDIDATES, SHELL_GROWTH
    from vismobile.world.trajectory import Trajectory

    world = kit.world("w2")
    part = partition(world, "octree", depth=5)
    culler = Culler(part, "vfc,occlusion,tbfc")
    stage = culler.stages[1]
    assert stage.name == "occlusion" and stage.first_candidates == FIRST_CANDIDATES
    tree = stage.tree
    traj = Trajectory.load(Path(__file__).resolve().parents[2] / "trajectories" / "indoor.csv")
    cam = traj.camera(400, kit.ASPECT)
    planes = np.ascontiguousarray(cam.frustum_planes(), dtype=np.float64)
    eye = np.asarray(cam.eye, dtype=np.float64)
    none = np.zeros(0, dtype=np.int64)
    root = np.zeros(1, dtype=np.int64)

    def walk(limit):
        bits = np.zeros(world.triangle_count // 64 + 1, dtype=np.uint64)
        out = np.empty(stage.lists.size, dtype=np.int64)
        stack = np.empty(tree.node_count + 1, dtype=np.int64)
        later = np.empty(tree.node_count + 1, dtype=np.int64)
        args = (tree.lo, tree.hi, tree.first_child, tree.child_count, tree.nonempty, root,
                planes, tree.tol, eye, stage.detail, stage.lists, none, none, bits, out, stack)
        if limit is None:
            count, visited = gather_candidates(*args)
            reach = np.inf
        else:
            count, visited, reach = gather_shell_candidates(*args, later, stage.shell, limit,
                                                            SHELL_GROWTH)
        assert not bits.any()  # handed back clear
        return set(out[:count].tolist()), visited, reach

    every, visited_all, _ = walk(None)
    near, visited_near, reach = walk(64)
    nearer, _, reach_small = walk(8)
    assert np.isfinite(reach) and reach_small <= reach and visited_near < visited_all
    assert len(near) >= 64 and nearer <= near <= every
    assert walk(10 ** 9)[0] == every and walk(10 ** 9)[2] == np.inf
    few = Culler(part, "vfc,occlusion,tbfc", occlusion={"first_candidates": 64})
    few.cull(cam)  # the stage's own first round stops at a finite shell here
    assert np.isfinite(few.stages[1].reach) and few.stages[1].reach >= few.stages[1].shell
    fixed = Culler(part, "vfc,occlusion,tbfc", occlusion={"first_reach": 5.0})
    fixed.cull(cam)  # an explicit reach overrides the shells
    assert fixed.stages[1].reach == 5.0
    with pytest.raises(ValueError, match="first_candidates"):
        Culler(part, "vfc,occlusion", occlusion={"first_candidates": -1})
    whole = Culler(part, "vfc,occlusion,tbfc", occlusion={"first_candidates": 0})
    for f in np.linspace(0, len(traj) - 1, 6).astype(int):
        c = traj.camera(int(f), kit.ASPECT)
        visible = kit.visible_ids(world, c, True)
        for one in (culler, whole):
            assert not len(np.setdiff1d(visible, one.cull(c).triangles)), int(f)


def test_a_thin_far_triangle_along_a_buffer_row_is_dropped_only_with_the_screen(kit):
    # Issue 10: a wall (depth 2) covers the buffer rows below y = 80.5 (row 80 holds its edge,
    # open above it); a thin triangle far behind over y 79.55 .. 79.999 has a rectangle that,
    # grown by the device move and SLACK_PX, reaches row 80: kept without `screen`. The 240 x 320
    # screen samples it only at y 79.75 (buffer units), in row 79, which the wall covers nearer:
    # dropped with `screen`, and the item buffer never shows it.
    from vismobile.culling.backface import half_tangents

    cam = Camera((0.0, 0.0, 0.0), yaw=0.0, pitch=0.0, aspect=kit.ASPECT)
    tx, ty = half_tangents(cam.fov, cam.aspect)
    width, height = 120, 160

    def world_point(px, py, z):  # buffer pixel coordinates at depth z; yaw 0: forward is -z
        return [(px / (0.5 * width) - 1.0) * z * tx, (py / (0.5 * height) - 1.0) * z * ty, -z]

    top = world_point(0.0, 80.5, 2.0)[1]
    wall = kit.quad(-10.0, 10.0, -10.0, top, -2.0)
    thin = np.array([world_point(40.0, 79.55, 30.0), world_point(70.0, 79.999, 30.0),
                     world_point(40.0, 79.999, 30.0)])
    if np.cross(thin[1] - thin[0], thin[2] - thin[0]) @ -thin[0] < 0:
        thin = thin[[0, 2, 1]]
    world = kit.literal_world([wall, (thin, np.array([[0, 1, 2]]))], "row")
    part = partition(world, "octree", depth=2)
    assert 2 not in kit.visible_ids(world, cam, False)
    without = Culler(part, "vfc,occlusion").cull(cam)
    screen = tuple(kit.PROFILE.resolution)
    assert screen == (240, 320)
    result = Culler(part, "vfc,occlusion", occlusion={"screen": screen}).cull(cam)
    assert 2 in without.triangles and 2 not in result.triangles
    # The wall's visible triangle stays (its other one lies wholly below the screen: its
    # rectangle meets it, its shape does not, so the triangle test drops it).
    assert np.isin(kit.visible_ids(world, cam, False), result.triangles).all()
    assert 1 in result.triangles


def test_sample_buffer_is_on_for_large_worlds_with_a_screen_and_clips_shifting_occluders(
        kit, monkeypatch):
    # `samples` None: on from SAMPLES_FROM triangles with a screen (the screen's size), never
    # without one; the occluders are clipped where their screen shift would leave a sample's
    # square (sample_clip), deeper when the device moves points more.
    import vismobile.culling.occlusion as occ

    world = wall_scene(kit)
    part = partition(world, "octree", depth=3)
    screen = tuple(kit.PROFILE.resolution)
    stage = Culler(part, "vfc,occlusion", occlusion={"screen": screen}).stages[-1]
    assert not stage.sampled and (stage.width, stage.height) == (120, 160)
    monkeypatch.setattr(occ, "SAMPLES_FROM", world.triangle_count)
    stage = Culler(part, "vfc,occlusion", occlusion={"screen": screen}).stages[-1]
    assert stage.sampled and (stage.width, stage.height) == screen
    assert not Culler(part, "vfc,occlusion").stages[-1].sampled
    with pytest.raises(ValueError):
        Culler(part, "vfc,occlusion", occlusion={"samples": True})
    tx, ty, w, h = 0.4, 0.3, 240, 320
    px = 0.5 * max(w / tx, h / ty)
    for move in (1e-7, 1e-5, 1e-3):
        z = occ.sample_clip(1e-3, move, tx, ty, w, h, occ.SAMPLE_HALF)
        assert occ.occluder_shift(z, move, tx, ty) * px <= occ.SAMPLE_HALF - occ.SLACK_PX
        assert z == 1e-3 or occ.occluder_shift(0.999 * z, move, tx, ty) * px \
            > occ.SAMPLE_HALF - occ.SLACK_PX
    assert occ.sample_clip(1e-3, 1e-3, tx, ty, w, h, 0.25) > occ.sample_clip(
        1e-3, 1e-5, tx, ty, w, h, 0.25) > 1e-3

"""`horizon` on object worlds: occluders found from the geometry, the map of solid columns, and
the proof obligation on sampled cameras (the 2,000-camera sweep is tools/horizon_objects.py)."""
import numpy as np
import pytest

from vismobile.world.camera import Camera
from vismobile.culling import Culler, device_options
from vismobile.culling.horizon_solids import find_solids, is_prism, solid_map
from vismobile.device.profile import get_profile
from vismobile.render.device_view import device_buffers, shown_ids
from vismobile.world import World

from .conftest import quad


def boxes_world(boxes, ground=None, bottoms=False):
    """Closed boxes (x0, z0, x1, z1, y0, y1) wound outward (no bottom unless asked), one object
    each, and an optional ground (x0, z0, x1, z1) at y 0 facing up."""
    verts, tris, ids, names = [], [], [], []

    def add(v, t, name):
        tris.append(np.asarray(t) + sum(len(x) for x in verts))
        verts.append(v)
        ids.append(np.full(len(t), len(names)))

    for k, (x0, z0, x1, z1, y0, y1) in enumerate(boxes):
        v = np.array([[x, y, z] for y in (y0, y1) for z in (z0, z1) for x in (x0, x1)], float)
        faces = [(4, 6, 7, 5), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]
        if bottoms:
            faces.append((0, 2, 3, 1))
        t = []
        for a, b, c, d in faces:
            t += [[a, b, c], [a, c, d]]
        t = np.array(t)
        centre = v.mean(axis=0)
        cross = np.cross(v[t[:, 1]] - v[t[:, 0]], v[t[:, 2]] - v[t[:, 0]])
        out = np.einsum("ij,ij->i", cross, v[t].mean(axis=1) - centre) > 0
        t[~out] = t[~out][:, ::-1]
        add(v, t, f"box{k}")
        names.append(f"box{k}")
    if ground is not None:
        x0, z0, x1, z1 = ground
        v, t = quad(x0, x1, z0, z1, 0.0)
        v = v[:, [0, 2, 1]]  # the xz-plane at y = 0
        cross = np.cross(v[t[:, 1]] - v[t[:, 0]], v[t[:, 2]] - v[t[:, 0]])
        t = np.where((cross[:, 1] > 0)[:, None], t, t[:, ::-1])
        add(v, t, "ground")
        names.append("ground")
    return World(np.concatenate(verts), np.concatenate(tris), np.concatenate(ids), names, "boxes")


def test_the_city_s_buildings_and_ground_are_found(kit):
    w5 = kit.world("w5")
    found = find_solids(w5)
    solids = solid_map(w5, found)
    assert (solids.grounds, solids.prisms) == (1, 144)
    assert solids.bases is None  # every building stands on the ground: columns go down
    assert solids.max_base == -np.inf
    assert found.grounds_under((100.0, 1.7, 100.0)) == (0,)
    # Seen from beyond the ground's edge the ground is no solid (a ray may pass under its
    # edge): the buildings keep their bases and the eye must be above them.
    off = solid_map(w5, found, valid=())
    assert off.grounds == 0 and off.bases is not None and off.max_base == 0.0
    # Non-occluders are skipped: W6's cows and dragons add no solid.
    assert solid_map(kit.world("w6"), find_solids(kit.world("w6"))).prisms == 144


def test_an_open_or_bent_box_is_not_a_prism():
    world = boxes_world([(0, 0, 2, 2, 0, 3)])
    corners, normals = world.corners, world.normals
    assert is_prism(corners, normals) is not None
    for drop in (0, 2, 4):  # a roof, a wall or another wall missing: not closed
        keep = np.ones(len(corners), bool)
        keep[drop:drop + 2] = False
        assert is_prism(corners[keep], normals[keep]) is None
    bent = corners.copy()
    bent[bent[..., 1] == 3, 1] += np.linspace(0, 1, (bent[..., 1] == 3).sum())
    from vismobile.world.world import unit_normals
    assert is_prism(bent, unit_normals(bent)[0]) is None


def test_a_box_behind_a_wall_is_hidden_and_one_beside_it_is_not():
    world = boxes_world([(-2, -12, 2, -10, 0, 6), (-1, -20, 1, -19, 0, 2),
                         (5, -20, 7, -19, 0, 2)], ground=(-30, -40, 30, 10))
    from vismobile.partition import partition

    part = partition(world, "octree", depth=3)
    culler = Culler(part, "vfc,horizon")
    sent = culler.cull(Camera((0.0, 1.7, 0.0), yaw=0.0, pitch=0.0, aspect=0.75)).triangles
    names = np.array(world.object_names)[world.object_ids[sent]]
    assert "box1" not in names and "box2" in names and "box0" in names
    # From inside the wall, or under the ground, nothing is hidden.
    for eye in ((0.0, 1.7, -11.0), (0.0, -1.0, 0.0), (0.0, -0.5, 20.0)):  # in, under, beyond
        inside = culler.cull(Camera(eye, yaw=0.0, pitch=0.0, aspect=0.75))
        assert inside.stats.get("horizon.triangles_culled", 0) == 0  # off screen aside


def test_a_free_standing_box_hides_only_above_its_base():
    # A box lifted 3 above the ground (no ground object): seen from below its base nothing is
    # hidden (its open bottom); from above it hides what is behind it.
    world = boxes_world([(-2, -12, 2, -10, 3, 9), (-1, -20, 1, -19, 3.5, 5)])
    from vismobile.partition import partition

    part = partition(world, "octree", depth=2)
    culler = Culler(part, "vfc,horizon")
    high = culler.cull(Camera((0.0, 4.0, 0.0), yaw=0.0, pitch=0.0, aspect=0.75)).triangles
    assert not np.isin(world.object_ids[high], 1).any()
    low = culler.cull(Camera((0.0, 1.0, 0.0), yaw=0.0, pitch=15.0, aspect=0.75))
    assert low.stats.get("horizon.skipped") == 1


@pytest.mark.parametrize("mode", ["float32", "fixed16.16"])
@pytest.mark.parametrize("name", ["w5", "w6"])
def test_horizon_never_drops_a_visible_triangle(kit, name, mode):
    world = kit.world(name)
    profile = get_profile(kit.PROFILE, mode)
    parts = [kit.structure(name, "octree"), kit.structure(name, "kdtree")]
    rng = np.random.default_rng(7 if name == "w5" else 8)
    low, high = world.extent
    cameras = []
    for i in range(10):
        pos = rng.uniform(low, high)
        pos[1] = [1.7, rng.uniform(-2, 50), 0.05][i % 3]  # street level, anywhere, near ground
        pitch = [0.0, rng.uniform(-89, 89), rng.uniform(-30, 30)][i % 3]
        cameras.append(Camera(pos, yaw=rng.uniform(0, 360), pitch=pitch, aspect=kit.ASPECT,
                              near=[0.1, 1e-3, 1.0][i % 3]))
    culled = subpixel = 0
    for part in parts:
        culler = Culler(part, "vfc,horizon,tbfc", arithmetic=profile.vertex_format)
        # With the device's screen: also the triangles covering no pixel centre of it.
        screen = Culler(part, "vfc,horizon,tbfc", **device_options(profile))
        for cam in cameras:
            truth = shown_ids(device_buffers(world, cam, profile, True))
            result = culler.cull(cam)
            culled += result.stats.get("horizon.triangles_culled", 0)
            missing = np.setdiff1d(truth, result.triangles)
            assert not len(missing), (name, part.kind, mode, cam, missing[:5])
            result = screen.cull(cam)
            subpixel += result.stats.get("horizon.triangles_subpixel", 0)
            missing = np.setdiff1d(truth, result.triangles)
            assert not len(missing), (name, part.kind, mode, cam, "screen", missing[:5])
    assert culled > 0 and subpixel > 0  # the check saw the stage hide something


def test_adaptive_runs_the_horizon_and_never_drops(kit):
    from vismobile.culling.adaptive import AdaptiveCuller

    world = kit.world("w5")
    part = kit.structure("w5", "octree")
    culler = AdaptiveCuller(part, ["vfc", "horizon", "tbfc"], window=2, probe_every=3,
                            ms_per_triangle=0.05)
    ran = 0
    for i in range(8):
        cam = Camera((70.0, 1.7, 250.0 - 10 * i), yaw=0.0, pitch=0.0, aspect=kit.ASPECT)
        result = culler.cull(cam)
        ran += "horizon.nodes_tested" in result.stats
        assert not len(np.setdiff1d(kit.visible_ids(world, cam, True), result.triangles))
    assert ran  # the stage took part (adaptive may then switch it off when it does not pay)


def test_the_stage_is_in_every_registry():
    from vismobile.commands import STAGE_NAMES
    from vismobile.culling import CONSERVATIVE
    from vismobile.study.matrix import OUR_CULLS, STAGE_ORDER, parse_culls
    from vismobile.viewer.keys import PRESSED

    assert "horizon" in STAGE_NAMES and "horizon" in CONSERVATIVE and "horizon" in STAGE_ORDER
    assert "vfc+bfc+tbfc+horizon" in OUR_CULLS and "vfc+horizon" in parse_culls("vfc+horizon")
    assert "toggle:horizon" in PRESSED.values()
    from vismobile.culling.horizon import HorizonStage

    for bad in ({"bands": 0}, {"step": 2.0}, {"cells": 0}, {"screen": (0, 320)},
                {"screen": (240,)}):
        with pytest.raises(ValueError):
            HorizonStage(**bad)


def test_the_device_model_prices_the_horizon(kit):
    from vismobile.device.costmodel import cull_cycles

    part = kit.structure("w5", "octree")
    cam = Camera((70.0, 1.7, 250.0), yaw=0.0, pitch=0.0, aspect=kit.ASPECT)
    stats = Culler(part, "vfc,horizon,tbfc").cull(cam).stats
    plain = Culler(part, "vfc,tbfc").cull(cam).stats
    assert stats["horizon.pieces"] > 0 and stats["horizon.triangles_tested"] > 0
    assert cull_cycles(stats, 50.0) > cull_cycles(plain, 50.0) + 60 * stats["horizon.pieces"] - 1
    # With the device's screen the centre test is priced on what reached it.
    screen = Culler(part, "vfc,horizon,tbfc", horizon={"screen": (240, 320)}).cull(cam).stats
    assert 0 < screen["horizon.triangles_centre_tested"] <= screen["horizon.triangles_tested"]
    assert cull_cycles(screen, 50.0) == cull_cycles(stats, 50.0) + 80 * screen[
        "horizon.triangles_centre_tested"] - 200 * (stats["horizon.triangles_tested"]
                                                    - screen["horizon.triangles_tested"])


def test_triangles_wholly_off_screen_are_dropped(kit):
    # The kd-tree's straddling leaves hand on triangles outside the frustum; the stage's
    # triangle test drops those (all three corners outside one plane), and only those besides
    # the ones behind the horizon.
    world, part = kit.world("w5"), kit.structure("w5", "kdtree")
    cam = Camera((70.0, 1.7, 250.0), yaw=0.0, pitch=0.0, aspect=kit.ASPECT)
    planes = np.asarray(cam.frustum_planes())
    distance = world.corners @ planes[:, :3].T + planes[:, 3]
    off = (distance < 0).all(axis=1).any(axis=1)
    plain = Culler(part, "vfc").cull(cam).triangles
    result = Culler(part, "vfc,horizon").cull(cam)
    assert off[plain].sum() > 0
    assert not off[result.triangles].any()
    assert 0 < result.stats["horizon.triangles_off_screen"] <= off[plain].sum()  # nodes first
    assert not len(np.setdiff1d(kit.visible_ids(world, cam, False), result.triangles))


def test_the_stage_s_kernels_match_the_horizon_s_tests(kit):
    # The stage tests nodes and triangles in one numba call each (horizon_tests.py); they must
    # decide as the Horizon's own tests do, box by box and triangle by triangle.
    from vismobile.culling.horizon import HorizonStage
    from vismobile.culling.horizon_tests import (NO_OBJECTS, NO_SCREEN, _nodes, _triangles,
                                                 horizon_arrays, off_screen)

    part = kit.structure("w5", "octree")
    stage = HorizonStage()
    culler = Culler(part, "vfc")
    stage.prepare(culler.tree)
    from vismobile.culling.hiz import covers_no_sample

    tree, hidden_seen, subpixel_seen = culler.tree, 0, 0
    for z, yaw in ((250.0, 0.0), (150.0, 20.0), (100.0, -90.0)):
        cam = Camera((70.0, 1.7, z), yaw=yaw, pitch=0.0, aspect=kit.ASPECT)
        horizon = stage.cast(cam)
        nodes = np.flatnonzero(tree.nonempty)
        expected = horizon.hidden(tree.node_bounds[nodes] + stage.grow)
        assert np.array_equal(_nodes(tree.node_bounds, nodes, stage.margin,
                                     *horizon_arrays(horizon)), expected)
        ids = np.arange(len(stage.corners))
        planes = np.asarray(cam.frustum_planes())
        off, behind, sub = _triangles(stage.corners, ids, planes, 1e-6, stage.margin,
                                      *horizon_arrays(horizon), *NO_SCREEN, *NO_OBJECTS)
        assert not sub.any()
        assert np.array_equal(off, off_screen(stage.corners, planes, 1e-6))
        expected = horizon.hidden_points(stage.corners, stage.margin)
        assert np.array_equal(behind, expected & ~off)
        hidden_seen += int(behind.sum()) + int(expected.sum())
        # With a screen: the centre test of hiz (camera space), on what the horizon kept.
        stage.screen = (240, 320)
        samples = stage.samples(cam)
        off2, behind2, sub = _triangles(stage.corners, ids, planes, 1e-6, stage.margin,
                                        *horizon_arrays(horizon), *samples, *NO_OBJECTS)
        assert np.array_equal(off2, off) and np.array_equal(behind2, behind)
        eye, rotation, near, tx, ty, width, height, move = samples
        cam_space = (stage.corners - eye) @ rotation.T
        expected = covers_no_sample(cam_space, near, tx, ty, width, height, move)
        assert np.array_equal(sub, expected & ~off & ~behind)
        subpixel_seen += int(sub.sum())
        stage.screen = None
    assert hidden_seen > 0 and subpixel_seen > 0


@pytest.mark.parametrize("name", ["w5", "terrain"])
def test_the_fixed_point_triangle_kernel_matches_hidden_points(kit, name):
    # fixed16.16 tests triangles in one numba call (_triangles over hidden_one_fixed);
    # it must decide as FixedHorizon.hidden_points does, triangle by triangle, on an object
    # world's solids and on a terrain's ground (a 65^2 fractal, boxes standing on it).
    from vismobile.culling.horizon import HorizonStage
    from vismobile.culling.horizon_tests import (NO_OBJECTS, NO_SCREEN, _triangles,
                                                 fixed_arrays, off_screen)
    from vismobile.terrain.horizon import FixedHorizon

    if name == "w5":
        part, eyes = kit.structure("w5", "octree"), [(70.0, 1.7, 250.0), (150.0, 1.7, 100.0)]
    else:
        from vismobile.partition import partition
        from vismobile.terrain import sources
        from vismobile.terrain.ground import TerrainGround

        hm = sources.diamond_square(65, seed=2, roughness=0.5, relief=0.2)
        rng = np.random.default_rng(5)
        boxes = []
        for x, z in rng.uniform(2, 60, (40, 2)) * hm.spacing:
            h = float(hm.height_at(x, z))
            boxes.append((x, z, x + 1.5, z + 1.5, h - 1.0, h + 2.0))
        world = boxes_world(boxes, bottoms=True)
        world.ground = TerrainGround(hm)
        part = partition(world, "octree", depth=3)
        eyes = [(x, float(hm.height_at(x, z)) + up, z) for x, z, up in ((5.0, 5.0, 3.0),
                                                                       (60.0, 30.0, 1.0))]
    stage = HorizonStage()
    stage.arithmetic = "fixed16.16"
    culler = Culler(part, "vfc")
    stage.prepare(culler.tree)
    ids = np.arange(len(stage.corners))
    hidden_seen = 0
    for eye in eyes:
        for yaw in (0.0, 45.0, 200.0):
            cam = Camera(eye, yaw=yaw, pitch=-5.0, aspect=kit.ASPECT)
            horizon = stage.cast(cam)
            if horizon is None:
                continue
            assert isinstance(horizon, FixedHorizon)
            planes = np.asarray(cam.frustum_planes())
            off, behind, sub = _triangles(stage.corners, ids, planes, 1e-6, stage.margin,
                                          *fixed_arrays(horizon), *NO_SCREEN, *NO_OBJECTS)
            assert not sub.any()
            assert np.array_equal(off, off_screen(stage.corners, planes, 1e-6))
            expected = horizon.hidden_points(stage.corners, stage.margin)
            assert np.array_equal(behind, expected & ~off)
            hidden_seen += int(behind.sum())
    assert hidden_seen > 0


@pytest.mark.parametrize("mode", ["float64", "fixed16.16"])
def test_object_boxes_decide_whole_objects_once_a_frame(kit, mode):
    # With object boxes a triangle whose object's box is off screen or behind the horizon goes
    # with it (one box test a frame); the others are tested one by one as without them. So the
    # boxes drop a superset, every extra one in a box the horizon hides, and nothing shown.
    from vismobile.culling.horizon import HorizonStage
    from vismobile.culling.horizon_tests import (BEHIND, NO_OBJECTS, NO_SCREEN, OFF,
                                                 _triangles, fixed_arrays, horizon_arrays)

    world, part = kit.world("w6"), kit.structure("w6", "octree")
    stage = HorizonStage()
    stage.arithmetic = mode
    stage.prepare(Culler(part, "vfc").tree)
    ids = np.arange(len(stage.corners))
    decided = 0
    for z, yaw in ((250.0, 0.0), (150.0, 20.0), (100.0, -90.0)):
        cam = Camera((70.0, 1.7, z), yaw=yaw, pitch=0.0, aspect=kit.ASPECT)
        horizon = stage.cast(cam)
        planes = np.asarray(cam.frustum_planes())

        def run(objects):
            arrays = horizon_arrays(horizon) if mode == "float64" else fixed_arrays(horizon)
            return _triangles(stage.corners, ids, planes, 1e-6, stage.margin, *arrays,
                              *NO_SCREEN, *objects)

        off, behind, _ = run(NO_OBJECTS)
        objects = stage.objects()
        off_o, behind_o, _ = run(objects)
        verdict = stage.verdict[stage.object_ids]
        assert not ((off | behind) & ~(off_o | behind_o)).any()
        extra = (off_o | behind_o) & ~(off | behind)
        assert np.all(verdict[extra] == BEHIND)
        assert np.all(off_o[verdict == OFF]) and np.all(behind_o[verdict == BEHIND])
        decided += int((verdict == BEHIND).sum() + (verdict == OFF).sum())
        shown = kit.visible_ids(world, cam, False)
        assert not (off_o | behind_o)[shown].any()
    assert decided > 0

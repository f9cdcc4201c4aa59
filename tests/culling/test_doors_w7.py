"""W7 (issue 25), doors shut and on their schedule: every conservative stage and combination
(test_conservative.COMBOS) keeps every triangle the item buffer of the frame's pose shows, on
sampled frames of W7's path (street, entrance, gallery, in front of shut doors, back out) and on
random cameras inside the building and on the streets around it at random times, over the default
portal cells and over cells on both faces of every wall (`walls=True`: a room per storey, the
streets' portals into the building its doors, windows and arches, the cracks where their faces
meet followed by crack slivers); portals with the doors shut
in the device's float32 and fixed16.16 vertex formats; and a shut door removes what lies behind,
seen from inside and from the street."""
import importlib.util
from pathlib import Path

import numpy as np
import pytest

from vismobile.culling import Culler, parse_stages
from vismobile.partition import partition
from vismobile.scenes import hybrid
from vismobile.scenes.thesis import write_motion
from vismobile.world.animated import AnimatedWorld
from vismobile.world.camera import Camera
from vismobile.world.trajectory import Trajectory

ROOT = Path(__file__).resolve().parents[2]
_spec = importlib.util.spec_from_file_location(
    "conservative_combos", Path(__file__).with_name("test_conservative.py"))
_combos = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(_combos)
COMBOS, OPTIONS = _combos.COMBOS, _combos.OPTIONS
FRAMES = (120, 400, 470, 530, 600, 660, 760, 870, 1000)  # street, door, gallery, room, out
_CACHE = {}


def animated_w7(thesis_world, tmp_path_factory, doors, walls=False):
    if (doors, walls) not in _CACHE:
        path = tmp_path_factory.mktemp("motion") / f"{doors}.json"
        write_motion("w7", path, doors=doors)
        world = AnimatedWorld.from_motion_file(thesis_world("w7"), path)
        _CACHE[doors, walls] = partition(world, "portal", depth=2, walls=walls)
    return _CACHE[doors, walls]


def cameras(kit, seed):
    """(camera, time): the path's FRAMES at f / 30 s, random cameras in the building, and
    random cameras on the streets around it (within 12 m of its walls, up to 10 m high)."""
    path = Trajectory.load(ROOT / "trajectories" / "hybrid.csv")
    out = [(path.camera(f, kit.ASPECT), f / 30.0) for f in FRAMES]
    rng = np.random.default_rng(seed)
    foot = hybrid.footprint()
    for _ in range(6):
        eye = [rng.uniform(foot[0, 0], foot[1, 0]), rng.uniform(0.3, 6.0),
               rng.uniform(foot[0, 1], foot[1, 1])]
        out.append((Camera(eye, yaw=rng.uniform(0, 360), pitch=rng.uniform(-40, 40),
                           aspect=kit.ASPECT), rng.uniform(0, 40)))
    for side in range(4):  # west, south, east, north of the building
        high, column = side >= 2, side % 2  # column 0: x off the wall, 1: z off the wall
        eye = np.array([rng.uniform(foot[0, 0], foot[1, 0]), rng.uniform(0.5, 10.0),
                        rng.uniform(foot[0, 1], foot[1, 1])])
        away = rng.uniform(1.0, 12.0)
        eye[2 * column] = foot[1, column] + away if high else foot[0, column] - away
        out.append((Camera(eye, yaw=rng.uniform(0, 360), pitch=rng.uniform(-30, 30),
                           aspect=kit.ASPECT), rng.uniform(0, 40)))
    return out


@pytest.mark.parametrize("doors, walls", [("closed", False), ("closed", True),
                                          ("scheduled", True)])
def test_no_stage_drops_a_visible_triangle_on_w7(kit, thesis_world, tmp_path_factory, doors,
                                                 walls):
    part = animated_w7(thesis_world, tmp_path_factory, doors, walls)
    animated = part.animated
    cullers = {combo: Culler(part, combo, **OPTIONS.get(combo, {})) for combo in COMBOS}
    shut = 0
    for i, (cam, t) in enumerate(cameras(kit, seed=(7 if doors == "closed" else 8) + walls)):
        posed = animated.posed(t)
        truth = {}
        for combo, culler in cullers.items():
            back = bool(kit.BACKFACE_STAGES & set(parse_stages(combo)))
            if back not in truth:
                truth[back] = kit.visible_ids(posed, cam, back)
            result = culler.cull(cam, time=t)
            shut += result.stats.get("portals.portals_shut", 0)
            missing = np.setdiff1d(truth[back], result.triangles)
            assert not len(missing), (f"{combo} with doors {doors} dropped {len(missing)} "
                                      f"visible triangles at t={t:.2f}, camera {cam}")
    assert shut > 0  # the doors did block portals on these frames


@pytest.mark.parametrize("stages, back", [("portals", False), ("portals,tbfc", True)])
def test_wall_cells_keep_what_a_crack_shows(kit, thesis_world, tmp_path_factory, stages, back):
    """Frame 580 (in the gallery, looking up the arches), doors on their schedule: the item
    buffer shows one pixel of the upper storey's floor (with back faces culled, of the wall of
    the room above) through the crack along the ceiling's edge, a T-junction with the wall's
    top edge; over wall cells the ceiling closes the cell's top face and the wall its side.
    The crack slivers (culling/portal_cracks.py) keep it; without them `portals` drops it."""
    path = Trajectory.load(ROOT / "trajectories" / "hybrid.csv")
    camera, t = path.camera(580, kit.ASPECT), 580 / 30.0
    part = animated_w7(thesis_world, tmp_path_factory, "scheduled", walls=True)
    shown = kit.visible_ids(part.animated.posed(t), camera, back)
    sent = Culler(part, stages).cull(camera, time=t).triangles
    assert not len(np.setdiff1d(shown, sent))
    without = Culler(part, stages, portals={"cracks": False}).cull(camera, time=t).triangles
    assert len(np.setdiff1d(shown, without))


@pytest.mark.parametrize("walls", [False, True])
def test_a_shut_door_hides_the_room_behind_it(kit, thesis_world, tmp_path_factory, walls):
    """Frame 608: the walker, 2 m away, faces the door into room (2, 0); shut, portals sends a fraction
    of what it sends with every door open."""
    path = Trajectory.load(ROOT / "trajectories" / "hybrid.csv")
    camera = path.camera(608, kit.ASPECT)
    sent = {}
    for doors in ("closed", "open"):
        part = animated_w7(thesis_world, tmp_path_factory, doors, walls)
        sent[doors] = len(Culler(part, "portals").cull(camera, time=20.0).triangles)
    assert sent["closed"] < 0.5 * sent["open"]


def test_from_the_street_a_shut_entrance_hides_the_rooms(kit, thesis_world, tmp_path_factory):
    """Frame 420: on the street 7 m before the entrance, facing it. Over wall cells the street's
    portals into the building are its openings: the portals run outdoors (no fallback), and
    with the entrance shut they send under half of what they send with every door open."""
    path = Trajectory.load(ROOT / "trajectories" / "hybrid.csv")
    camera = path.camera(420, kit.ASPECT)
    sent = {}
    for doors in ("closed", "open"):
        part = animated_w7(thesis_world, tmp_path_factory, doors, walls=True)
        result = Culler(part, "portals").cull(camera, time=14.0)
        assert "portals.fallbacks" not in result.stats
        sent[doors] = len(result.triangles)
    assert sent["closed"] < 0.5 * sent["open"]


@pytest.mark.parametrize("fmt", ["float32", "fixed16.16"])
def test_shut_doors_keep_what_the_device_shows(kit, thesis_world, tmp_path_factory, fmt):
    """In the device's vertex formats (render/device_view.py: what the device draws from its
    rounded vertices), portals with every door shut keeps every triangle the device shows."""
    from vismobile.culling import device_options
    from vismobile.device.profile import get_profile
    from vismobile.render.device_view import device_buffers, shown_ids

    part = animated_w7(thesis_world, tmp_path_factory, "closed")
    profile = get_profile(kit.PROFILE, fmt)
    combos = ("portals", "portals,occlusion,cbfc,cone,tbfc")
    cullers = {c: Culler(part, c, **device_options(profile)) for c in combos}
    shut = 0
    for cam, t in cameras(kit, seed=31)[::2]:
        posed = part.animated.posed(t)
        for combo, culler in cullers.items():
            back = bool(kit.BACKFACE_STAGES & set(parse_stages(combo)))
            truth = shown_ids(device_buffers(posed, cam, profile, back))
            result = culler.cull(cam, time=t)
            shut += result.stats.get("portals.portals_shut", 0)
            missing = np.setdiff1d(truth, result.triangles)
            assert not len(missing), f"{combo} in {fmt} dropped {len(missing)}, camera {cam}"
    assert shut > 0

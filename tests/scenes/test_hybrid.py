"""W7 (scenes/hybrid.py, crowd.py): the building in the city, its outside, doors, movers, path."""
import importlib.util
import json
from pathlib import Path

import numpy as np
import pytest

from vismobile.scenes import build_world, crowd, hybrid
from vismobile.scenes.thesis import motion_path
from vismobile.world.trajectory import Trajectory

ROOT = Path(__file__).resolve().parents[2]
PATH = ROOT / "trajectories" / "hybrid.csv"


@pytest.fixture(scope="module")
def built():
    return hybrid.build_hybrid()


def _names(world, prefix):
    return [i for i, n in enumerate(world.object_names) if n.startswith(prefix)]


def test_no_city_building_stands_on_the_building(built):
    world = built[0]
    foot = hybrid.footprint()
    ids = _names(world, "building_")
    assert 120 < len(ids) < 144  # the lots under the building are left out
    boxes = np.array([world.corners[world.object_ids == i].reshape(-1, 3)[:, [0, 2]]
                      .min(axis=0) for i in ids])
    highs = np.array([world.corners[world.object_ids == i].reshape(-1, 3)[:, [0, 2]]
                      .max(axis=0) for i in ids])
    apart = (highs < foot[0] - hybrid.LOT_CLEARANCE) | (boxes > foot[1] + hybrid.LOT_CLEARANCE)
    assert apart.any(axis=1).all()


def test_no_floor_lies_in_the_grounds_plane(built):
    world = built[0]
    ground = world.object_ids == world.object_names.index("ground")
    foot = hybrid.footprint()
    centres = world.centroids[ground][:, [0, 2]]
    inside = ((centres > foot[0]) & (centres < foot[1])).all(axis=1)
    assert not inside.any()
    # the hole is exactly the footprint: ground area = square minus footprint
    low, high = hybrid.city.city_extent()
    expected = (high - low) ** 2 - np.prod(foot[1] - foot[0])
    assert world.areas[ground].sum() == pytest.approx(expected, rel=1e-9)


def test_the_building_is_closed_seen_from_the_street(built):
    """Rays from the street toward the building's outer walls, away from windows and the
    entrance, hit an outward front face (the outside), not W1's room walls' backs."""
    from vismobile.open3d_import import raycast_primitive_ids

    world = built[0]
    foot = hybrid.footprint()
    rng = np.random.default_rng(0)
    zs = rng.uniform(foot[0, 1] + 0.5, foot[1, 1] - 0.5, 200)
    ys = rng.uniform(0.2, hybrid.TOP - 0.2, 200)
    origins = np.column_stack([np.full(200, foot[0, 0] - 5.0), ys, zs])
    directions = np.tile([1.0, 0.0, 0.0], (200, 1))
    ids = raycast_primitive_ids(world.vertices, world.triangles, origins, directions)
    hit = ids[ids >= 0]
    assert len(hit) > 150  # most rays meet the wall; the others pass windows or the entrance
    assert (world.normals[hit] @ [1.0, 0.0, 0.0] <= 1e-12).all()  # never a back face
    assert (world.normals[hit] @ [1.0, 0.0, 0.0] < 0).mean() > 0.9
    names = [world.object_names[world.object_ids[i]] for i in hit]
    assert names.count("outside_x0") > 0.8 * len(names)  # the rest: rooms seen through windows


def test_doors_are_closed_boxes_that_contain_their_doorways(built):
    world, plan, leaves, _ = built
    assert len(leaves) == 35  # 34 door-sized doorways and the entrance (5 arches stay open)
    for leaf in leaves:
        ids = world.object_ids == world.object_names.index(leaf.name)
        corners = world.corners[ids].reshape(-1, 3)
        assert np.allclose(corners.min(axis=0), leaf.box[0])
        assert np.allclose(corners.max(axis=0), leaf.box[1])
        volume = np.einsum("ij,ij->i", world.corners[ids][:, 0],
                           np.cross(world.corners[ids][:, 1], world.corners[ids][:, 2])).sum() / 6
        assert volume == pytest.approx(np.prod(leaf.box[1] - leaf.box[0]))  # closed, outward
        # the hinge is a corner of the box's footprint
        assert np.isclose(leaf.hinge[1], leaf.box[0, 1])
    for door in plan.doors:
        if (door.width, door.height) != hybrid.DOOR:
            continue
        leaf = next(l for l in leaves if l.name.endswith(
            f"s{door.storey}_{door.rooms[0][0]}{door.rooms[0][1]}_"
            f"{door.rooms[1][0]}{door.rooms[1][1]}"))
        lo = hybrid.OFFSET.copy()
        lo[door.axis] += door.plane - hybrid.WALL / 2
        lo[2 - door.axis] += door.centre - door.width / 2
        lo[1] += hybrid.FLOOR_Y[door.storey]
        hi = lo.copy()
        hi[door.axis] += hybrid.WALL
        hi[2 - door.axis] += door.width
        hi[1] += door.height
        assert (leaf.box[0] < lo).all() and (leaf.box[1] > hi).all()


def test_an_open_door_turns_into_room_b(built):
    from vismobile.scenes.crowd import yaw_quaternion

    _, _, leaves, _ = built
    for leaf in leaves:
        q = yaw_quaternion([leaf.open_degrees])[0]
        x, y, z, w = q
        turn = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                         [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                         [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])
        centre = leaf.box.mean(axis=0)
        moved = leaf.hinge + turn @ (centre - leaf.hinge)
        axis = int(np.argmin(leaf.box[1] - leaf.box[0]))
        assert moved[axis] > leaf.box[1, axis] + 0.3  # swung out of the wall into room b


def test_motion_names_every_mover_and_loops_people_and_cars(built):
    world, _, leaves, document = built
    objects = document["objects"]
    names = set(world.object_names)
    assert set(objects) <= names
    assert {l.name for l in leaves} <= set(objects)
    movers = [n for n in objects if n.startswith(("person_", "car_"))]
    assert len(movers) == crowd.PEOPLE + sum(r[-1] for r in crowd.RINGS)
    for name in movers:
        entry = objects[name]
        assert entry["loop"] and entry["translation"][0] == [0.0, 0.0, 0.0]
        assert np.allclose(entry["translation"][-1], 0.0, atol=1e-6)  # a whole circuit
    for name, frames in crowd.PATH_DOORS.items():  # open while the walker passes
        times = np.array(objects[name]["times"])
        turn = np.array(objects[name]["rotation"])[:, 1]
        for a, b in frames:
            for f in (a, b):
                k = np.searchsorted(times, f / crowd.FPS) - 1
                assert abs(turn[k]) > 0.7 and abs(turn[k + 1]) > 0.7


def test_w7_is_built_with_its_motion_file_deterministically(tmp_path):
    build_world("w7", tmp_path / "a", rebuild=True)
    build_world("w7", tmp_path / "b", rebuild=True)
    for name in ("w7.obj", "w7.motion.json"):
        assert (tmp_path / "a" / name).read_bytes() == (tmp_path / "b" / name).read_bytes()
    assert motion_path("w7", tmp_path / "a") == tmp_path / "a" / "w7.motion.json"
    assert motion_path("w1") is None
    document = json.loads((tmp_path / "a" / "w7.motion.json").read_text())
    assert document["fps"] == 30


def _crossings(world, positions, ids):
    spec = importlib.util.spec_from_file_location("tt", ROOT / "tests" / "test_trajectory.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    mask = np.isin(world.object_ids, ids)
    return module.segments_cross(positions[:-1], positions[1:], world.corners[mask])


def test_the_path_goes_in_and_out_through_doorways_only(built):
    world = built[0]
    positions = Trajectory.load(PATH).poses[:, :3]
    moving = _names(world, ("door_", "person_", "car_"))
    still = [i for i in range(len(world.object_names)) if i not in set(moving)]
    assert not _crossings(world, positions, still).any()
    foot = hybrid.footprint()
    inside = ((positions[:, [0, 2]] > foot[0]) & (positions[:, [0, 2]] < foot[1])).all(axis=1)
    assert not inside[0] and not inside[-1] and inside.sum() > 300
    crossed = np.flatnonzero(_crossings(world, positions, _names(world, "door_")))
    spans = [pair for frames in crowd.PATH_DOORS.values() for pair in frames]
    assert len(crossed) and all(any(a <= f <= b for a, b in spans) for f in crossed)


def test_committed_path_matches_its_generator(tmp_path):
    spec = importlib.util.spec_from_file_location("make_trajectories",
                                                  ROOT / "tools" / "make_trajectories.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    module.hybrid().save(tmp_path / "hybrid.csv")
    assert (tmp_path / "hybrid.csv").read_bytes() == PATH.read_bytes()


def test_street_walkers_loop_round_the_blocks_clear_of_the_buildings(built):
    walkers = crowd.street_walkers(40)
    assert len({name for name, *_ in walkers}) == 40
    world = built[0]
    city = [i for i, n in enumerate(world.object_names) if n.startswith("building_")]
    boxes = np.array([[world.corners[world.object_ids == i].reshape(-1, 3).min(axis=0),
                       world.corners[world.object_ids == i].reshape(-1, 3).max(axis=0)]
                      for i in city])
    for _, vertices, _, entry in walkers:
        assert entry["loop"] and np.allclose(entry["translation"][-1], 0.0, atol=1e-6)
        path = np.array(entry["translation"])[:, [0, 2]] + vertices.mean(axis=0)[[0, 2]]
        inside = ((path[:, None] > boxes[None, :, 0, [0, 2]] - 0.3)
                  & (path[:, None] < boxes[None, :, 1, [0, 2]] + 0.3)).all(axis=2)
        assert not inside.any()

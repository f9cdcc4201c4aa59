"""`vismobile trajectory generate`: collision-free, inside the world, deterministic, and the
camera sees something on most frames; the fly-over for a world without a ceiling."""

import numpy as np
import pytest
import trimesh

from vismobile.geometry.ray import ray_triangle
from vismobile.device.profile import get_profile
from vismobile.world.trajectory import Trajectory
from vismobile.app.walk import counts, walk, waypoints
from vismobile.world.world import World


def box(extents, centre, inward=False):
    mesh = trimesh.creation.box(extents=extents)
    mesh.apply_translation(centre)
    return World(mesh.vertices, mesh.faces[:, ::-1] if inward else mesh.faces)


def rooms() -> World:
    """A 20 x 3 x 12 hall seen from inside, a wall with a 4-unit gap and two pillars."""
    return World.concatenate([box((20, 3, 12), (0, 1.5, 0), inward=True),
                              box((0.3, 3, 8), (0, 1.5, -2)),
                              box((1, 3, 1), (5, 1.5, 3)), box((1, 3, 1), (-6, 1.5, -3))],
                             name="rooms")


def town() -> World:
    """A ground plane and a few blocks: no ceiling, so a fly-over."""
    ground = World([[-50, 0, -50], [50, 0, -50], [50, 0, 50], [-50, 0, 50]],
                   [[0, 2, 1], [0, 3, 2]])
    blocks = [box((8, h, 8), (x, h / 2, z)) for x, z, h in
              ((-20, -20, 12), (15, -10, 20), (0, 20, 8), (25, 25, 15))]
    return World.concatenate([ground, *blocks], name="town")


def crossings(world, poses) -> int:
    """Path segments that meet a triangle (ray cast, t in [0, 1], edges counted as hits)."""
    start, end = poses[:-1, :3], poses[1:, :3]
    with np.errstate(invalid="ignore"):
        t = ray_triangle(start, end - start, world.corners)
    return int((t <= 1.0).any(axis=1).sum())


@pytest.fixture(scope="module")
def hall():
    world = rooms()
    poses, kind, space = walk(world, 240, seed=3)
    return world, poses, kind


def test_walk_is_collision_free_inside_the_world_and_goes_around_the_wall(hall):
    world, poses, kind = hall
    assert kind == "walk" and poses.shape == (240, 5)
    assert crossings(world, poses) == 0
    low, high = world.extent
    assert (poses[:, :3] > low).all() and (poses[:, :3] < high).all()
    assert np.allclose(poses[:, 1], 1.5)  # eye height: half of a 3-unit hall
    assert poses[:, 0].min() < -4 and poses[:, 0].max() > 4  # both sides of the wall
    # It passes the dividing wall (x = 0, z from -6 to 2) only through the gap (z > 2).
    a, b = poses[:-1], poses[1:]
    across = np.flatnonzero(np.sign(a[:, 0]) != np.sign(b[:, 0]))
    assert len(across) and (np.minimum(a[across, 2], b[across, 2]) > 2.0).all()


def test_walk_is_deterministic_with_a_seed(hall):
    world, poses, _ = hall
    assert np.array_equal(walk(world, 240, seed=3)[0], poses)
    assert not np.array_equal(walk(world, 240, seed=4)[0], poses)


def test_playing_the_walk_sends_triangles_on_most_frames(hall):
    from vismobile.culling import Culler
    from vismobile.partition import partition

    world, poses, _ = hall
    profile = get_profile("ipaq-hx2490b")
    trajectory = Trajectory(poses)
    culler = Culler(partition(world, "octree", depth=2), "vfc")
    sent = np.array([len(culler.cull(c).triangles) for c in trajectory.cameras(profile.aspect)])
    assert np.mean(sent > 0) > 0.9
    in_frustum, frames, visible = counts(world, trajectory, profile)
    assert np.mean(visible > 0) > 0.9 and (in_frustum > 0).mean() > 0.9
    marks = waypoints(in_frustum, frames, visible)
    assert set(marks) == {"most_visible", "least_visible", "most_in_frustum", "least_in_frustum"}
    assert len(set(marks.values())) == 4
    assert in_frustum[marks["most_in_frustum"]] == in_frustum.max()
    assert visible.max() == visible[list(frames).index(marks["most_visible"])]


def test_a_world_without_a_ceiling_gets_a_fly_over():
    world = town()
    poses, kind, _ = walk(world, 120, seed=1)
    assert kind == "fly-over"
    low, high = world.extent
    assert crossings(world, poses) == 0 and (poses[:, 1] > high[1]).all()
    assert (poses[:, [0, 2]] > low[[0, 2]]).all() and (poses[:, [0, 2]] < high[[0, 2]]).all()
    in_frustum, frames, visible = counts(world, Trajectory(poses), get_profile("ipaq-hx2490b"))
    assert (in_frustum > 0).all() and (visible > 0).all()


def test_cli_generates_a_plain_csv_that_plays(tmp_path, vismobile_cli):
    rooms().to_obj(tmp_path / "rooms.obj")
    made = vismobile_cli("trajectory", "generate", "rooms.obj", "--seed", "2", "--length", "120",
                     "-o", "walk.csv", cwd=tmp_path)
    assert made.returncode == 0, made.stderr
    assert "wrote walk.csv: walk of 120 frames" in made.stdout
    again = vismobile_cli("trajectory", "generate", "rooms.obj", "--seed", "2", "--length", "120",
                      "-o", "again.csv", "--quiet", cwd=tmp_path)
    assert again.returncode == 0 and again.stderr == ""
    assert (tmp_path / "walk.csv").read_bytes() == (tmp_path / "again.csv").read_bytes()
    from vismobile import generate_trajectory

    same = generate_trajectory(World.from_file(tmp_path / "rooms.obj"), 120, seed=2)
    written = Trajectory.load(tmp_path / "walk.csv")
    assert np.allclose(same.poses, written.poses, atol=1e-3)
    assert same.waypoints == written.waypoints
    table = np.genfromtxt(tmp_path / "walk.csv", delimiter=",", names=True, dtype=None,
                          encoding="ascii")
    assert len(table) == 120 and set(table["waypoint"]) - {""} == {
        "most_visible", "least_visible", "most_in_frustum", "least_in_frustum"}
    played = vismobile_cli("play", "rooms.obj", "--trajectory", "walk.csv", "--structure",
                       "octree:2", "--cull", "vfc", "-o", "run", "--quiet", cwd=tmp_path)
    assert played.returncode == 0, played.stderr
    assert "warning" not in played.stderr


@pytest.mark.parametrize("args, needle", [
    (("nothing.obj",), "nothing.obj"),
    (("rooms.obj", "--length", "1"), "--length"),
    (("rooms.obj", "--clearance", "-1"), "--clearance"),
])
def test_cli_bad_input_is_one_line_exit_2(tmp_path, args, needle, vismobile_cli):
    rooms().to_obj(tmp_path / "rooms.obj")
    done = vismobile_cli("trajectory", "generate", *args, "--quiet", cwd=tmp_path)
    assert done.returncode == 2 and done.stderr.count("\n") == 1
    assert needle in done.stderr and "Traceback" not in done.stderr

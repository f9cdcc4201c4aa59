"""Trajectories: CSV round trip, frame counts, waypoints, and paths that never go through walls."""
import importlib.util
from pathlib import Path

import numpy as np
import pytest

from vismobile.errors import TrajectoryError
from vismobile.open3d_import import raycast_primitive_ids
from vismobile.world.trajectory import Trajectory, pitch_sweep

ROOT = Path(__file__).resolve().parents[1]
INDOOR = ROOT / "trajectories" / "indoor.csv"
OUTDOOR = ROOT / "trajectories" / "outdoor.csv"


def segments_cross(starts, ends, corners, chunk=64):
    """(S,) bool: segment s passes through some triangle (Moller-Trumbore, edges included)."""
    v0, e1, e2 = corners[:, 0], corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]
    out = np.zeros(len(starts), bool)
    for lo in range(0, len(starts), chunk):
        o = starts[lo:lo + chunk, None, :]
        d = (ends - starts)[lo:lo + chunk, None, :]
        p = np.cross(d, e2)
        det = np.einsum("stk,tk->st", p, e1)
        with np.errstate(divide="ignore", invalid="ignore"):
            inv = 1.0 / det
            s = o - v0
            u = np.einsum("stk,stk->st", s, p) * inv
            q = np.cross(s, e1)
            v = np.einsum("stk,stk->st", d, q) * inv
            t = np.einsum("tk,stk->st", e2, q) * inv
            hit = (np.abs(det) > 1e-12) & (u >= 0) & (v >= 0) & (u + v <= 1) & (t >= 0) & (t <= 1)
            out[lo:lo + chunk] = hit.any(axis=1)
    return out


def test_segment_test_finds_a_crossing_and_a_miss():
    tri = np.array([[[0, 0, 0], [1, 0, 0], [0, 1, 0]]], float)
    starts = np.array([[0.2, 0.2, -1], [0.2, 0.2, 0.5], [2, 2, -1]], float)
    ends = np.array([[0.2, 0.2, 1], [0.2, 0.2, 1.0], [2, 2, 1]], float)
    assert segments_cross(starts, ends, tri).tolist() == [True, False, False]


def test_round_trip_keeps_poses_and_waypoints(tmp_path):
    rng = np.random.default_rng(3)
    poses = rng.uniform(-50, 50, (20, 5))
    original = Trajectory(poses, {"A": 3, "B": 17})
    original.save(tmp_path / "t.csv")
    loaded = Trajectory.load(tmp_path / "t.csv")
    assert loaded.waypoints == {"A": 3, "B": 17}
    np.testing.assert_allclose(loaded.poses, poses, atol=1e-3)
    loaded.save(tmp_path / "u.csv")
    assert (tmp_path / "t.csv").read_bytes() == (tmp_path / "u.csv").read_bytes()


def test_iteration_yields_cameras_with_the_given_aspect():
    trajectory = Trajectory(np.zeros((3, 5)))
    cameras = list(trajectory.cameras(aspect=2.0))
    assert len(cameras) == 3 and all(c.aspect == 2.0 for c in cameras)


@pytest.mark.parametrize("text", ["", "frame,x,y,z,yaw,pitch\n0,1,2\n", "a,b\n0,1,2,3,4,5\n",
                                  "frame,x,y,z,yaw,pitch\n1,0,0,0,0,0\n"])
def test_bad_trajectory_files_raise(tmp_path, text):
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(TrajectoryError):
        Trajectory.load(path)


def test_thesis_frame_counts_and_waypoints():
    indoor, outdoor = Trajectory.load(INDOOR), Trajectory.load(OUTDOOR)
    assert len(indoor) == 1476 and len(outdoor) == 1999
    assert indoor.waypoints == dict(A=56, B=124, C=229, D=290, E=462, F=1000, G=1413)
    assert outdoor.waypoints == dict(A=330, B=428, C=719, D=1156)


def test_committed_trajectories_match_their_generator(tmp_path):
    spec = importlib.util.spec_from_file_location("make_trajectories",
                                                  ROOT / "tools" / "make_trajectories.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    module.indoor().save(tmp_path / "indoor.csv")
    module.outdoor().save(tmp_path / "outdoor.csv")
    module.indoor_pitched(module.indoor()).save(tmp_path / "indoor_pitched.csv")
    pitch_sweep(module.outdoor()).save(tmp_path / "outdoor_pitched.csv")
    for name in ("indoor", "outdoor", "indoor_pitched", "outdoor_pitched"):
        assert (tmp_path / f"{name}.csv").read_bytes() == (INDOOR.parent
                                                           / f"{name}.csv").read_bytes()


def test_pitched_paths_look_up_and_down_from_the_same_places(w1):
    level, pitched = Trajectory.load(INDOOR), Trajectory.load(INDOOR.parent / "indoor_pitched.csv")
    inserted = len(pitched) - len(level)
    assert inserted > 0 and pitched.waypoints["G"] == level.waypoints["G"] + inserted
    top = 876  # the stairs segment follows the landing frame
    same = np.concatenate([pitched.poses[:top + 1], pitched.poses[top + 1 + inserted:]])
    assert np.allclose(same[:, :3], level.poses[:, :3])
    assert same[:, 4].max() > 84.0 and same[:, 4].min() < -84.0
    stairs = pitched.poses[top + 1:top + 1 + inserted]
    assert stairs[:, 4].min() < -59.0 and stairs[:, 4].max() > 59.0  # down, then up the ramp
    positions = pitched.poses[:, :3]
    assert not segments_cross(positions[:-1], positions[1:], w1.corners).any()
    outdoor = Trajectory.load(INDOOR.parent / "outdoor_pitched.csv")
    assert np.allclose(outdoor.poses[:, :3], Trajectory.load(OUTDOOR).poses[:, :3])


def test_pitch_sweep_refuses_a_vertical_amplitude():
    with pytest.raises(ValueError, match="amplitude"):
        pitch_sweep(Trajectory.load(OUTDOOR), amplitude=90.0)


def test_paths_move_smoothly():
    for path, step in ((INDOOR, 0.3), (OUTDOOR, 1.5)):
        poses = Trajectory.load(path).poses
        assert np.linalg.norm(np.diff(poses[:, :3], axis=0), axis=1).max() < step
        assert np.abs(np.diff(poses[:, 3])).max() < 8.0  # degrees per frame, unwrapped


def test_indoor_path_never_crosses_a_surface(w1):
    positions = Trajectory.load(INDOOR).poses[:, :3]
    assert not segments_cross(positions[:-1], positions[1:], w1.corners).any()


@pytest.mark.parametrize("name", ["w2", "w3", "w4"])
def test_indoor_path_keeps_clear_of_objects(thesis_world, name):
    world, w1 = thesis_world(name), thesis_world("w1")
    positions = Trajectory.load(INDOOR).poses[:, :3]
    extra = [i for i, n in enumerate(world.object_names) if n not in set(w1.object_names)]
    for index in extra:
        corners = world.corners[world.object_ids == index].reshape(-1, 3)
        low, high = corners.min(axis=0) - 0.3, corners.max(axis=0) + 0.3
        near = ((positions >= low) & (positions <= high)).all(axis=1)
        assert not near.any(), world.object_names[index]


def test_indoor_path_stays_inside_at_eye_height(w1):
    positions = Trajectory.load(INDOOR).poses[:, :3]
    for direction, sign in (((0, -1, 0), 1), ((0, 1, 0), -1)):
        d = np.tile(np.array(direction, float), (len(positions), 1))
        ids = raycast_primitive_ids(w1.vertices, w1.triangles, positions, d)
        assert (ids >= 0).all()
        assert (w1.normals[ids][:, 1] * sign > 0.5).all()  # a floor below, a ceiling above
        if sign > 0:
            corners = w1.corners[ids]
            normal = w1.normals[ids]
            along = normal @ np.array(direction, float)
            t = np.einsum("ij,ij->i", normal, corners[:, 0] - positions) / along
            np.testing.assert_allclose(t, 1.7, atol=0.05)


def test_outdoor_path_never_crosses_a_surface(w5, thesis_world):
    positions = Trajectory.load(OUTDOOR).poses[:, :3]
    assert not segments_cross(positions[:-1], positions[1:], w5.corners).any()
    w6 = thesis_world("w6")
    added = [i for i, n in enumerate(w6.object_names) if n not in set(w5.object_names)]
    objects = w6.subset(np.flatnonzero(np.isin(w6.object_ids, added)))
    assert objects.triangle_count == 7500
    assert not segments_cross(positions[:-1], positions[1:], objects.corners).any()

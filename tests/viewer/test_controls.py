import numpy as np
import pytest

from vismobile.world.camera import Camera
from vismobile.viewer.controls import PITCH_LIMIT, Speeds, mouse_look, overview_pose, step_pose

SPEEDS = Speeds(move=2.0, turn=90.0, climb=1.0, look=45.0, mouse=0.5)
START = np.array([1.0, 2.0, 3.0, 0.0, 0.0])


def test_forward_moves_along_the_camera_heading():
    for yaw in (0.0, 37.0, 200.0):
        pose = START.copy()
        pose[3] = yaw
        moved = step_pose(pose, {"forward"}, 0.5, SPEEDS)
        heading = Camera(pose[:3], yaw).forward
        assert np.allclose(moved[:3] - pose[:3], heading * 1.0)
        back = step_pose(pose, {"back"}, 0.5, SPEEDS)
        assert np.allclose(back[:3] - pose[:3], -heading * 1.0)


def test_forward_stays_level_when_pitched():
    pose = START.copy()
    pose[4] = 30.0
    moved = step_pose(pose, {"forward"}, 1.0, SPEEDS)
    assert moved[1] == pose[1]
    assert np.isclose(np.linalg.norm(moved[[0, 2]] - pose[[0, 2]]), 2.0)


def test_left_turns_toward_the_camera_left_and_opposites_cancel():
    turned = step_pose(START, {"turn_left"}, 0.5, SPEEDS)
    assert turned[3] == 45.0
    right = Camera(START[:3], 0.0).basis()[0]
    assert np.dot(Camera(START[:3], turned[3]).forward, right) < 0
    assert np.array_equal(step_pose(START, {"turn_left", "turn_right", "forward", "back"}, 1.0,
                                    SPEEDS), START)
    assert step_pose(START, {"turn_right"}, 1.0, SPEEDS)[3] == 270.0


def test_height_and_pitch_keys():
    assert step_pose(START, {"rise"}, 2.0, SPEEDS)[1] == 4.0
    assert step_pose(START, {"sink"}, 2.0, SPEEDS)[1] == 0.0
    assert step_pose(START, {"look_up"}, 100.0, SPEEDS)[4] == PITCH_LIMIT
    assert step_pose(START, {"look_down"}, 100.0, SPEEDS)[4] == -PITCH_LIMIT


def test_mouse_drag_right_turns_right_and_up_looks_up():
    pose = mouse_look(START, 10.0, 4.0, SPEEDS)
    assert pose[3] == 355.0 and pose[4] == 2.0
    assert mouse_look(START, 0.0, 1e6, SPEEDS)[4] == PITCH_LIMIT


def test_speeds_scale_with_the_world():
    assert Speeds.for_extent([[0, 0, 0], [40, 6, 20]]).move == pytest.approx(2.0)
    assert Speeds.for_extent([[1, 1, 1], [1, 1, 1]]).move > 0


def test_overview_looks_at_the_world_from_outside():
    extent = np.array([[0.0, 0.0, 0.0], [10.0, 4.0, 20.0]])
    pose = overview_pose(extent)
    assert pose[2] > extent[1, 2]
    to_centre = extent.mean(axis=0) - pose[:3]
    assert np.allclose(Camera(pose[:3], pose[3], pose[4]).forward,
                       to_centre / np.linalg.norm(to_centre))

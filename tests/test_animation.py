"""Animated scenes in the commands (app/animation.py, issue 25): which worlds move, the renderer
posed per frame, and play over W7 and over a world with --motion."""
import json

import numpy as np
import pytest

from vismobile.app.animation import Poser, open_animated
from vismobile.app.playback import load_scene, play
from vismobile.device.profile import get_profile
from vismobile.errors import VisMobileError
from vismobile.render import Renderer, item_buffer
from vismobile.study.thesis import trajectory_for
from vismobile.world.camera import Camera
from vismobile.world.trajectory import Trajectory
from vismobile.world.world import World

from .conftest import refuse

PROFILE = get_profile("ipaq-hx2490b")


def two_boxes():
    """Two unit cubes 4 m apart along x (objects 'still' and 'mover'), wound outward."""
    from vismobile.scenes.crowd import outward_boxes

    v, t = outward_boxes(np.array([[[0, 0, 0], [1, 1, 1]], [[4, 0, 0], [5, 1, 1]]], float))
    return World(v, t, np.repeat([0, 1], 12), ["still", "mover"], "boxes")


def motion_file(path, dx=-2.0):
    path.write_text(json.dumps({"fps": 30, "objects": {"mover": {
        "times": [0, 1], "translation": [[0, 0, 0], [dx, 0, 0]]}}}))
    return path


def test_which_worlds_move(thesis_world, tmp_path):
    assert len(open_animated("w7", thesis_world("w7")).motion) == 67
    assert open_animated("w1", thesis_world("w1")) is None
    world = two_boxes()
    assert open_animated(str(tmp_path / "boxes.obj"), world) is None
    animated = open_animated("boxes.obj", world, motion_file(tmp_path / "m.json"))
    assert animated.moving_object_ids.tolist() == [1]


def test_the_posed_renderer_draws_each_frames_pose(tmp_path):
    world = two_boxes()
    animated = open_animated("boxes.obj", world, motion_file(tmp_path / "m.json"))
    renderer = Renderer(animated.world, PROFILE)
    poser = Poser(animated, renderer)
    camera = Camera((2.5, 0.5, 8.0), aspect=PROFILE.aspect)
    for t in (0.0, 0.5, 1.0):
        poser.pose(t)
        renderer.draw(np.arange(24), camera, kind="item")
        assert np.array_equal(renderer.read_ids(),
                              item_buffer(animated.posed(t), None, camera, PROFILE))
    mover = np.arange(12, 24)  # a frame drawing only the mover poses only it
    for t in (0.25, 0.75):
        poser.pose(t, mover)
        assert poser.posed == 1
        renderer.draw(mover, camera, kind="item")
        assert np.array_equal(renderer.read_ids(),
                              item_buffer(animated.posed(t), mover, camera, PROFILE))
    poser.pose(0.5, np.arange(12))  # only the still cube drawn: nothing to move
    assert poser.posed == 0


def test_play_w7_moves_its_objects_and_sends_the_moving_ones(tmp_path, thesis_world):
    scene = load_scene("w7", "portal:2")
    assert scene.animated is not None and scene.partition.kind == "portal"
    path = Trajectory.load(trajectory_for("w7"))
    result = play(scene, path, "portals+tbfc", PROFILE, frames="stride:200")
    assert result.summary["moving_objects"] == 67 and result.summary["scene_fps"] == 30.0
    assert result.summary["frames"] == 6


def test_play_cli_takes_a_motion_file_and_refuses_a_bad_one(capsys, tmp_path):
    from vismobile.app.cli import main

    two_boxes().to_obj(tmp_path / "boxes.obj")
    Trajectory(np.array([[2.5, 0.5, 8.0, 0.0, 0.0]] * 4)).save(tmp_path / "t.csv")
    motion = motion_file(tmp_path / "m.json")
    args = ["play", str(tmp_path / "boxes.obj"), "--trajectory", str(tmp_path / "t.csv"),
            "--structure", "octree:2", "--quiet"]
    assert main(args + ["-o", str(tmp_path / "run"), "--motion", str(motion),
                        "--fps", "2"]) == 0
    summary = json.loads((tmp_path / "run" / "summary.json").read_text())
    assert summary["moving_objects"] == 1 and summary["scene_fps"] == 2.0
    (tmp_path / "bad.json").write_text('{"objects": {"nobody": {"times": [0]}}}')
    refuse(capsys, args + ["-o", str(tmp_path / "r2"), "--motion", str(tmp_path / "bad.json")],
           "bad.json")
    assert not (tmp_path / "r2").exists()


def test_a_partition_file_does_not_move():
    with pytest.raises(VisMobileError, match="static"):
        load_scene("x.vmp", motion="m.json")


def test_play_regional_picks_per_portal_cell_and_says_which(tmp_path):
    from vismobile.commands.play import regional_choices

    choices = regional_choices("portals+tbfc;vfc+occlusion+tbfc")
    assert choices == ["tbfc+portals", "vfc+tbfc+occlusion"]
    scene = load_scene("w7", "portal:2")
    path = Trajectory.load(trajectory_for("w7"))
    result = play(scene, path, "vfc", PROFILE, frames="stride:100", regional=choices)
    picks = result.summary["regional"]
    assert picks and set(picks.values()) <= set(choices)
    assert set(result.frames["active_stages"]) <= set(choices)
    with pytest.raises(VisMobileError, match="portal structure"):
        play(load_scene("w1", "octree:2"), path, "vfc", PROFILE, frames="stride:600",
             regional=choices)
    with pytest.raises(VisMobileError, match="no stage"):
        regional_choices(" ; ")

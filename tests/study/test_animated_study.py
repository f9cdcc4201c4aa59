"""compare and tune on a world whose objects move (issue 25): W7, each frame judged against the
item buffer of that frame's pose (study/engine.py: TimedCamera, PosedRenderer)."""
import json

import numpy as np

from vismobile.app.cli import main
from vismobile.study import engine
from vismobile.world.trajectory import Trajectory
from vismobile.study.thesis import trajectory_for


def test_the_truth_of_a_moving_world_is_each_frames_pose(tmp_path):
    world = engine.load_world("w7", None)
    animated = engine.animated_of(world)
    assert animated is not None and len(animated.motion) == 67
    path = Trajectory.load(trajectory_for("w7"))
    cameras = engine.frame_cameras(world, path, [0, 90], 240 / 320)
    assert [c.time for c in cameras] == [0.0, 3.0]
    from vismobile.device.profile import get_profile
    from vismobile.render import item_buffer

    profile = get_profile("ipaq-hx2490b")
    buffer = engine.item_buffer_fn(world, profile, False)
    for camera in cameras:  # the cars on the street move between the two frames
        expected = item_buffer(animated.posed(camera.time), None, camera, profile)
        assert np.array_equal(buffer(camera), expected)


def test_compare_and_tune_run_w7_without_a_false_negative(tmp_path, capsys):
    out = tmp_path / "cmp"
    assert main(["compare", "--worlds", "w7", "--structures", "portal:2", "--cull",
                 "portals+tbfc", "--cull", "vfc+occlusion+tbfc", "--profiles", "ipaq-hx2490b",
                 "--frames", "sample:3", "--jobs", "1", "--cache", str(tmp_path / "cache"),
                 "-o", str(out), "--quiet", "--agreement", "0"]) == 0
    runs = json.loads((out / "runs.json").read_text())
    assert len(runs) == 2 and all(r.get("conservative") for r in runs), runs
    assert (out / "report.html").is_file()
    assert main(["tune", "w7", "--structures", "portal:2", "--probe", "3", "--quiet"]) == 0
    text = capsys.readouterr().out
    assert "0 false negatives" in text and "WARNING" not in text

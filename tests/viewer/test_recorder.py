import numpy as np
import pytest

from vismobile.world.trajectory import Trajectory
from vismobile.viewer.recorder import Player, Recorder


def test_records_only_while_on(tmp_path):
    recorder = Recorder()
    recorder.add([0, 0, 0, 0, 0])
    recorder.start()
    for i in range(3):
        recorder.add([i, 1.5, -i, 10.0 * i, 0.0])
    recorder.stop()
    recorder.add([9, 9, 9, 9, 9])
    assert len(recorder) == 3
    saved = recorder.save(tmp_path / "path.csv")
    loaded = Trajectory.load(tmp_path / "path.csv")
    assert np.allclose(loaded.poses, saved.poses, atol=1e-3)
    assert loaded.poses[2].tolist() == [2.0, 1.5, -2.0, 20.0, 0.0]


def test_starting_again_drops_the_old_recording():
    recorder = Recorder()
    recorder.start()
    recorder.add([1, 2, 3, 4, 5])
    recorder.start()
    assert len(recorder) == 0
    with pytest.raises(ValueError):
        recorder.trajectory()


def test_player_pause_step_and_end():
    player = Player(Trajectory(np.arange(20.0).reshape(4, 5)))
    player.advance()
    assert player.frame == 1
    player.paused = True
    player.advance()
    assert player.frame == 1
    player.step(-5)
    assert player.frame == 0
    player.step(10)
    assert player.frame == 3 and player.finished
    player.paused = False
    player.advance()
    assert player.frame == 3
    assert np.array_equal(player.pose(), np.arange(15.0, 20.0))


def test_nearest_waypoint():
    player = Player(Trajectory(np.zeros((100, 5)), {"A": 10, "B": 50}))
    assert player.nearest_waypoint() == ("A", -10)
    player.step(31)
    assert player.nearest_waypoint() == ("B", -19)
    player.step(29)
    assert player.nearest_waypoint() == ("B", 10)
    assert Player(Trajectory(np.zeros((2, 5)))).nearest_waypoint() is None

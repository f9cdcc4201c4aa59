"""The viewer's level-of-detail key: T cycles tau, frames send the levels, the HUD says so
and the god view numbers the objects drawn coarser."""
import numpy as np
import pytest

from vismobile.app.playback import Scene
from vismobile.partition import partition
from vismobile.viewer import Session
from vismobile.viewer.keys import action_pressed
from vismobile.viewer.session import LOD_TAUS


@pytest.fixture
def session(lod_world):
    scene = Scene(lod_world, partition(lod_world, "octree", depth=3), "octree:3")
    s = Session(scene, ("vfc",), "ipaq-hx2490b", structures=("octree:3",))
    s.pose = np.array([0.0, 0.5, 30.0, 0.0, -2.0])  # far from the sphere and the box
    return s


def test_t_cycles_tau_and_frames_send_the_levels(session):
    assert action_pressed("T") == "lod_tau"
    full = session.render()
    session.press("lod_tau")
    assert session.lod_tau == LOD_TAUS[1]
    session.press("lod_tau")
    session.press("lod_tau")  # tau 2 px
    frame = session.render()
    assert frame.info["sent"] < full.info["sent"]
    assert frame.info["lod_full"] == full.info["sent"] and frame.info["lod_coarse"] >= 1
    assert any(line.startswith("LOD tau 2 px") for line in frame.hud)
    assert not np.array_equal(frame.god, full.god)  # level numbers drawn on the god view
    for _ in range(len(LOD_TAUS) - 3):
        session.press("lod_tau")
    assert session.lod_tau is None
    again = session.render()
    assert again.info["sent"] == full.info["sent"] and "lod_tau" not in again.info
    assert np.array_equal(again.image, full.image)

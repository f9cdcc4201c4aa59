"""The hard camera classes place what they say, on any world; the conservativeness sweep runs
one small case end to end and refuses bad arguments with exit status 2."""
import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest

from vismobile.scenes.hard_cameras import CLASSES, WALL_DISTANCE, WALL_NEAR, hard_cameras, moved
from vismobile.scenes.stress import base_world


def test_each_class_is_what_it_says():
    world = base_world()
    cams = hard_cameras(world, 6, seed=3)
    assert len(cams) == 6 * len(CLASSES)
    low, high = world.extent
    for label, cam in cams:
        kind = label.split("_")[0]
        if kind == "pitch":
            assert abs(cam.pitch) >= 89.0
        if kind == "narrow":
            assert cam.fov == 1.0
        if kind == "wide":
            assert cam.fov == 170.0
        if kind == "wall":
            assert cam.near == WALL_NEAR
            # 1e-3 from the plane of some triangle whose box it is next to
            d = np.abs(np.einsum("tj,tj->t", world.normals, cam.eye - world.corners[:, 0]))
            near_box = np.all((world.bounds[:, 0] - 2 * WALL_DISTANCE <= cam.eye)
                              & (cam.eye <= world.bounds[:, 1] + 2 * WALL_DISTANCE), axis=1)
            assert np.any(near_box & np.isclose(d, WALL_DISTANCE, rtol=1e-6))
        else:
            span = high - low
            assert np.all(cam.eye >= low - 0.1 * span - 1e-9)
            assert np.all(cam.eye <= high + 0.1 * span + 1e-9)


def test_moved_keeps_the_view():
    cam = hard_cameras(base_world(), 1, seed=1, classes=("wall",))[0][1]
    far = moved(cam, 1e-3, (1e5, 1e5, 1e5))
    assert far.near == pytest.approx(cam.near * 1e-3)
    assert np.allclose(far.eye, cam.eye * 1e-3 + 1e5)
    assert (far.yaw, far.pitch, far.fov) == (cam.yaw, cam.pitch, cam.fov)


def test_unknown_class_is_refused():
    with pytest.raises(ValueError, match="unknown camera class"):
        hard_cameras(base_world(), 1, classes=("sideways",))


def _sweep_tool():
    spec = importlib.util.spec_from_file_location(
        "conservative_sweep", Path(__file__).resolve().parents[2] / "tools"
        / "conservative_sweep.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules["conservative_sweep"] = module
    spec.loader.exec_module(module)
    return module


def test_sweep_runs_a_small_case(capsys):
    tool = _sweep_tool()
    status = tool.main(["--worlds", "stress", "--cases", "offset-1e5", "--modes", "float32",
                        "--structures", "octree", "--stages", "vfc,cbfc,portals",
                        "--cameras", "1"])
    out = capsys.readouterr().out
    assert status == 0
    assert "| cbfc | 6 | 0 | 0 | 0 | 0 | 0 |" in out  # 5 classes + 1 node corner


@pytest.mark.parametrize("argv", [["--stages", "vfc,nope"], ["--worlds", "/no/such.obj"],
                                  ["--cameras", "0"], ["--modes", "float16"]])
def test_sweep_refuses_bad_arguments(argv, capsys):
    assert _sweep_tool().main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("conservative_sweep: ")

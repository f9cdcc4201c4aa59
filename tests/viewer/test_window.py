"""The real window under Xvfb: scripted keys through pyglet's event path, and the screenshot's
view equals the headless renderer's image of the same camera (scaled up, nearest)."""
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from vismobile.world.camera import Camera
from vismobile.device.profile import get_profile
from vismobile.render import render_rgb

ROOT = Path(__file__).resolve().parents[2]
XVFB = shutil.which("xvfb-run") and shutil.which("Xvfb")
needs_xvfb = pytest.mark.skipif(not XVFB, reason="Xvfb is not installed; `make xvfb` "
                                                 "(as root) installs the Debian xvfb package")


def view(args, tmp_path, xvfb=True, env=None):
    command = [sys.executable, "-m", "vismobile", "view", *args]
    if xvfb:
        command = ["xvfb-run", "-a", "-s", "-screen 0 1280x1024x24", *command]
    environment = dict(os.environ, **(env or {}))
    environment["PYTHONPATH"] = os.pathsep.join([str(ROOT), environment.get("PYTHONPATH", "")])
    return subprocess.run(command, cwd=tmp_path, env=environment, capture_output=True, text=True,
                          timeout=600)


@needs_xvfb
def test_window_shows_the_headless_renderers_image(tmp_path, thesis_world):
    world = thesis_world("w1")
    shot = tmp_path / "shot.png"
    result = view([str(ROOT / "worlds" / "w1.obj"), "--structure", "octree:3", "--cull", "vfc",
                   "--script", "UP*8,LEFT*3,_6,R,UP*4,R,V", "--screenshot", str(shot)], tmp_path)
    assert result.returncode == 0, result.stderr
    sidecar = json.loads(shot.with_suffix(".json").read_text())
    left, top, width, height = sidecar["view"]
    scale = sidecar["scale"]
    shown = np.asarray(Image.open(shot).convert("RGB"))[top:top + height, left:left + width]
    device = shown[::scale, ::scale]
    assert device.shape == (320, 240, 3) and scale == 2
    assert np.array_equal(shown, np.repeat(np.repeat(device, scale, 0), scale, 1))  # nearest
    camera = Camera(**sidecar["camera"])
    expected = render_rgb(world, np.array(sidecar["triangles"], dtype=np.int64), camera,
                          get_profile("ipaq-hx2490b"), sidecar["cull_back"])
    assert np.array_equal(device, expected)
    assert sidecar["hud"][0].startswith("VFC+OCCLUSION")
    # R, UP*4, R, V through the window's key events: a tap takes one frame, so the recording
    # holds the frame of R (standing) and 4 frames moving forward
    lines = (tmp_path / "recorded.csv").read_text().splitlines()
    assert len(lines) == 1 + 5 and lines[1].split(",")[3] != lines[2].split(",")[3]


def test_no_display_is_one_line_and_exit_2(tmp_path):
    obj = tmp_path / "one.obj"
    obj.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    result = view([str(obj), "--structure", "none", "--cull", "none", "--script", "UP"],
                  tmp_path, xvfb=False, env={"DISPLAY": ""})
    assert result.returncode == 2
    assert result.stderr.strip().count("\n") == 0 and "cannot open a window" in result.stderr


def test_bad_script_exits_2(capsys):
    from vismobile.app.cli import main

    assert main(["view", "w1", "--script", "UP*x"]) == 2
    assert "--script" in capsys.readouterr().err


@needs_xvfb
def test_window_flies_through_a_terrain(tmp_path):
    from vismobile.terrain import sources, store

    store.save(tmp_path / "t.vmt", sources.diamond_square(65, seed=2))
    shot = tmp_path / "shot.png"
    result = view(["t.vmt", "--terrain-method", "roam", "--script", "UP*4,T,M,UP*2",
                   "--screenshot", str(shot)], tmp_path)
    assert result.returncode == 0, result.stderr
    hud = json.loads(shot.with_suffix(".json").read_text())["hud"]
    assert hud[0].startswith("tiles at tau 2 px")  # M: roam -> tiles; T: 1 -> 2 px


@needs_xvfb
def test_window_flies_through_a_paged_terrain(tmp_path):
    """view t.vmrpages (Röttger paged in by pages): its own method; M keeps it."""
    from vismobile.app.cli import main
    from vismobile.terrain import sources, store

    store.save(tmp_path / "t.vmt", sources.diamond_square(65, seed=2))
    assert main(["terrain", "tile", str(tmp_path / "t.vmt"), "-o",
                 str(tmp_path / "t.vmrpages")]) == 0
    shot = tmp_path / "shot.png"
    result = view(["t.vmrpages", "--script", "UP*4,T,M,UP*2", "--screenshot", str(shot)],
                  tmp_path)
    assert result.returncode == 0, result.stderr
    hud = json.loads(shot.with_suffix(".json").read_text())["hud"]
    assert hud[0].startswith("roettger at tau 2 px")

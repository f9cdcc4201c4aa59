"""One CLI grammar: --version, help listing valid values, stage and frame syntax, clear errors."""
import csv

import numpy as np
import pytest
import trimesh

from vismobile import __version__
from vismobile.app.cli import build_parser, main
from vismobile.commands import PROFILE_NAMES, STAGE_NAMES
from vismobile.world.trajectory import Trajectory


@pytest.fixture
def ball(tmp_path):
    """A sphere mesh file and a 10-frame walk toward it."""
    path = tmp_path / "ball.stl"
    trimesh.creation.icosphere(subdivisions=2, radius=2.0).export(path)
    poses = np.column_stack([np.zeros(10), np.zeros(10), np.linspace(12, 6, 10), np.zeros(10),
                             np.zeros(10)])
    Trajectory(poses, {"A": 4}).save(tmp_path / "walk.csv")
    return path, tmp_path / "walk.csv"


def test_version(capsys):
    with pytest.raises(SystemExit) as stop:
        main(["--version"])
    assert stop.value.code == 0 and capsys.readouterr().out.strip() == f"vismobile {__version__}"


def test_help_names_every_stage_and_profile():
    from vismobile.culling import STAGES
    from vismobile.device.profile import PROFILES

    assert set(STAGE_NAMES) == set(STAGES) and set(PROFILE_NAMES) == set(PROFILES)
    play_help = build_parser()._subparsers._group_actions[0].choices["play"].format_help()
    assert all(name in play_help for name in STAGE_NAMES + PROFILE_NAMES)


def test_building_the_parser_imports_no_numpy():
    # --help must stay light: every command module is imported to build the parser, so heavy
    # imports belong inside run() (commands/__init__.py spells out valid values for this).
    import subprocess
    import sys
    from pathlib import Path

    code = ("import sys; from vismobile.app.cli import build_parser; build_parser(); "
            "print(sorted(m for m in sys.modules if m.split('.')[0] in ('numpy', 'numba')))")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          cwd=Path(__file__).resolve().parents[1], timeout=120)
    assert done.returncode == 0 and done.stdout.strip() == "[]", done.stdout + done.stderr


def test_every_option_has_help():
    for name, sub in build_parser()._subparsers._group_actions[0].choices.items():
        for action in sub._actions:
            if action.option_strings and action.dest != "help":
                assert action.help, f"{name} {action.option_strings}"


def test_play_takes_both_stage_separators_prints_plus_and_selects_frames(ball, capsys):
    path, walk = ball
    out = walk.parent / "run"
    assert main(["play", str(path), "--trajectory", str(walk), "--structure", "octree:2",
                 "--cull", "vfc,bfc", "-o", str(out), "--frames", "stride:3", "--images", "2",
                 "--quiet"]) == 0
    assert "cull vfc+bfc" in capsys.readouterr().out
    with open(out / "frames.csv", newline="") as handle:
        rows = list(csv.DictReader(handle))
    assert [int(r["frame"]) for r in rows] == [0, 3, 6, 9]
    assert sorted(p.name for p in (out / "frames").iterdir()) == ["frame_00000.png",
                                                                   "frame_00006.png"]
    assert main(["play", str(path), "--trajectory", str(walk), "--structure", "octree:2",
                 "--cull", "vfc+bfc", "-o", str(walk.parent / "again"), "--quiet"]) == 0


def test_portals_on_another_structure_is_an_error(ball, capsys):
    path, walk = ball
    assert main(["play", str(path), "--trajectory", str(walk), "--structure", "octree:2",
                 "--cull", "vfc+portals", "-o", str(walk.parent / "p"), "--quiet"]) == 2
    assert "portal structure" in capsys.readouterr().err


def test_bad_frame_selection_is_one_line(ball, capsys):
    path, walk = ball
    assert main(["play", str(path), "--trajectory", str(walk), "-o", str(walk.parent / "f"),
                 "--frames", "every:2", "--quiet"]) == 2
    assert "bad frame selection" in capsys.readouterr().err

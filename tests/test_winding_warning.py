"""The one-line warning when back-face culling is on and closed rooms face outward (issue 31)."""
import numpy as np
import pytest
import trimesh

from vismobile.app.cli import main
from vismobile.commands import BACKFACE_NAMES, warn_winding
from vismobile.culling import BACKFACE_STAGES
from vismobile.world.trajectory import Trajectory
from vismobile.world.world import World


@pytest.fixture
def box_room(tmp_path):
    """A trimesh box room (faces pointing outward, as trimesh makes them) with a walk inside."""
    trimesh.creation.box(extents=(10.0, 4.0, 10.0)).export(tmp_path / "room.ply")
    frames = 6
    poses = np.column_stack([np.linspace(-3, 3, frames), np.zeros(frames), np.zeros(frames),
                             np.linspace(0, 300, frames), np.zeros(frames)])
    Trajectory(poses, {}).save(tmp_path / "walk.csv")
    return tmp_path


def test_backface_names_are_the_cullers():
    assert set(BACKFACE_NAMES) == set(BACKFACE_STAGES)


def test_helper_warns_only_with_a_backface_stage_and_outward_rooms(box_room):
    world = World.from_file(box_room / "room.ply")
    line = warn_winding(world, ("vfc", "bfc"), "room.ply")
    assert line.startswith("warning: room.ply: 12 of 12 room triangles") and "--fix-winding" in line
    assert warn_winding(world, ("vfc",), "room.ply") is None
    assert warn_winding(world, ("bfc",), "room.ply", fixed=True) is None


def test_play_warns_in_one_line_and_not_after_fix_winding(box_room, capsys):
    args = ["play", str(box_room / "room.ply"), "--trajectory", str(box_room / "walk.csv"),
            "--cull", "bfc", "--profile", "desktop", "--quiet"]
    assert main(args + ["-o", str(box_room / "a")]) == 0
    err = [line for line in capsys.readouterr().err.splitlines() if "room triangles" in line]
    assert len(err) == 1 and "back-face culling (bfc)" in err[0] and "--fix-winding" in err[0]
    assert main(args + ["-o", str(box_room / "b"), "--fix-winding"]) == 0
    assert "room triangles" not in capsys.readouterr().err
    assert main(args[:-5] + ["--cull", "none", "--profile", "desktop", "--quiet", "-o",
                             str(box_room / "c")]) == 0
    assert "room triangles" not in capsys.readouterr().err


def test_view_and_compare_warn(box_room, capsys):
    # The warning comes before the window opens (without a display the window then fails).
    main(["view", str(box_room / "room.ply"), "--structure", "none", "--cull", "bfc",
          "--script", "UP", "--screenshot", str(box_room / "s.png")])
    assert "room triangles face away" in capsys.readouterr().err
    code = main(["compare", "--worlds", str(box_room / "room.ply"), "--trajectory",
                 str(box_room / "walk.csv"), "--structures", "octree:2", "--cull", "vfc+tbfc",
                 "--profiles", "desktop", "--frames", "sample:2", "--agreement", "0",
                 "--quiet", "-o", str(box_room / "cmp"), "--cache", str(box_room / "cache"),
                 "--jobs", "1"])
    assert code == 0 and "back-face culling (tbfc)" in capsys.readouterr().err

"""`vismobile partition`: builds, saves, reports; bad parameters exit 2 with one line."""
from vismobile.app.cli import main

from vismobile.scenes.objects import PACKAGE_MODELS

MODEL = PACKAGE_MODELS / "suzanne.obj.gz"


def test_partition_command(tmp_path, capsys):
    out = tmp_path / "s.vmp"
    assert main(["partition", str(MODEL), "--structure", "grid", "--slabs", "x:0.2,0.2,0.3,0.3",
                 "--slabs", "z:2", "-o", str(out)]) == 0
    text = capsys.readouterr().out
    assert out.exists() and "build time" in text and "refs/tri" in text and "KB" in text
    assert main(["partition", str(MODEL), "--structure", "bsp", "--min-leaf", "4", "-o", str(out)]) == 0


def test_bad_depth_exits_2(tmp_path, capsys):
    assert main(["partition", str(MODEL), "--depth", "9", "-o", str(tmp_path / "x.vmp")]) == 2
    assert "--depth must be 1..8" in capsys.readouterr().err  # commands/options.py RANGES


def test_structure_specs_and_options_are_one_grammar(tmp_path, capsys):
    out = tmp_path / "g.vmp"
    assert main(["partition", str(MODEL), "--structure", "grid:4", "--out", str(out)]) == 0
    assert "structure   grid:auto=False,slabs=4x4x4" in capsys.readouterr().out
    assert main(["partition", str(MODEL), "-s", "octree:3", "-o", str(out)]) == 0
    assert "structure   octree:3" in capsys.readouterr().out
    assert main(["partition", str(MODEL), "-s", "octree:3", "--depth", "4", "-o", str(out)]) == 2
    assert "depth given twice" in capsys.readouterr().err

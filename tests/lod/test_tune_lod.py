"""tune --max-error-px: the fastest tolerance up to the budget, with its image error."""
import json

import numpy as np

from vismobile.app.cli import main
from vismobile.study.lod_tune import taus_under
from vismobile.world.trajectory import Trajectory


def test_taus_under_a_budget():
    assert taus_under(1.0) == [0.25, 0.5, 1.0]
    assert taus_under(3.0) == [0.25, 0.5, 1.0, 2.0, 3.0]
    assert taus_under(0.0) == [0.0]


def test_tune_picks_a_tau_within_the_budget(lod_world, tmp_path, capsys):
    mesh = tmp_path / "scene.obj"
    lod_world.to_obj(mesh)
    z = np.linspace(8.0, 40.0, 12)
    poses = np.stack([np.zeros(12), np.full(12, 0.5), z, np.zeros(12), np.full(12, -2.0)], 1)
    Trajectory(poses).save(tmp_path / "walk.csv")
    out = tmp_path / "tune.json"
    assert main(["tune", str(mesh), "--trajectory", str(tmp_path / "walk.csv"), "--probe", "4",
                 "--structures", "octree:3", "--max-error-px", "2", "--cache",
                 str(tmp_path / "cache"), "-o", str(out), "--quiet"]) == 0
    text = capsys.readouterr().out
    assert "level of detail under 2 px" in text and "<- pick" in text
    lod = json.loads(out.read_text())["lod"]
    assert 0 < lod["tau"] <= 2.0 and [r["tau"] for r in lod["rows"]] == [0.25, 0.5, 1.0, 2.0]
    pick = next(r for r in lod["rows"] if r["tau"] == lod["tau"])
    assert pick["frame_ms"] == min(r["frame_ms"] for r in lod["rows"])
    assert pick["triangles"] < lod["full"]["triangles"]
    assert all(r["psnr_db_min"] is None or r["psnr_db_min"] > 30 for r in lod["rows"])

"""compare --lod: one run per tolerance, each measuring PSNR against its full-detail frames."""
import json

import numpy as np
import pytest

from vismobile.study.matrix import RunSpec, SelectionError, expand, parse_lod
from vismobile.study.tasks import Context, execute
from vismobile.world.trajectory import Trajectory


def test_lod_axis_expands_and_keeps_old_keys():
    assert parse_lod("none,1,2.5,1") == [None, 1.0, 2.5]
    with pytest.raises(SelectionError):
        parse_lod("-1")
    plain = expand("w1", "octree:3", "vfc", "ipaq-hx2490b", "sample:2")
    both = expand("w1", "octree:3", "vfc", "ipaq-hx2490b", "sample:2", lod="none,1")
    assert [s.lod_tau for s in both] == [None, 1.0]
    assert both[0].key("x") == plain[0].key("x") and both[1].key("x") != plain[0].key("x")
    assert "lod_tau" not in plain[0].to_dict()


def test_a_lod_run_records_psnr_and_fewer_triangles(lod_world, tmp_path):
    mesh = tmp_path / "scene.obj"
    lod_world.to_obj(mesh)
    z = np.linspace(6.0, 40.0, 5)
    poses = np.stack([np.zeros(5), np.full(5, 0.5), z, np.zeros(5), np.full(5, -2.0)], axis=1)
    Trajectory(poses).save(tmp_path / "walk.csv")
    context = Context(tmp_path, tmp_path / "out", tmp_path / "worlds", tmp_path / "cache")
    base = RunSpec(str(mesh), str(tmp_path / "walk.csv"), "octree:3", "vfc", "ipaq-hx2490b")
    full = execute(base, context)
    lod = execute(RunSpec(*list(base.to_dict().values()), lod_tau=2.0), context)
    s = lod["summary"]
    assert s["lod_tau"] == 2.0 and s["psnr_db_min"] > 30.0
    assert s["triangles_sent"]["mean"] < full["summary"]["triangles_sent"]["mean"]
    assert s["triangles_full"]["mean"] == full["summary"]["triangles_sent"]["mean"]
    assert len(lod["frames"]["psnr_db"]) == 5
    json.dumps(lod)  # no infinities: identical frames are null
    assert (tmp_path / "cache" / "lod").is_dir()  # the chains are cached for the next run


def test_compare_sweeps_lod_and_reports_it(lod_world, tmp_path):
    from vismobile.study.report import write_report
    from vismobile.study.runner import run_matrix

    mesh = tmp_path / "scene.obj"
    lod_world.to_obj(mesh)
    z = np.linspace(6.0, 40.0, 4)
    poses = np.stack([np.zeros(4), np.full(4, 0.5), z, np.zeros(4), np.full(4, -2.0)], axis=1)
    Trajectory(poses).save(tmp_path / "walk.csv")
    specs = expand(str(mesh), "octree:3", "vfc", "ipaq-hx2490b,nokia-n82", "all",
                   {str(mesh): str(tmp_path / "walk.csv")}, lod="none,1,4")
    context = Context(tmp_path, tmp_path / "out", tmp_path / "worlds", tmp_path / "cache")
    records = run_matrix(specs, context, processes=1, progress=False)
    assert not [r for r in records if "error" in r]
    sent = {(r["spec"]["profile"], r["spec"].get("lod_tau")): r["summary"]["triangles_sent"]["mean"]
            for r in records}
    assert sent[("ipaq-hx2490b", 4.0)] < sent[("ipaq-hx2490b", 1.0)] < sent[("ipaq-hx2490b",
                                                                                None)]
    header = (tmp_path / "out" / "runs.csv").read_text().splitlines()[0].split(",")
    assert header[-3:] == ["lod_tau", "psnr_db_min", "psnr_db_mean"]
    page = write_report(records, tmp_path / "report.html").read_text()
    assert "id='lod'" in page and "run time against image error" in page


@pytest.mark.parametrize("value", ["-1", "abc", "nan", "1e9"])
def test_a_bad_lod_list_is_one_line_and_exit_2(value, tmp_path, capsys):
    from vismobile.app.cli import main

    assert main(["compare", "--worlds", "w1", "--structures", "octree:3", "--cull", "vfc",
                 f"--lod={value}", "-o", str(tmp_path / "c")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--lod" in err[0] and not (tmp_path / "c").exists()

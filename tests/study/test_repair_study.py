"""compare --repair and tune --repair (issue 29): the study loads each world repaired
(files/loader.repaired) in every worker, keeps a repaired world's runs and partitions apart
from the unrepaired ones, and says so in its records; bad values are refused in one line."""
import json

import numpy as np

from vismobile.app.cli import main
from vismobile.files.loader import load_world
from vismobile.partition import load_partition
from vismobile.world.trajectory import Trajectory


def _room(tmp_path, literal):
    """The crease room (T-junctions along its far wall's foot) as an OBJ, and a 6-frame walk
    inside it looking at the crease."""
    world = tmp_path / "crease.obj"
    literal.crease_world().to_obj(world)
    frames = 6
    poses = np.column_stack([np.linspace(0.8, 3.2, frames), np.full(frames, 1.6),
                             np.full(frames, 1.0), np.linspace(-30, 30, frames),
                             np.full(frames, -20.0)])
    path = tmp_path / "walk.csv"
    Trajectory(poses, {}).save(path)
    return world, path


def test_compare_repairs_every_world_and_keeps_its_runs_apart(tmp_path, literal, capsys):
    world, path = _room(tmp_path, literal)
    plain, fixed = load_world(world), load_world(world, "tjunctions")
    assert fixed.triangle_count > plain.triangle_count  # the crease's triangles split
    out = tmp_path / "out"
    common = ["compare", "--worlds", str(world), "--trajectory", str(path), "--structures",
              "grid", "--cull", "vfc", "--profiles", "ipaq-hx2490b", "--frames", "sample:2",
              "--agreement", "1", "--jobs", "1", "--cache", str(tmp_path / "cache"),
              "--quiet", "-o", str(out)]
    assert main(common + ["--repair", "tjunctions"]) == 0
    repaired = [json.loads(p.read_text()) for p in (out / "runs").glob("*.json")]
    assert len(repaired) == 1
    summary = repaired[0]["summary"]
    assert summary["repair"] == "tjunctions"
    assert summary["world_triangles"] == fixed.triangle_count
    assert summary["conservative"]
    assert "worlds repaired: tjunctions" in (out / "report.html").read_text()
    agreement = json.loads((out / "agreement.json").read_text())
    assert agreement and all(a["world"] == str(world) for a in agreement)
    # the same selection unrepaired is a run of its own, on the original triangles
    assert main(common) == 0
    runs = {p.name: json.loads(p.read_text()) for p in (out / "runs").glob("*.json")}
    assert len(runs) == 2
    counts = sorted(r["summary"]["world_triangles"] for r in runs.values())
    assert counts == [plain.triangle_count, fixed.triangle_count]
    assert sum("repair" in r["summary"] for r in runs.values()) == 1
    # each world's partition cached once per geometry, the repaired one flagged
    cached = [load_partition(p).world
              for p in (tmp_path / "cache" / "partitions").glob("*.vmp")]
    assert sorted((w.triangle_count, w.repair == "tjunctions") for w in cached) == \
        [(plain.triangle_count, False), (fixed.triangle_count, True)]


def test_tune_repairs_its_world(tmp_path, literal, capsys):
    """(octree:2: a structure the compare test above did not keep in this process's memory,
    so tune builds it and caches its file.)"""
    world, path = _room(tmp_path, literal)
    fixed = load_world(world, "tjunctions")
    cache = tmp_path / "cache"
    assert main(["tune", str(world), "--trajectory", str(path), "--probe", "2",
                 "--structures", "octree:2", "--repair", "tjunctions", "--cache", str(cache),
                 "--quiet", "-o", str(tmp_path / "t.json")]) == 0
    assert json.loads((tmp_path / "t.json").read_text())["repair"] == "tjunctions"
    cached = [load_partition(p).world for p in (cache / "partitions").glob("*.vmp")]
    assert cached and all(w.repair == "tjunctions" and w.digest() == fixed.digest()
                          for w in cached)


def test_bad_repair_values_are_refused_in_one_line(tmp_path, literal, capsys):
    world, path = _room(tmp_path, literal)
    for argv in (["compare", "--worlds", str(world), "--trajectory", str(path), "-o",
                  str(tmp_path / "c")],
                 ["tune", str(world), "--trajectory", str(path)]):
        capsys.readouterr()
        try:
            rc = main(argv + ["--repair", "tjunction"])
        except SystemExit as exit:
            rc = exit.code
        err = capsys.readouterr().err.strip().splitlines()
        assert rc == 2 and "--repair" in err[-1] and "invalid choice" in err[-1], err
        assert not (tmp_path / "c").exists()

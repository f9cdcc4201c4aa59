"""`vismobile compare --terrain`: the pixel-knob sweep along paths, CSV, JSON and report."""
import csv

from vismobile.app.cli import main


def test_sweep_writes_csv_json_and_report(tmp_path, capsys):
    terrain = tmp_path / "t.vmt"
    assert main(["terrain", "build", "fractal", "--size", "129", "--seed", "4", "-o",
                 str(terrain)]) == 0
    out = tmp_path / "sweep"
    assert main(["compare", "--terrain", str(terrain), "--methods", "tiles,roam,roam/2000",
                 "--taus", "1,4", "--paths", "circle:fast", "--frames", "sample:2", "--out",
                 str(out), "--quiet"]) == 0
    with open(out / "terrain.csv") as f:
        rows = list(csv.DictReader(f))
    assert [(r["method"], float(r["tau"])) for r in rows] == [
        ("tiles", 1.0), ("tiles", 4.0), ("roam", 1.0), ("roam", 4.0), ("roam/2000", 1.0),
        ("roam/2000", 4.0)]
    for r in rows:
        assert r["frames"] == "2" and float(r["triangles"]) > 0
        if r["method"] in ("tiles", "roam"):
            assert float(r["sample_error_max"]) <= float(r["tau"])
    assert float(rows[2]["triangles"]) > float(rows[3]["triangles"])
    assert float(rows[4]["triangles"]) <= 2000
    page = (out / "report.html").read_text()
    assert "pixel knob" in page and "roam/2000" in page and "data:image/png" in page
    # A recommendation first (the fastest within 1 px of exact error) and a picture.
    assert page.index("What to use") < page.index("pixel knob")
    assert "the terrain from above with the camera paths" in page
    printed = capsys.readouterr().out
    within = [r for r in rows if float(r["sample_error_max"]) <= 1.0]
    best = min(within, key=lambda r: (float(r["lod_ms"]) + float(r["render_ms"]),
                                      float(r["triangles"])))
    assert f"use on the circle fast path: {best['method']}, tau {float(best['tau']):g} px" \
        in printed
    assert (out / "terrain.json").stat().st_size > 0


def test_sweep_runs_the_objects_as_play_does(tmp_path, capsys):
    """A .vmt with placed objects: each row adds the objects culled by vfc+horizon and drawn at
    their LOD within the row's tau, checked against the item buffer (0 dropped)."""
    from vismobile.terrain import sources, store
    from vismobile.terrain.placement import place_objects

    hm = sources.diamond_square(129, seed=4, roughness=0.5, relief=0.12)
    terrain = tmp_path / "objects.vmt"
    store.save(terrain, hm, place_objects(hm, 3, seed=2, height=5.0))
    out = tmp_path / "sweep"
    assert main(["compare", "--terrain", str(terrain), "--methods", "tiles,roettger",
                 "--taus", "0.5,8", "--paths", "circle:fast", "--frames", "sample:2", "--out",
                 str(out), "--cache", str(tmp_path / "cache"), "--quiet"]) == 0
    with open(out / "terrain.csv") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 4
    for r in rows:
        assert int(r["objects_dropped"]) == 0
        assert 0 < float(r["object_triangles"]) <= float(r["object_triangles_full"])
    for method in ("tiles", "roettger"):
        fine, coarse = (float(r["object_triangles"]) for r in rows if r["method"] == method)
        assert coarse < fine  # the same knob coarsens the objects
    assert "The objects on the terrain" in (out / "report.html").read_text()
    assert "0 visible object triangles dropped" in capsys.readouterr().out


def test_bad_sweep_options_exit_2_with_one_line(tmp_path, capsys):
    terrain = tmp_path / "t.vmt"
    assert main(["terrain", "build", "fractal", "--size", "65", "-o", str(terrain)]) == 0
    capsys.readouterr()
    for option, value in (("--methods", "tiles,lod"), ("--taus", "1,-2"),
                          ("--paths", "spiral:fast"), ("--frames", "every:3"),
                          ("--methods", "roam/x")):
        assert main(["compare", "--terrain", str(terrain), option, value, "--out",
                     str(tmp_path / "o"), "--quiet"]) == 2
        err = capsys.readouterr().err
        assert err.startswith("vismobile: error:") and option in err and err.count("\n") == 1
    assert main(["compare", "--terrain", str(tmp_path / "missing.vmt"), "--out",
                 str(tmp_path / "o"), "--quiet"]) == 2

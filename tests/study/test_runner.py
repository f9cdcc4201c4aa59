"""The resumable runner on the tiny world, and the HTML report it feeds."""
import json

import numpy as np
import pytest

from vismobile.study import runner, tasks
from vismobile.study.matrix import RunSpec
from vismobile.study.report import best_run, find_run, pareto_png, write_report
from vismobile.study.runner import Context, run_matrix


def test_every_run_finishes_with_per_frame_rows(study):
    _, specs, records = study
    assert [r["spec"]["cull"] for r in records] == [s.cull for s in specs]
    for record in records:
        assert "error" not in record, record.get("error")
        frames = record["frames"]
        assert frames["frame"] == [0.0, 2.0, 5.0, 7.0]   # sample:4 plus waypoints A, B
        assert np.allclose(np.add(frames["cull_ms"], frames["render_ms"]), frames["frame_ms"])


def test_conservative_runs_have_no_false_negatives(study):
    for record in study[2]:
        summary = record["summary"]
        assert summary["false_negatives_total"] == 0
        assert summary["tightness"]["mean"] >= 1.0


def test_no_culling_sends_everything(study):
    record = study[2][0]
    assert record["spec"]["cull"] == "none"
    assert set(record["frames"]["triangles_sent"]) == {record["summary"]["world_triangles"]}


def test_finished_runs_are_reused(study, monkeypatch):
    context, specs, records = study

    def refuse(*args):
        raise AssertionError("a finished run was executed again")

    monkeypatch.setattr(tasks, "execute", refuse)
    again = run_matrix(specs, context, processes=1, progress=False)
    assert [r["key"] for r in again] == [r["key"] for r in records]
    assert len(list((context.out / "runs").glob("*.json"))) == len(specs)


def test_runs_carry_each_device_models_frame_time(study):
    from vismobile.device.costmodel import DEVICES, device_model, label

    for record in study[2]:
        model = record["summary"]["model"]
        assert set(model) == set(DEVICES)
        for device in DEVICES:
            per_frame = np.array(record["frames"][f"model_ms:{device}"])
            # Every modelled frame costs at least the device's fixed render time.
            assert np.all(per_frame >= device_model(device).cost.render_base_ms)
            assert np.isclose(model[device]["frame_ms"]["mean"], per_frame.mean())
            assert model[device]["label"] == label(device) != label(None)


def test_tables_hold_one_row_per_run(study):
    context, specs, _ = study
    lines = (context.out / "runs.csv").read_text().splitlines()
    assert len(lines) == len(specs) + 1 and lines[0].startswith("world,structure,cull")
    assert "model_ms:ipaq-hx2490b" in lines[0].split(",")
    assert "model_ms:nokia-n82" in lines[0].split(",")
    assert len(json.loads((context.out / "runs.json").read_text())) == len(specs)


def test_a_failing_run_is_recorded_not_fatal(tmp_path, world_file, trajectory_file):
    context = Context("/", tmp_path / "out", tmp_path / "worlds", tmp_path / "cache")
    spec = RunSpec(str(world_file), str(trajectory_file), "octree:2", "vfc", "no-such-device",
                   "sample:2")
    [record] = run_matrix([spec], context, processes=1, progress=False)
    assert "no-such-device" in record["error"]
    assert not (context.out / "runs").exists() or not list((context.out / "runs").iterdir())


def test_report_is_self_contained(study, tmp_path):
    _, _, records = study
    path = write_report(records, tmp_path / "report.html")
    text = path.read_text()
    assert text.count("data:image/png;base64,") >= 4
    assert "http://" not in text and "https://" not in text and "<script" not in text
    world = records[0]["spec"]["world"]
    pareto_png(records, world, "ipaq-hx2490b", tmp_path / "pareto.png")
    assert (tmp_path / "pareto.png").read_bytes()[:4] == b"\x89PNG"
    assert best_run(records, world)["summary"]["conservative"]


def test_the_report_answers_what_to_use_per_device_first(study, tmp_path):
    from vismobile.study.report import answer_rows

    _, _, records = study
    world = records[0]["spec"]["world"]
    rows, _ = answer_rows(records, world)
    # One row per device model, then this machine; each names where its time comes from.
    assert [row[1] for row in rows] == ["iPaq hx2490b model", "Nokia N82 model",
                                        "measured here"]
    best = best_run(records, world, device="nokia-n82")
    assert best["spec"]["cull"] in rows[1][2] and rows[1][-1] == "0 (conservative)"
    # A tune result for the iPaq becomes its recommendation, with its interval and ties.
    tuned = {"world": world, "text": "tune text", "result": {
        "world": world, "profile": "ipaq-hx2490b", "cost": "device", "probe_frames": [0, 2, 5],
        "choice": {"structure": "bsp", "cull": "vfc+occlusion", "predicted_ms": 100.0,
                   "low_ms": 95.0, "high_ms": 104.0},
        "tied": [{"structure": "octree:2", "cull": "vfc+occlusion"}]}}
    rows, _ = answer_rows(records, world, [tuned])
    assert "bsp vfc+occlusion" in rows[0][2] and "tied: octree:2 vfc+occlusion" in rows[0][2]
    # One figure per pick: the compared run's mean with its own interval, not tune's estimate.
    run = find_run(records, world, "bsp", "vfc+occlusion", "ipaq-hx2490b")
    ms = run["summary"]["model"]["ipaq-hx2490b"]["frame_ms"]["mean"]
    assert rows[0][3].startswith("tune, 3 probe frames; timed over 4 compared frames")
    assert f">{ms:,.1f} <span" in rows[0][4] and "[95.0–104.0]" not in rows[0][4]
    # A pick the comparison did not run keeps tune's estimate and says so.
    unrun = {**tuned, "result": {**tuned["result"], "choice": {
        **tuned["result"]["choice"], "structure": "octree:2", "cull": "vfc+bfc"}}}
    rows, _ = answer_rows(records, world, [unrun])
    assert rows[0][3] == "tune, 3 probe frames (not compared)" and "[95.0–104.0]" in rows[0][4]
    # Every row has an interval: the N82 and this machine's too.
    assert all("[" in row[4] for row in rows)
    text = write_report(records, tmp_path / "r.html", tunes=[tuned]).read_text()
    # The answer table comes before any figure; no missed pixels: a sentence, not a plot.
    assert text.index("ms per frame [95% interval]") < text.index("<img")
    assert "no missed-pixel plot" in text


def test_profiles_measured_alike_run_once(tmp_path, world_file, trajectory_file, monkeypatch):
    """The iPaq and the N82 share screen, vertex format and batch size: one execution serves
    both (identical timings, which two executions would not give); desktop runs on its own."""
    context = Context("/", tmp_path / "out", tmp_path / "worlds", tmp_path / "cache")
    specs = [RunSpec(str(world_file), str(trajectory_file), "octree:2", "vfc", profile,
                     "sample:4") for profile in ("ipaq-hx2490b", "nokia-n82", "desktop")]
    assert runner.reusable_runs(specs, context) == (0, 2)
    executed = []
    real = tasks.execute
    monkeypatch.setattr(tasks, "execute",
                        lambda spec, ctx: executed.append(spec.profile) or real(spec, ctx))
    ipaq, n82, desktop = run_matrix(specs, context, processes=1, progress=False)
    assert executed == ["ipaq-hx2490b", "desktop"]
    assert n82["spec"]["profile"] == "nokia-n82" and n82["measured_by"] == ipaq["key"]
    assert n82["key"] != ipaq["key"] and n82["frames"]["cull_ms"] == ipaq["frames"]["cull_ms"]
    assert "measured_by" not in desktop
    assert desktop["frames"]["visible_pixels"] != ipaq["frames"]["visible_pixels"]  # 640x480
    assert len(list((context.out / "runs").glob("*.json"))) == 3
    assert runner.reusable_runs(specs, context) == (3, 0)
    monkeypatch.setattr(tasks, "execute", lambda *a: pytest.fail("a finished run ran again"))
    again = run_matrix(specs, context, processes=1, progress=False)
    assert [r["key"] for r in again] == [ipaq["key"], n82["key"], desktop["key"]]


def test_the_report_shows_one_figure_per_pick_in_the_table_and_the_tune_section(
        study, tmp_path, world, trajectory, profile):
    from vismobile.study.report import _picks, pick_mismatches
    from vismobile.study.tune import tune

    _, _, records = study
    name = records[0]["spec"]["world"]
    result = tune(world, trajectory, profile, probe=4, structures="octree:2,bsp")
    result.world = name
    item = {"world": name, "text": result.report(), "result": result.to_dict()}
    page = write_report(records, tmp_path / "r.html", tunes=[item]).read_text()
    picks = _picks(page)
    key = f"{name}|ipaq-hx2490b"
    figures = [text for k, text in picks if k == key]
    # The summary table, the world's table and the tune section: the same figure, three times.
    assert len(figures) == 3 and len(set(figures)) == 1 and "[" in figures[0]
    assert pick_mismatches(page) == []
    assert "<h2>Automatic configuration" in page and "tune's full output" in page
    assert "<td class='l'>vfc</td>" in page or "<td class='l'>occlusion</td>" in page
    # The check finds a page that contradicts itself.
    broken = page.replace(figures[0], "1.0", 1)
    assert pick_mismatches(broken) and key in pick_mismatches(broken)[0]


def test_pareto_labels_do_not_overlap():
    from vismobile.study.report_figures import place_labels

    # Six front points crowded into one corner of a 500 x 250 pt axes.
    xs = np.array([0.10, 0.11, 0.12, 0.13, 0.115, 0.125])
    ys = np.array([0.50, 0.51, 0.49, 0.50, 0.52, 0.48])
    texts = ["1", "2–3", "4", "5", "6–9", "10"]
    offsets = place_labels(xs, ys, texts, (500.0, 250.0))
    boxes = []
    for x, y, text, (dx, dy) in zip(xs, ys, texts, offsets):
        left, bottom = x * 500 + dx, y * 250 + dy
        boxes.append((left, bottom, left + 5.5 * len(text) + 4, bottom + 11))
    for i in range(len(boxes)):
        for j in range(i):
            a, b = boxes[i], boxes[j]
            assert a[2] <= b[0] or b[2] <= a[0] or a[3] <= b[1] or b[3] <= a[1], (i, j)
    assert offsets[0] == (4, 4)  # an uncrowded label stays beside its point

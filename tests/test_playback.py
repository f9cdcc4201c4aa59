"""Playback: frames.csv / summary.json contents, images identical across runs, refusals."""
import csv
import itertools
import json

import numpy as np
import pytest

from vismobile.app.cli import main
from vismobile.errors import ProfileError, VisMobileError
from vismobile.app.playback import COLUMNS, Scene, load_scene, parse_stages, parse_structure, play
from vismobile.stats import pearson
from vismobile.device.profile import get_profile
from vismobile.render.hud import hud_lines
from vismobile.world.trajectory import Trajectory
from vismobile.world.world import World


def hills(n=30):
    xs, zs = np.meshgrid(np.linspace(-30, 30, n + 1), np.linspace(-30, 30, n + 1))
    ys = np.sin(xs * 0.3) * np.cos(zs * 0.2) * 2.0
    vertices = np.stack([xs, ys, zs], -1).reshape(-1, 3)
    i = (np.arange(n)[:, None] * (n + 1) + np.arange(n)[None, :]).ravel()
    triangles = np.concatenate([np.stack([i, i + n + 1, i + 1], 1),
                                np.stack([i + 1, i + n + 1, i + n + 2], 1)])
    return World(vertices, triangles, (np.arange(len(triangles)) // 300).astype(np.int32),
                 name="hills")


def walk(frames=12):
    t = np.linspace(0.0, 1.0, frames)
    poses = np.column_stack([-20 + 40 * t, np.full(frames, 6.0), 25 - 30 * t, 60 * t,
                             np.full(frames, -15.0)])
    waypoints = {name: frame for name, frame in (("A", 3), ("B", 9)) if frame < frames}
    return Trajectory(poses, waypoints)


def read_csv(path):
    with open(path, newline="") as handle:
        return list(csv.reader(handle))


def test_frames_csv_and_summary_are_consistent(tmp_path):
    world, trajectory = hills(), walk()
    result = play(Scene(world), trajectory, "bfc", "ipaq-hx2490b", tmp_path / "run")
    rows = read_csv(tmp_path / "run" / "frames.csv")
    assert tuple(rows[0]) == COLUMNS and len(rows) == 1 + len(trajectory)
    table = {name: [row[k] for row in rows[1:]] for k, name in enumerate(COLUMNS)}
    assert table["frame"] == [str(i) for i in range(len(trajectory))]
    assert [w for w in table["waypoint"] if w] == ["A", "B"]
    assert table["waypoint"][3] == "A" and table["waypoint"][9] == "B"
    cull, render, total = (np.array(table[c], float) for c in ("cull_ms", "render_ms",
                                                                "frame_ms"))
    assert np.all(render > 0) and np.allclose(cull + render, total, atol=2e-4)
    assert set(table["triangles_sent"]) == {str(world.triangle_count)}
    memory = get_profile("ipaq-hx2490b").estimate_memory(world)["total"]
    assert set(table["memory_bytes"]) == {str(memory)}
    summary = json.loads((tmp_path / "run" / "summary.json").read_text())
    assert summary == json.loads(json.dumps(result.summary))
    assert summary["frames"] == len(trajectory) and summary["stages"] == ["bfc"]
    for column in COLUMNS[1:8]:
        values = np.array(table[column], float)
        assert summary[column]["median"] == pytest.approx(np.median(values), abs=1e-3)
        assert summary[column]["mean"] == pytest.approx(values.mean(), abs=1e-3)
        assert values.min() - 1e-3 <= summary[column]["p95"] <= values.max() + 1e-3
    assert summary["fps"] == pytest.approx(1000.0 / summary["frame_ms"]["mean"])
    assert summary["pearson_frame_ms_triangles"] is None  # constant triangle count
    # render_ms split into the index upload and the rest (clear, draws, glFinish)
    upload, draw = summary["upload_ms"], summary["draw_ms"]
    assert upload["mean"] > 0 and draw["mean"] > 0
    assert upload["mean"] + draw["mean"] == pytest.approx(summary["render_ms"]["mean"], abs=1e-6)


def test_images_are_identical_across_runs(tmp_path):
    world, trajectory = hills(), walk()
    for name in ("one", "two"):
        play(Scene(world), trajectory, (), "ipaq-hx2490b", tmp_path / name, frames_every=4,
             gif=True, hud=False)
    one = sorted((tmp_path / "one" / "frames").iterdir())
    two = sorted((tmp_path / "two" / "frames").iterdir())
    assert [p.name for p in one] == ["frame_00000.png", "frame_00004.png", "frame_00008.png"]
    assert [p.name for p in two] == [p.name for p in one]
    assert all(a.read_bytes() == b.read_bytes() for a, b in zip(one, two))
    gifs = [(tmp_path / name / "run.gif").read_bytes() for name in ("one", "two")]
    assert gifs[0] == gifs[1]
    assert one[0].read_bytes() != one[1].read_bytes()  # the camera moved


def test_images_are_identical_in_another_process(tmp_path):
    import subprocess
    import sys

    world, trajectory = hills(), walk(5)
    world.to_obj(tmp_path / "hills.obj")
    trajectory.save(tmp_path / "walk.csv")
    here = play(load_scene(tmp_path / "hills.obj"), Trajectory.load(tmp_path / "walk.csv"),
                "bfc", "ipaq-hx2490b", tmp_path / "here", frames_every=2)
    subprocess.run([sys.executable, "-m", "vismobile", "play", str(tmp_path / "hills.obj"),
                    "--trajectory", str(tmp_path / "walk.csv"), "--cull", "bfc", "--out",
                    str(tmp_path / "there"), "--images", "2", "--quiet"], check=True,
                   capture_output=True)
    for frame, data in here.images.items():
        assert (tmp_path / "there" / "frames" / f"frame_{frame:05d}.png").read_bytes() == data


def test_hud_changes_only_the_top_band(tmp_path):
    world, trajectory = hills(), walk(2)
    plain = play(Scene(world), trajectory, (), "ipaq-hx2490b", tmp_path / "a", frames_every=1)
    hud = play(Scene(world), trajectory, (), "ipaq-hx2490b", tmp_path / "b", frames_every=1,
               hud=True)
    from PIL import Image
    import io
    a = np.asarray(Image.open(io.BytesIO(plain.images[0])))
    b = np.asarray(Image.open(io.BytesIO(hud.images[0])))
    assert not np.array_equal(a[:48], b[:48]) and np.array_equal(a[48:], b[48:])


def test_heap_and_partition_refusals_come_before_any_output(tmp_path):
    world = hills()
    tiny = get_profile("ipaq-hx2490b").with_(heap_bytes=10_000)
    with pytest.raises(ProfileError, match="10,000 bytes"):
        play(Scene(world), walk(), (), tiny, tmp_path / "run")
    with pytest.raises(VisMobileError, match="vfc.*need a partition"):
        play(Scene(world), walk(), "vfc,bfc", "ipaq-hx2490b", tmp_path / "run")
    assert not (tmp_path / "run").exists()


def test_parsers():
    assert parse_stages("vfc, BFC,cbfc") == ("vfc", "bfc", "cbfc")
    assert parse_stages("none") == () and parse_stages("") == ()
    with pytest.raises(VisMobileError, match="twice"):
        parse_stages("vfc,vfc")
    assert parse_structure("octree:5") == ("octree", {"depth": 5})
    assert parse_structure("grid:resolution=8") == ("grid", {"resolution": 8})
    assert parse_structure("none") == (None, {})
    assert pearson([1, 2, 3], [2, 4, 6]) == pytest.approx(1.0)
    assert pearson([1, 2, 3], [3, 2, 1]) == pytest.approx(-1.0)
    assert pearson([1, 1], [1, 2]) is None


def test_cli_plays_an_obj_and_reports_errors_in_one_line(tmp_path, capsys):
    hills().to_obj(tmp_path / "hills.obj")
    walk(5).save(tmp_path / "walk.csv")
    code = main(["play", str(tmp_path / "hills.obj"), "--trajectory", str(tmp_path / "walk.csv"),
                 "--cull", "bfc", "--profile", "nokia-n82", "--vertex-format", "fixed16.16",
                 "--out", str(tmp_path / "out"), "--images", "2", "--hud", "--quiet"])
    assert code == 0
    assert len(read_csv(tmp_path / "out" / "frames.csv")) == 6
    assert sorted(p.name for p in (tmp_path / "out" / "frames").iterdir()) == [
        "frame_00000.png", "frame_00002.png", "frame_00004.png"]
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert summary["profile"] == "nokia-n82" and summary["vertex_format"] == "fixed16.16"
    printed = capsys.readouterr().out.splitlines()
    # The profile's device model first, then the other device, then this machine, labelled.
    assert "Nokia N82 model" in printed[1] and "iPaq hx2490b model" in printed[2]
    assert "measured here" in printed[3] and "median" in printed[3]
    assert "warm-up" in printed[4] and "in no figure" in printed[4] and "of 128 MB" in printed[5]
    assert load_scene(tmp_path / "hills.obj").world.triangle_count == hills().triangle_count
    code = main(["play", str(tmp_path / "hills.obj"), "--trajectory", str(tmp_path / "walk.csv"),
                 "--profile", "palm", "--out", str(tmp_path / "bad")])
    assert code == 2 and "unknown profile 'palm'" in capsys.readouterr().err


def test_culled_playback_draws_the_same_pictures_with_fewer_triangles(tmp_path):
    # Conservative culling never drops a visible triangle, so every frame is pixel-identical.
    world, trajectory = hills(40), walk(10)
    culled = load_scene_from(world, "octree:3")
    result = play(culled, trajectory, "vfc,bfc,cbfc", "ipaq-hx2490b", tmp_path / "culled",
                  frames_every=3)
    full = play(Scene(world), trajectory, "bfc", "ipaq-hx2490b", tmp_path / "full",
                frames_every=3)
    assert result.images.keys() == full.images.keys() == {0, 3, 6, 9}
    assert all(result.images[f] == full.images[f] for f in result.images)
    sent = result.frames["triangles_sent"]
    assert np.all(sent <= world.triangle_count) and sent.mean() < 0.8 * world.triangle_count
    assert np.all(result.frames["nodes_visited"] > 0)
    summary = result.summary
    assert summary["structure"] == "octree:depth=3" and summary["stages"] == ["vfc", "bfc", "cbfc"]
    assert summary["memory"]["partition"] > 0
    assert summary["pearson_frame_ms_triangles"] is not None
    # Each device's model of the same frames, labelled; culling lowers the modelled iPaq time.
    assert summary["timing"] == "measured here"
    for device, label in (("ipaq-hx2490b", "iPaq hx2490b model"),
                          ("nokia-n82", "Nokia N82 model")):
        model, whole = summary["model"][device], full.summary["model"][device]
        assert model["label"] == label
        assert np.isclose(model["fps"], 1000.0 / model["frame_ms"]["mean"])
        assert model["frame_ms"]["mean"] < whole["frame_ms"]["mean"]


def test_hud_lines_show_the_heap_budget_and_how_fps_was_obtained():
    lines = hud_lines(("vfc", "bfc"), 3 << 20, 1234, 4.46, "octree:depth=4",
                      heap_bytes=64 << 20, fps_label="iPaq hx2490b model")
    assert lines == ["VFC+BFC / octree:depth=4", "mem 3.0 of 64 MB", "tris 1,234",
                     "4.5 fps (iPaq hx2490b model)"]
    assert hud_lines((), 1 << 20, 0, 60.0)[1:] == ["mem 1.0 MB", "tris 0", "60.0 fps"]


def load_scene_from(world, structure):
    from vismobile.partition import partition

    kind, params = parse_structure(structure)
    return Scene(world, partition(world, kind, **params), f"{kind}:depth={params['depth']}")


def test_partition_files_and_bad_settings(tmp_path):
    from vismobile.partition.store import save_partition

    world = hills(10)
    world.to_obj(tmp_path / "hills.obj")
    scene = load_scene(tmp_path / "hills.obj", "octree:2")
    assert scene.structure == "octree:2" and scene.partition.kind == "octree"
    save_partition(scene.partition, tmp_path / "hills.vmp")
    again = load_scene(tmp_path / "hills.vmp")
    assert again.partition.kind == "octree" and again.world.triangle_count == world.triangle_count
    result = play(again, walk(3), "vfc", "desktop")
    assert result.out is None and result.summary["resolution"] == [640, 480]
    with pytest.raises(VisMobileError, match="--structure octree:depth=99"):
        load_scene(tmp_path / "hills.obj", "octree:depth=99")
    with pytest.raises(VisMobileError, match="--structure cone:2"):
        load_scene(tmp_path / "hills.obj", "cone:2")
    with pytest.raises(VisMobileError, match="--cull vfx"):
        play(scene, walk(3), "vfx", "ipaq-hx2490b")


def test_adaptive_playback_switches_off_a_stage_that_removes_nothing(tmp_path):
    # vfc_thesis after vfc removes nothing (vfc is tighter) but costs time: it must go off,
    # and frames.csv must show the switch at the recorded frame.
    from vismobile.partition import partition

    world = hills()
    scene = Scene(world, partition(world, "octree", depth=3), "octree:3")
    ticks = itertools.count()  # every cull takes exactly 1 s on this clock: timing is not tested
    result = play(scene, walk(60), "vfc,vfc_thesis", "ipaq-hx2490b", tmp_path / "run",
                  adaptive={"clock": lambda: float(next(ticks)), "ms_per_triangle": 1e-3})
    events = result.summary["adaptive_events"]
    assert [(e["stage"], e["action"]) for e in events][:1] == [("vfc_thesis", "off")]
    assert events[0]["saving_ms"] == 0.0 and events[0]["cost_ms"] == 0.0  # equal either way
    rows = read_csv(tmp_path / "run" / "frames.csv")
    stages = [row[COLUMNS.index("active_stages")] for row in rows[1:]]
    frame = events[0]["frame"]
    assert stages[frame - 1] == "vfc+vfc_thesis" and stages[frame + 1] == "vfc"


def test_play_warns_in_one_line_when_the_path_misses_the_world(tmp_path, vismobile_cli):
    """A path 20-40 units away from a small trimesh room: the camera is outside it and sends
    nothing; `vismobile play` (the real entry point) says so in one stderr line, exit 0; a path
    inside the room, and one outside a box looking at it (a view of an object), get none."""
    import trimesh

    from vismobile.world.trajectory import Trajectory

    room = trimesh.creation.box(extents=(4, 3, 4))
    room.invert()
    room.export(tmp_path / "room.stl")
    far = np.column_stack([np.linspace(20, 40, 6), np.full(6, 1.7), np.full(6, 20.0),
                           np.full(6, -90.0), np.zeros(6)])
    Trajectory(far).save(tmp_path / "far.csv")
    inside = np.column_stack([np.zeros(6), np.zeros(6), np.zeros(6), np.linspace(0, 300, 6),
                              np.zeros(6)])
    Trajectory(inside).save(tmp_path / "inside.csv")
    trimesh.creation.box(extents=(4, 3, 4)).export(tmp_path / "object.stl")
    angle = np.linspace(0, 300, 6)
    orbit = np.column_stack([10 * np.sin(np.radians(angle)), np.zeros(6),
                             10 * np.cos(np.radians(angle)), angle, np.zeros(6)])
    Trajectory(orbit).save(tmp_path / "orbit.csv")

    def play(path, mesh="room.stl"):
        return vismobile_cli("play", mesh, "--trajectory", path, "-o", f"run-{path}",
                             "--structure", "octree:1", "--cull", "vfc", "--quiet", cwd=tmp_path)

    done = play("far.csv")
    assert done.returncode == 0, done.stderr
    assert done.stderr.count("\n") == 1 and done.stderr.startswith("warning: ")
    assert "outside the world's bounds and sees nothing on 6 of 6 frames" in done.stderr
    assert "6 of 6 frames sent no triangles" in done.stderr
    summary = json.loads((tmp_path / "run-far.csv" / "summary.json").read_text())
    assert len(summary["warnings"]) == 2
    for quiet in (play("inside.csv"), play("orbit.csv", "object.stl")):
        assert quiet.returncode == 0 and quiet.stderr == "", quiet.stderr


def test_first_use_work_is_in_the_warm_up_not_in_any_measured_frame(tmp_path, monkeypatch):
    # A stand-in for numba's first-use compile: the first cull in the process sleeps 0.3 s.
    import time

    from vismobile.app import playback

    made = playback.make_culler
    first = []

    class FirstUseSlow:
        def __init__(self, inner):
            self.inner = inner

        def __getattr__(self, name):
            return getattr(self.inner, name)

        def cull(self, camera):
            if not first:
                first.append(1)
                time.sleep(0.3)
            return self.inner.cull(camera)

    monkeypatch.setattr(playback, "make_culler", lambda *a, **k: FirstUseSlow(made(*a, **k)))
    result = play(Scene(hills()), walk(6), "bfc", "ipaq-hx2490b")
    assert first and result.summary["warmup_ms"] >= 300.0
    assert result.frames["cull_ms"].max() < 300.0 and result.summary["frames"] == 6
    # CPU time per frame: the sleep (no CPU) is in no frame, and every frame has one.
    assert 0.0 < result.summary["cpu_ms"]["median"] < 300.0


def test_the_gif_does_not_follow_the_images_stride(tmp_path):
    from PIL import Image

    from vismobile.app.playback import GIF_FRAMES

    result = play(Scene(hills(12)), walk(30), (), "desktop", tmp_path / "run", frames_every=10,
                  gif=True)
    assert len(result.images) == 3
    with Image.open(tmp_path / "run" / "run.gif") as gif:
        assert gif.n_frames == 30 <= GIF_FRAMES

"""Options out of range and outputs that are inputs (issue 28): one table of ranges that `--help`
and the checks both read (commands/options.py), and no command writing over its input
(commands/overwrite.py). Each refusal: exit 2, one stderr line naming the option or the file,
no traceback, nothing written."""
import errno
import os

import pytest

from vismobile.app.cli import build_parser, main
from vismobile.commands import options

from .conftest import TRIANGLE, refuse

TRAJECTORY = "frame,x,y,z,yaw,pitch\n0,0.5,0.5,3,0,-10\n1,0.5,0.5,2,0,-10\n"


def listing(folder):
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*"))


@pytest.fixture
def files(tmp_path):
    (tmp_path / "m.obj").write_text(TRIANGLE)
    (tmp_path / "t.csv").write_text(TRAJECTORY)
    return tmp_path


def test_the_table_and_the_parser_agree():
    # every range names a real option (and so reaches its --help), and mirrors its constant
    from vismobile.terrain.heightmap import MAX_LEVEL
    from vismobile.world.trajectory import MAX_FRAMES

    pairs = {(c, o) for c, table in options.RANGES.items() for o in table}
    assert build_parser().ranged == pairs
    assert options.MAX_TERRAIN_SIZE == 2 ** MAX_LEVEL + 1
    assert options.MAX_FRAMES == MAX_FRAMES


def test_structure_ranges_mirror_the_checks_partition_makes():
    # partition() checks budget= itself (it cannot import commands/): the same range
    from vismobile.partition.pvs_coarsen import BUDGET_MAX, DEFAULT_BUDGET, budget_option

    limit = options.STRUCTURE["budget"]
    assert (limit.low, limit.high, limit.above) == (0.0, BUDGET_MAX, True)
    for value in (0.0, -1.0, BUDGET_MAX * 2, float("nan"), float("inf"), 1e-9, BUDGET_MAX):
        refused = limit.problem(value) is not None
        try:
            budget_option(value)
            assert not refused, value
        except ValueError:
            assert refused, value
    # not given: the default share; none/off: the exact sets (no range to check)
    assert budget_option(None) == DEFAULT_BUDGET and limit.problem(DEFAULT_BUDGET) is None
    assert budget_option("none") is None and budget_option(" Off ") is None


def test_help_shows_the_range(capsys):
    with pytest.raises(SystemExit):
        main(["terrain", "build", "--help"])
    out = " ".join(capsys.readouterr().out.split())
    assert "[2^n+1 in 3..8,193]" in out and "[a power of two in 1..8,192]" in out


T = ["terrain", "build", "fractal", "-o", "{d}/t.vmt"]
CASES = [
    (T + ["--size", "16385"], "--size"),
    (T + ["--size", "65537"], "--size"),
    (T + ["--size", "1000"], "--size"),
    (T + ["--spacing", "0"], "--spacing"),
    (T + ["--spacing", "-1"], "--spacing"),
    (T + ["--spacing", "nan"], "--spacing"),
    (T + ["--objects", "1000000000"], "--objects"),
    (T + ["--objects", "-5"], "--objects"),
    (T + ["--object-height", "nan", "--objects", "3"], "--object-height"),
    (T + ["--object-height", "1e9", "--objects", "3"], "--object-height"),
    (T + ["--obj", "{d}/t.obj", "--obj-stride", "0"], "--obj-stride"),
    (T + ["--obj", "{d}/t.obj", "--obj-stride", "3"], "--obj-stride"),
    (T + ["--roughness", "inf"], "--roughness"),
    (T + ["--seed", "-1"], "--seed"),
    (["trajectory", "generate", "{d}/m.obj", "--seed", "-1"], "--seed"),
    (["trajectory", "generate", "{d}/m.obj", "--clearance", "1e9"], "--clearance"),
    (["trajectory", "generate", "{d}/m.obj", "--eye-height=-inf"], "--eye-height"),
    (["tune", "w1", "--probe", "1000000000"], "--probe"),
    (["partition", "{d}/m.obj", "-o", "{d}/m.vmp", "--jobs", "0"], "--jobs"),
    (["partition", "{d}/m.obj", "-o", "{d}/m.vmp", "--jobs", "-4"], "--jobs"),
    (["partition", "{d}/m.obj", "-o", "{d}/m.vmp", "--depth", "99"], "--depth"),
    (["compare", "--worlds", "w1", "--jobs", "0", "-o", "{d}/c"], "--jobs"),
    (["compare", "--worlds", "w1", "--agreement", "-1", "-o", "{d}/c"], "--agreement"),
    (["compare", "--worlds", "w1", "--cull", "", "-o", "{d}/c"], "--cull"),
    (["compare", "--worlds", "w1", "--cull", " , ", "-o", "{d}/c"], "--cull"),
    (["play", "{d}/m.obj", "--trajectory", "{d}/t.csv", "-o", "{d}/r", "--cull", ""],
     "--cull"),
    (["play", "{d}/m.obj", "--trajectory", "{d}/t.csv", "-o", "{d}/r", "--images", "-1"],
     "--images"),
    (["view", "{d}/m.obj", "--scale", "0"], "--scale"),
    (["play", "{d}/m.obj", "--trajectory", "{d}/t.csv", "-o", "{d}/r", "--fps", "0"], "--fps"),
    (["play", "{d}/m.obj", "--trajectory", "{d}/t.csv", "-o", "{d}/r", "--fps", "nan"],
     "--fps"),
    (["view", "{d}/m.obj", "--fps", "1e9"], "--fps"),
    (["play", "{d}/m.obj", "--trajectory", "{d}/t.csv", "-o", "{d}/r", "--regional", " "],
     "--regional"),
]


@pytest.mark.parametrize("argv, option", CASES, ids=[f"{a[0]}{a[-2]}={a[-1]}" for a, _ in CASES])
def test_an_option_out_of_range_is_one_line_and_writes_nothing(capsys, files, argv, option):
    before = listing(files)
    refuse(capsys, [a.format(d=files) for a in argv], option)
    assert listing(files) == before


def test_obj_stride_beyond_the_terrain_is_refused_before_the_vmt(capsys, files):
    before = listing(files)
    refuse(capsys, ["terrain", "build", "fractal", "--size", "33", "-o", files / "t.vmt",
                    "--obj", files / "t.obj", "--obj-stride", "64"], "--obj-stride")
    refuse(capsys, ["terrain", "build", "fractal", "--size", "33", "-o", files / "t.vmt",
                    "--objects", "2", "--object-height", "100"], "--object-height")
    assert listing(files) == before


def test_a_clearance_wider_than_the_world_or_an_eye_above_it_is_refused(capsys, files):
    # both used to become a fly-over silently
    refuse(capsys, ["trajectory", "generate", files / "m.obj", "-o", files / "w.csv",
                    "--clearance", "5", "--quiet"], "--clearance")
    refuse(capsys, ["trajectory", "generate", files / "m.obj", "-o", files / "w.csv",
                    "--eye-height", "1e6", "--quiet"], "--eye-height")
    assert not (files / "w.csv").exists()


def test_the_default_object_height_must_fit_the_terrain(capsys, files):
    # --size 3 --objects 2: 8 spacings on a 2-spacing terrain was a ValueError traceback
    refuse(capsys, ["terrain", "build", "fractal", "--size", "3", "-o", files / "t.vmt",
                    "--objects", "2"], "default object height")
    assert not (files / "t.vmt").exists()


# outputs that are inputs
@pytest.mark.parametrize("argv", [
    ["partition", "{d}/m.obj", "-s", "octree:3", "-o", "{d}/m.obj"],
    ["partition", "{d}/link.obj", "-s", "octree:3", "-o", "{d}/m.obj"],
    ["partition", "{d}/m.obj", "-s", "octree:3", "-o", "{d}/hard.obj"],
    ["partition", "{d}/m.obj", "-s", "octree:3", "-o", "{d}/sub/../m.obj"],
    ["info", "{d}/m.obj", "-o", "{d}/link.obj"],
    ["tune", "{d}/m.obj", "--trajectory", "{d}/t.csv", "-o", "{d}/t.csv"],
    ["trajectory", "generate", "{d}/m.obj", "-o", "{d}/m.obj"],
    ["terrain", "build", "{d}/h.npy", "-o", "{d}/h.npy"],
    ["terrain", "build", "fractal", "--size", "33", "-o", "{d}/x.vmt", "--obj", "{d}/x.vmt"],
    ["play", "{d}/m.obj", "--trajectory", "{d}/t.csv", "-o", "{d}/m.obj"],
    ["play", "{d}/r/frames.csv", "--trajectory", "{d}/t.csv", "-o", "{d}/r"],
    ["compare", "--worlds", "{d}/c/runs.csv", "--trajectory", "{d}/t.csv", "-o", "{d}/c"],
    ["compare", "--worlds", "w1", "--trajectory", "{d}/t.csv", "-o", "{d}/c",
     "--report", "{d}/t.csv"],
    ["view", "{d}/m.obj", "--trajectory", "{d}/t.csv", "--record-to", "{d}/t.csv"],
    ["view", "{d}/m.obj", "--motion", "{d}/mo.json", "--record-to", "{d}/mo.json"],
    ["play", "{d}/m.obj", "--trajectory", "{d}/t.csv", "--motion", "{d}/r/summary.json",
     "-o", "{d}/r"],
    ["terrain", "tile", "{d}/h.vmt", "-o", "{d}/h.vmt"],
])
def test_no_command_writes_over_its_input(capsys, files, argv):
    import numpy as np

    np.save(files / "h.npy", np.zeros((3, 3)))
    os.symlink(files / "m.obj", files / "link.obj")
    os.link(files / "m.obj", files / "hard.obj")
    for folder in ("r", "c"):
        (files / folder).mkdir()
    (files / "r" / "frames.csv").write_text(TRIANGLE)
    (files / "c" / "runs.csv").write_text(TRIANGLE)
    for name in ("mo.json", "r/summary.json", "h.vmt"):
        (files / name).write_text("{}")
    before = {p: p.read_bytes() for p in files.rglob("*") if p.is_file()}
    refuse(capsys, [a.format(d=files) for a in argv], "input" if "x.vmt" not in argv[-1]
           else "twice")
    assert {p: p.read_bytes() for p in files.rglob("*") if p.is_file()} == before


def test_no_output_replaces_a_file_of_an_input_world_directory(capsys, tmp_path):
    world = tmp_path / "big"
    world.mkdir()
    (world / "vertices.npy").write_bytes(b"keep")
    refuse(capsys, ["partition", world, "-o", world / "vertices.npy"], "file of the input")
    assert (world / "vertices.npy").read_bytes() == b"keep"


# play's run folder
@pytest.mark.parametrize("out", ["{d}/m.obj", "/dev/null", "{d}/m.obj/run", "/proc/vismobile"])
def test_play_checks_its_folder_before_loading(capsys, files, out):
    # the world does not exist: an error about it would mean the folder came second
    refuse(capsys, ["play", files / "missing.obj", "--trajectory", files / "t.csv", "-o",
                    out.format(d=files), "--quiet"], out.format(d=files).split("/run")[0])


def test_a_full_disk_names_the_run_folder_not_the_staging_one(tmp_path, monkeypatch):
    from vismobile.files.atomic import atomic_write_bytes, staged_directory
    from vismobile.errors import OutputError

    def full(_):
        raise OSError(errno.ENOSPC, "No space left on device")

    out = tmp_path / "run"
    with pytest.raises(OutputError) as caught:
        with staged_directory(out) as stage:
            monkeypatch.setattr(os, "fsync", full)
            atomic_write_bytes(stage / "frames.csv", b"x")
    assert str(caught.value) == f"{out / 'frames.csv'}: cannot write: No space left on device"
    assert listing(tmp_path) == []

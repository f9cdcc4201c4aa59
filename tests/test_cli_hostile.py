"""Hostile input through the CLI (issue 11): each case is one line on stderr naming the file
(and line), exit code 2, no traceback and nothing partial left behind."""
import json
import struct
import zlib

import numpy as np
import pytest

from vismobile.errors import TrajectoryError, VisMobileError, WorldError
from vismobile.app.playback import load_scene
from vismobile.world.trajectory import Trajectory
from vismobile.world.world import World

from .conftest import TRIANGLE, refuse

TRAJECTORY = "# waypoint A 1\nframe,x,y,z,yaw,pitch\n0,0.5,0.5,3,0,-10\n1,0.5,0.5,2,0,-10\n"


@pytest.fixture
def obj(tmp_path):
    def write(text, name="w.obj", mode="w"):
        path = tmp_path / name
        if isinstance(text, bytes):
            path.write_bytes(text)
        else:
            path.write_text(text)
        return path

    return write


@pytest.fixture
def triangle(obj):
    return obj(TRIANGLE, "tri.obj")


@pytest.fixture
def trajectory(tmp_path):
    path = tmp_path / "t.csv"
    path.write_text(TRAJECTORY)
    return path


# 1. huge coordinates
def test_case01_huge_coordinate_is_refused_with_its_line(capsys, obj):
    path = obj("v 0 0 0\nv 1e154 0 0\nv 0 1 0\nf 1 2 3\n")
    refuse(capsys, ["info", path], f"{path}:2:", "beyond")


def test_case01_world_arrays_near_the_float_limit_do_not_overflow():
    world = World.from_arrays(np.array([[0, 0, 0], [1e160, 0, 0], [0, 1e160, 0.0]]),
                              [[0, 1, 2]], [0], ["a"])
    assert world.triangle_count == 1


# 2. non-ASCII white space and control characters
@pytest.mark.parametrize("byte", [b"\xa0", b"\x0b", b"\x1c", b"\r"])
def test_case02_ambiguous_white_space_is_refused_with_its_line(capsys, obj, byte):
    path = obj(b"v 0 0 0\nv 1" + byte + b"0 0\nv 0 1 0\nf 1 2 3\n")
    refuse(capsys, ["info", path], f"{path}:2:", "unsupported")


@pytest.mark.parametrize("text, line", [
    ("v 0 0 0\n  v 1 0 0\nv 0 1 0\nf 1 2 3\n", 2),      # trimesh skips indented vertices
    ("v 0 0 0\nv\t1 0 0\nv 0 1 0\nf 1 2 3\n", 2),        # and tab-separated keywords
    ("v 0 0 0\nv 1 0 0 \\\nv 0 1 0\nf 1 2 3\n", 2),      # and joins continued lines
    ("v 0 0 0\nv 1_0 0 0\nv 0 1 0\nf 1 2 3\n", 2),       # Python reads 1_0, numpy does not
    ("v 0 0 0\nv 1 0 0 1\nv 0 1 0\nf 1 2 3\n", 2),       # vertex widths differ
    ("v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1 2 3\nf 1/1 2/1 3/1\n", 6),  # corner forms mix
    ("v 0 0 0\nv 1 0 0\nf 1 2 -1\nv 0 1 0\n", 3),        # relative index before a later vertex
])
def test_case02_lines_trimesh_would_misread_are_refused(capsys, obj, text, line):
    path = obj(text)
    refuse(capsys, ["info", path], f"{path}:{line}:")


# 3. tiny files that cost minutes
def test_case03_polygon_over_the_corner_limit_is_refused(capsys, obj):
    ring = "".join(f"v {np.cos(a):.4f} {np.sin(a):.4f} 0\n" for a in np.linspace(0, 6, 300))
    path = obj(ring + "f " + " ".join(map(str, range(1, 301))) + "\n")
    refuse(capsys, ["info", path], f"{path}:301:", "corners")


def test_case03_too_many_groups_are_refused(capsys, obj):
    path = obj("v 0 0 0\nv 1 0 0\nv 0 1 0\n" + "".join(f"g g{i}\nf 1 2 3\n" for i in range(4100)))
    refuse(capsys, ["info", path], f"{path}:", "groups")


def test_case03_repeated_triangles_are_dropped_with_a_warning(obj):
    path = obj("v 0 0 0\nv 1 0 0\nv 0 1 0\n" + "f 1 2 3\nf 2 3 1\n" * 500 + "f 1 3 2\n")
    with pytest.warns(UserWarning, match="999 repeated"):
        world = World.from_obj(path)
    assert world.triangle_count == 2  # both orientations stay


# 4. trajectory positions that overflow
def test_case04_huge_trajectory_position_is_refused(capsys, tmp_path, triangle):
    path = tmp_path / "far.csv"
    path.write_text("frame,x,y,z,yaw,pitch\n0,1e300,0,0,0,0\n")
    refuse(capsys, ["play", triangle, "--trajectory", path, "--out", tmp_path / "run"],
           f"{path}:2:", "position")
    assert not (tmp_path / "run").exists()


# 5. waypoint frame numbers
def test_case05_waypoint_with_thousands_of_digits_is_refused(tmp_path):
    path = tmp_path / "t.csv"
    path.write_text("# waypoint A " + "9" * 1000 + "\n" + TRAJECTORY)
    with pytest.raises(TrajectoryError, match=f"{path}:1: waypoint frame"):
        Trajectory.load(path)
    path.write_text("# waypoint A " + "9" * 5000 + "\n" + TRAJECTORY)
    with pytest.raises(TrajectoryError, match=f"{path}:1: line longer"):
        Trajectory.load(path)


# 6. long trajectories
def test_case06_limit_reads_only_the_first_frames(tmp_path):
    path = tmp_path / "t.csv"
    path.write_text(TRAJECTORY + "2,oops\n")  # never reached with limit=2
    assert len(Trajectory.load(path, limit=2)) == 2
    with pytest.raises(TrajectoryError, match=":5: not a number"):
        Trajectory.load(path)


def test_case06_too_many_frames_without_a_limit_are_refused(tmp_path, monkeypatch):
    from vismobile.world import trajectory

    monkeypatch.setattr(trajectory, "MAX_FRAMES", 3)
    path = tmp_path / "t.csv"
    Trajectory(np.zeros((5, 5))).save(path)
    with pytest.raises(TrajectoryError, match="more than 3 frames"):
        Trajectory.load(path)
    assert len(Trajectory.load(path, limit=3)) == 3


# 7. the documented structure shorthand
def test_case07_grid_with_a_bare_count_builds(triangle):
    scene = load_scene(triangle, "grid:2")
    assert scene.partition.kind == "grid"
    assert [len(scene.partition.extras[f"grid_{a}"]) - 1 for a in "xyz"] == [2, 2, 2]


# 8. non-positive counts
@pytest.mark.parametrize("limit", ["0", "-5"])
def test_case08_non_positive_limit_is_refused(capsys, tmp_path, triangle, trajectory, limit):
    refuse(capsys, ["play", triangle, "--trajectory", trajectory, "--out", tmp_path / "run",
                    "--limit", limit], "--limit")
    assert not (tmp_path / "run").exists()


def test_case08_negative_probe_is_refused(capsys, trajectory):
    refuse(capsys, ["tune", "w1", "--trajectory", trajectory, "--probe", "-3"], "--probe")


# 9, 10. output paths
@pytest.mark.parametrize("where", ["directory", "under_a_file", "device"])
def test_case09_bad_output_paths_are_one_line(capsys, tmp_path, triangle, where):
    (tmp_path / "file").write_text("keep")
    out = {"directory": tmp_path, "under_a_file": tmp_path / "file" / "x.vmp",
           "device": "/dev/full"}[where]
    refuse(capsys, ["partition", triangle, "-s", "grid", "-o", out], out)
    assert (tmp_path / "file").read_text() == "keep"
    assert not list(tmp_path.rglob("*.tmp"))


def test_case09_play_into_a_file_is_refused(capsys, tmp_path, triangle, trajectory):
    (tmp_path / "file").write_text("keep")
    refuse(capsys, ["play", triangle, "--trajectory", trajectory, "--out", tmp_path / "file",
                    "--quiet"], tmp_path / "file")
    assert (tmp_path / "file").read_text() == "keep"


# extras: messages stay one line; worlds build reports on stderr
def test_newline_in_a_file_name_stays_one_line(capsys, tmp_path):
    refuse(capsys, ["info", tmp_path / "two\nlines.obj"], "two\\nlines.obj")


def test_worlds_build_unknown_name_goes_to_stderr(capsys, tmp_path):
    refuse(capsys, ["worlds", "build", "--only", "w9", "--out", tmp_path], "w9")
    assert capsys.readouterr().out == ""


def test_errors_are_vismobile_errors():
    assert issubclass(WorldError, VisMobileError) and issubclass(TrajectoryError, VisMobileError)


# 11, 12. parameters that explode memory or time are refused before building
@pytest.mark.parametrize("args, needle", [
    (["-s", "grid", "--slabs", "x:3000", "--slabs", "y:3000", "--slabs", "z:3000"], "cell count"),
    (["-s", "grid", "--cells", "1000000000"], "--cells must be 1..1,048,576"),  # its range
    (["-s", "bsp", "--candidates", "1000000000"], "--candidates must be 1..4,096"),
    (["-s", "kdtree:bins=100000"], "bins"),
    (["-s", "kdtree", "--max-depth", "1000"], "--max-depth must be 0..256"),
    (["-s", "portal", "--cells", "100000", "--depth", "3"], "portal cell count"),
    (["-s", "portal", "--slabs", "x:500", "--slabs", "z:500"], "portal cell count"),
])
def test_case11_12_exploding_parameters_are_refused(capsys, tmp_path, triangle, args, needle):
    named = () if needle.startswith("--") else (triangle,)  # the option, or the world
    refuse(capsys, ["partition", triangle, *args, "-o", tmp_path / "x.vmp"], *named, needle)
    assert not (tmp_path / "x.vmp").exists()


def test_case11_overlapping_triangles_hit_the_reference_limit(monkeypatch):
    from vismobile.partition import layout, partition

    monkeypatch.setattr(layout, "MAX_REFERENCES", 250)
    rng = np.random.default_rng(0)
    corners = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0.0]]) + rng.normal(0, 1e-3, (300, 3, 3))
    world = World(corners.reshape(-1, 3), np.arange(900).reshape(300, 3))
    for kind in ("octree", "grid"):  # (BSP finds no plane to split these by)
        with pytest.raises(ValueError, match="over the limit of 500"):
            partition(world, kind, **({"slabs": 40} if kind == "grid" else {}))


# 13. frame selections
def test_case13_huge_frame_sample_is_refused():
    from vismobile.study.matrix import SelectionError, parse_frames

    assert parse_frames("sample:60") == "sample:60"
    for text in ("sample:100000000", "stride:" + "9" * 5000):
        with pytest.raises(SelectionError, match="from 1 to"):
            parse_frames(text)


# 14-18. crafted .vmp files with valid checksums
@pytest.fixture(scope="module")
def vmp_bytes(tmp_path_factory):
    from vismobile.partition import partition, save_partition

    rng = np.random.default_rng(1)
    corners = rng.uniform(0, 10, (60, 1, 3)) + rng.uniform(-1, 1, (60, 3, 3))
    world = World(corners.reshape(-1, 3), np.arange(180).reshape(60, 3), name="soup")
    out = {}
    for kind, params in (("octree", {"depth": 2}), ("portal", {"depth": 1, "cells": 8}),
                         ("bsp", {}), ("kdtree", {})):
        path = tmp_path_factory.mktemp("vmp") / f"{kind}.vmp"
        save_partition(partition(world, kind, **params), path)
        out[kind] = path.read_bytes()
    return out


PREFIX = struct.Struct("<8sIII")


def header_of(data):
    return json.loads(data[PREFIX.size:PREFIX.size + PREFIX.unpack_from(data, 0)[2]])


def craft(data, edit_header=None, field=None, values=None):
    """A .vmp with its header edited and/or one field's raw section replaced, CRCs recomputed."""
    magic, version, length, _ = PREFIX.unpack_from(data, 0)
    header = header_of(data)
    start = PREFIX.size + length + (-(PREFIX.size + length) % 64)
    body = bytearray(data[start:])
    if field is not None:
        entry = header["fields"][field]
        raw = np.ascontiguousarray(values, dtype=entry["dtype"]).tobytes()
        entry.update(encoding="raw", parts=[field], shape=list(np.shape(values)))
        header["sections"] = [s for s in header["sections"] if not s["name"].startswith(field)]
        header["sections"].append({"name": field, "dtype": entry["dtype"],
                                   "count": int(np.size(values)), "offset": len(body),
                                   "nbytes": len(raw), "crc32": zlib.crc32(raw)})
        body += raw
    if edit_header is not None:
        edit_header(header)
    text = json.dumps(header).encode()
    head = PREFIX.pack(magic, version, len(text), zlib.crc32(text)) + text
    return head + b"\0" * (-len(head) % 64) + bytes(body)


def play_vmp(capsys, tmp_path, trajectory, data, *needles, stages="vfc,occlusion"):
    path = tmp_path / "crafted.vmp"
    path.write_bytes(data)
    return refuse(capsys, ["play", path, "--trajectory", trajectory, "--cull", stages,
                           "--out", tmp_path / "run", "--quiet"], path, *needles)


def test_case14_deeply_nested_header_is_refused(capsys, tmp_path, trajectory):
    nested = b'{"x":' + b"[" * 100000 + b"]" * 100000 + b"}"
    head = PREFIX.pack(b"\x89VMP\r\n\x1a\n", 1, len(nested), zlib.crc32(nested)) + nested
    play_vmp(capsys, tmp_path, trajectory, head + b"\0" * (-len(head) % 64), "nested")


@pytest.mark.parametrize("count", [2 ** 31, 2 ** 40])
def test_case15_declared_sizes_beyond_the_file_are_refused(capsys, tmp_path, trajectory,
                                                           vmp_bytes, count):
    def grow(header):
        entry = header["fields"]["world.object_ids"]
        entry["shape"] = [count]

    play_vmp(capsys, tmp_path, trajectory, craft(vmp_bytes["octree"], grow), "declares")


def test_case16_params_must_be_a_dict(capsys, tmp_path, trajectory, vmp_bytes):
    def scalar(header):
        header["params"] = 5

    play_vmp(capsys, tmp_path, trajectory, craft(vmp_bytes["octree"], scalar), "params")


def test_case17_negative_child_count_is_refused(capsys, tmp_path, trajectory, vmp_bytes):
    data = vmp_bytes["bsp"]
    counts = np.zeros(header_of(data)["fields"]["child_count"]["shape"], dtype="<i4")
    counts[0], counts[1] = 3, -2  # sums to N - 1 and first_child follows, yet negative
    play_vmp(capsys, tmp_path, trajectory, craft(data, field="child_count", values=counts),
             "inconsistent")


def test_case17_kdtree_split_axes_must_match_the_tree(capsys, tmp_path, trajectory, vmp_bytes):
    data = vmp_bytes["kdtree"]
    axes = np.full(header_of(data)["fields"]["extras.split_axis"]["shape"], 1, dtype="<i1")
    play_vmp(capsys, tmp_path, trajectory, craft(data, field="extras.split_axis", values=axes),
             "inconsistent")


@pytest.mark.parametrize("case", ["nan_bounds", "cell_node", "vertex", "ref_start"])
def test_case18_files_that_would_crash_a_stage_are_refused(capsys, tmp_path, trajectory,
                                                          vmp_bytes, case):
    from vismobile.partition import load_partition

    kind = "portal" if case == "cell_node" else "bsp"
    path = tmp_path / "good.vmp"
    path.write_bytes(vmp_bytes[kind])
    good = load_partition(path)
    if case == "nan_bounds":
        bounds = good.node_bounds.copy()
        bounds[1, 0, 0] = np.nan
        data = craft(vmp_bytes[kind], field="node_bounds", values=bounds.astype("<f8"))
    elif case == "cell_node":
        cells = good.extras["cell_node"].copy()
        cells[0] = good.node_count + 5
        data = craft(vmp_bytes[kind], field="extras.cell_node", values=cells.astype("<i4"))
    elif case == "vertex":
        vertices = good.world.vertices.copy()
        vertices[0, 0] = 1e300

        def digest(header):
            from vismobile.world.world import World

            w = World(vertices, good.world.triangles, good.world.object_ids)
            header["world"]["digest"] = w.digest().hex()

        data = craft(vmp_bytes[kind], digest, field="world.vertices",
                     values=vertices.astype("<f8"))
    else:
        data = craft(vmp_bytes[kind], field="ref_start",
                     values=np.zeros(good.node_count, dtype="<i8"))
    play_vmp(capsys, tmp_path, trajectory, data, "partition file",
             stages="portals,occlusion" if kind == "portal" else "vfc,occlusion")


@pytest.mark.parametrize("argv", [
    ["tune", "w1", "--json", "{dir}"],
    ["compare", "--worlds", "w1", "--structures", "grid", "--cull", "vfc", "--out", "{file}"],
    ["compare", "--worlds", "w1", "--structures", "grid", "--cull", "vfc", "--out", "{dir}/o",
     "--report", "{dir}"],
])
def test_case09_outputs_are_checked_before_the_work(capsys, tmp_path, argv):
    (tmp_path / "file").write_text("keep")
    argv = [a.format(dir=tmp_path, file=tmp_path / "file") for a in argv]
    refuse(capsys, argv, tmp_path)
    assert (tmp_path / "file").read_text() == "keep"


def test_case03_flat_polygon_fans_stay_cheap_in_an_octree():
    # A flat world's octree cells have zero height: splitting them there doubled every
    # reference per level (a 64-gon fan: 1,368 references per triangle at depth 5).
    from vismobile.partition import partition

    angles = np.linspace(0, 2 * np.pi, 64, endpoint=False)
    ring = np.column_stack([np.cos(angles), np.sin(angles), np.zeros(64)])
    fan = np.column_stack([np.zeros(62), np.arange(1, 63), np.arange(2, 64)])
    tree = partition(World(ring, fan), "octree", depth=5)
    assert tree.stats()["refs_per_triangle"] < 64
    assert set(np.unique(tree.extras["octant"][1:])) <= {0, 1, 2, 3}  # never the z-high half

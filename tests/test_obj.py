"""OBJ loading: every shipped model loads (from .obj.gz); each kind of bad input is a WorldError naming file and line."""
import contextlib
import gzip
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from vismobile.errors import WorldError
from vismobile.scenes.objects import OBJECTS, PACKAGE_MODELS
from vismobile.world.world import World

MODELS = sorted(PACKAGE_MODELS.glob("*.obj.gz"))


def test_every_model_the_worlds_need_ships_with_its_source():
    shipped = {p.name for p in MODELS}
    assert {f"{filename}.gz" for filename, _ in OBJECTS.values()} <= shipped
    sources = (PACKAGE_MODELS / "SOURCES.md").read_text()
    assert all(name in sources for name in shipped)


@pytest.mark.parametrize("path", MODELS, ids=lambda p: p.name.split(".")[0])
def test_every_shipped_model_loads(path):
    world = World.from_obj(path)
    assert world.triangle_count > 100
    assert np.isfinite(world.vertices).all()
    assert world.triangles.min() >= 0 and world.triangles.max() < len(world.vertices)
    np.testing.assert_allclose(np.linalg.norm(world.normals, axis=1), 1.0, atol=1e-6)


def test_o_records_become_objects(tmp_path):
    path = tmp_path / "two.obj"
    path.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\no first\nf 1 2 3\no second\nf 1 3 4\nf 1 4 2\n")
    world = World.from_obj(path)
    assert sorted(world.object_names) == ["first", "second"]
    assert np.bincount(world.object_ids).tolist() in ([1, 2], [2, 1])


def test_quads_are_triangulated(tmp_path):
    path = tmp_path / "quad.obj"
    path.write_text("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n")
    assert World.from_obj(path).triangle_count == 2


BAD = {
    "empty": ("", None),
    "blank": ("\n  \n", None),
    "garbage": ("v 0 0 0\nhello world\n", 2),
    "nan": ("v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n", 2),
    "inf": ("v 0 0 0\nv 1 0 0\nv 0 inf 0\nf 1 2 3\n", 3),
    "not_a_number": ("v 0 0 x\n", 1),
    "index_out_of_range": ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n", 4),
    "index_not_integer": ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 c\n", 4),
    "degenerate_only": ("v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n", None),
    "no_faces": ("v 0 0 0\nv 1 0 0\n", None),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_input_raises_world_error_naming_file_and_line(tmp_path, case):
    text, line = BAD[case]
    path = tmp_path / f"{case}.obj"
    path.write_text(text)
    with pytest.raises(WorldError) as info:
        with pytest.warns() if case == "degenerate_only" else contextlib.nullcontext():
            World.from_obj(path)
    message = str(info.value)
    assert str(path) in message
    if line is not None:
        assert f"{path}:{line}:" in message


def test_missing_file_raises_world_error(tmp_path):
    with pytest.raises(WorldError, match="no such file"):
        World.from_obj(tmp_path / "absent.obj")


def test_zero_area_triangles_are_dropped_with_a_warning(tmp_path):
    path = tmp_path / "mixed.obj"
    path.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 2 0 0\nf 1 2 3\nf 1 2 4\n")
    with pytest.warns(UserWarning, match="dropped 1 zero-area"):
        world = World.from_obj(path)
    assert world.triangle_count == 1


@pytest.mark.parametrize("case", ["garbage", "nan", "index_out_of_range"])
def test_cli_reports_bad_input_in_one_line_with_exit_2(tmp_path, case):
    path = tmp_path / "bad.obj"
    path.write_text(BAD[case][0])
    result = subprocess.run([sys.executable, "-m", "vismobile", "info", str(path)],
                            capture_output=True, text=True, cwd=Path(__file__).parents[1])
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in result.stderr
    assert str(path) in lines[0]


def test_cli_info_prints_counts(tmp_path):
    path = tmp_path / "tri.obj"
    path.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    result = subprocess.run([sys.executable, "-m", "vismobile", "info", str(path)],
                            capture_output=True, text=True, cwd=Path(__file__).parents[1])
    assert result.returncode == 0
    assert "triangles  1" in result.stdout



def test_gzipped_obj_loads_like_the_plain_file(tmp_path):
    text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\nf 1 3 4\n"
    (tmp_path / "t.obj").write_text(text)
    (tmp_path / "t.obj.gz").write_bytes(gzip.compress(text.encode()))
    plain, packed = World.from_obj(tmp_path / "t.obj"), World.from_obj(tmp_path / "t.obj.gz")
    assert plain.digest() == packed.digest()


def test_corrupt_gzip_is_a_world_error_naming_the_file(tmp_path):
    path = tmp_path / "bad.obj.gz"
    path.write_bytes(b"\x1f\x8b\x08\x00not really gzip")
    with pytest.raises(WorldError, match="bad.obj.gz"):
        World.from_obj(path)

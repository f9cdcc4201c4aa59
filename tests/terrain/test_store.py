import numpy as np
import pytest

from vismobile.app.cli import main
from vismobile.errors import WorldError
from vismobile.terrain import sources, store
from vismobile.terrain.placement import Placement


def test_roundtrip_is_exact_and_compact(tmp_path):
    hm = sources.diamond_square(129, seed=5, spacing=2.5)
    placement = Placement(("cow", "teapot"), np.array([[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]]),
                          np.array([10.0, 20.0]), np.array([3.0, 4.0]))
    path = tmp_path / "t.vmt"
    store.save(path, hm, placement)
    back, objects = store.load(path)
    assert np.array_equal(back.samples, hm.samples) and back.digest() == hm.digest()
    assert (back.spacing, back.z_scale, back.z_offset) == (hm.spacing, hm.z_scale, hm.z_offset)
    assert objects.kinds == placement.kinds and np.array_equal(objects.positions, placement.positions)
    assert path.stat().st_size < hm.samples.nbytes  # delta + zlib beats raw 16-bit
    assert not list(tmp_path.glob(".*tmp"))


@pytest.mark.parametrize("damage", ["magic", "header", "payload", "truncate"])
def test_corrupt_files_are_refused(tmp_path, damage):
    path = tmp_path / "t.vmt"
    store.save(path, sources.diamond_square(33, seed=1))
    data = bytearray(path.read_bytes())
    if damage == "magic":
        data[0:4] = b"XXXX"
    elif damage == "header":
        data[20] ^= 0xFF
    elif damage == "payload":
        data[-5] ^= 0xFF
    else:
        data = data[:len(data) // 2]
    path.write_bytes(bytes(data))
    with pytest.raises(WorldError, match="t.vmt"):
        store.load(path)


def test_cli_build_and_info(tmp_path, capsys):
    out = tmp_path / "f.vmt"
    assert main(["terrain", "build", "fractal", "--size", "65", "--seed", "2", "-o", str(out),
                 "--obj", str(tmp_path / "f.obj"), "--obj-stride", "4"]) == 0
    hm, _ = store.load(out)
    assert hm.size == 65 and np.array_equal(hm.samples, sources.diamond_square(65, seed=2).samples)
    assert (tmp_path / "f.obj").stat().st_size > 0
    assert main(["terrain", "info", str(out)]) == 0
    assert "65 x 65" in capsys.readouterr().out


def test_cli_bad_input_is_one_line_exit_2(tmp_path, capsys):
    bad = tmp_path / "bad.vmt"
    bad.write_bytes(b"nope")
    assert main(["terrain", "info", str(bad)]) == 2
    err = capsys.readouterr().err
    assert "bad.vmt" in err and err.count("\n") == 1
    assert main(["terrain", "build", "fractal", "--size", "100", "-o", str(tmp_path / "x.vmt")]) == 2


def test_existing_commands_accept_a_terrain(tmp_path, capsys):
    """info and partition take a .vmt like an OBJ (ground at a bounded stride)."""
    out = tmp_path / "t.vmt"
    assert main(["terrain", "build", "fractal", "--size", "129", "-o", str(out)]) == 0
    assert main(["info", str(out)]) == 0
    assert "32,768" in capsys.readouterr().out  # 2 * 128^2 triangles
    assert main(["partition", str(out), "--structure", "octree", "--depth", "3",
                 "-o", str(tmp_path / "t.vmp")]) == 0
    from vismobile.terrain.mesh import terrain_world_file

    assert terrain_world_file(out, max_triangles=2000).triangle_count == 2 * 16 * 16

"""The .vmp file: round trip, byte-identical output, rejection of bad files."""
import json
import struct

import numpy as np
import pytest

import vismobile
from vismobile.errors import PartitionError
from vismobile.partition import store
from vismobile.world.world import World


@pytest.fixture(scope="module")
def saved(cow, tmp_path_factory):
    p = vismobile.partition(cow, "octree", depth=4)
    path = tmp_path_factory.mktemp("vmp") / "cow.vmp"
    store.save_partition(p, path)
    return p, path


@pytest.mark.parametrize("kind,params", [("octree", {"depth": 3}), ("grid", {"auto": True}),
                                         ("bsp", {}), ("portal", {"depth": 2})])
def test_round_trip_is_identical(suzanne, tmp_path, kind, params):
    p = vismobile.partition(suzanne, kind, **params)
    store.save_partition(p, tmp_path / "a.vmp")
    q = vismobile.load_partition(tmp_path / "a.vmp", suzanne)
    for name in p.ARRAYS:
        assert np.array_equal(getattr(p, name), getattr(q, name)), name
    assert sorted(p.extras) == sorted(q.extras)
    for name in p.extras:
        assert np.array_equal(p.extras[name], q.extras[name], equal_nan=True), name
    alone = vismobile.load_partition(tmp_path / "a.vmp")
    assert alone.world.digest() == suzanne.digest() and alone.params == json.loads(json.dumps(p.params))


def test_same_inputs_same_bytes(cow, tmp_path):
    for name in ("a", "b"):
        store.save_partition(vismobile.partition(cow, "bsp"), tmp_path / f"{name}.vmp")
    assert (tmp_path / "a.vmp").read_bytes() == (tmp_path / "b.vmp").read_bytes()


def test_decimal_vertices_stored_as_float32(tmp_path):
    v = np.array([[0.1, 0.2, 0.3], [1.7, -2.25, 1e-3], [123.456, 7.0, -0.5]])
    w = World(v, np.array([[0, 1, 2]]))
    p = vismobile.partition(w, "octree", depth=1)
    data = store.to_bytes(p)
    header = json.loads(data[20:20 + struct.unpack_from("<8sIII", data)[2]])
    assert header["fields"]["world.vertices"]["encoding"] == "decimal6"
    store.save_partition(p, tmp_path / "d.vmp")
    assert np.array_equal(vismobile.load_partition(tmp_path / "d.vmp").world.vertices, v)


def _write(tmp_path, data):
    path = tmp_path / "bad.vmp"
    path.write_bytes(data)
    return path


def test_corrupt_section_rejected(saved, tmp_path):
    data = bytearray(saved[1].read_bytes())
    data[-100] ^= 0x40
    with pytest.raises(PartitionError, match="bad.vmp: corrupt"):
        vismobile.load_partition(_write(tmp_path, bytes(data)))


def test_corrupt_header_rejected(saved, tmp_path):
    data = bytearray(saved[1].read_bytes())
    data[40] ^= 0x01
    with pytest.raises(PartitionError, match="header checksum"):
        vismobile.load_partition(_write(tmp_path, bytes(data)))


@pytest.mark.parametrize("keep", [0, 10, 30, 5000, -1])
def test_truncated_rejected(saved, tmp_path, keep):
    data = saved[1].read_bytes()
    with pytest.raises(PartitionError, match="bad.vmp"):
        vismobile.load_partition(_write(tmp_path, data[:keep] if keep >= 0 else data[:-7]))


def test_wrong_magic_and_newer_version(saved, tmp_path):
    data = saved[1].read_bytes()
    with pytest.raises(PartitionError, match="bad magic"):
        vismobile.load_partition(_write(tmp_path, b"# OBJ fi" + data[8:]))
    newer = data[:8] + struct.pack("<I", store.VERSION + 1) + data[12:]
    with pytest.raises(PartitionError, match="newer"):
        vismobile.load_partition(_write(tmp_path, newer))


def test_other_world_and_missing_file(saved, suzanne, tmp_path):
    with pytest.raises(PartitionError, match="another world"):
        vismobile.load_partition(saved[1], suzanne)
    with pytest.raises(PartitionError, match="missing.vmp"):
        vismobile.load_partition(tmp_path / "missing.vmp")


def test_tampered_world_with_valid_checksums_rejected(saved, tmp_path):
    p, _ = saved
    w = p.world
    moved = World(w.vertices + 1.0, w.triangles, w.object_ids, w.object_names, w.name)
    bad = vismobile.partition(moved, "octree", depth=1)
    data = store.to_bytes(bad)
    # swap in the digest of the original world: every section checksum still holds
    text_len = struct.unpack_from("<8sIII", data)[2]
    header = data[20:20 + text_len].replace(moved.digest().hex().encode(), w.digest().hex().encode())
    import zlib
    forged = data[:12] + struct.pack("<II", text_len, zlib.crc32(header)) + header + data[20 + text_len:]
    with pytest.raises(PartitionError, match="digest"):
        vismobile.load_partition(_write(tmp_path, forged))


@pytest.mark.parametrize("value", ['"<f2"', "true", "-1.0", "NaN", "Infinity"])
def test_params_of_the_wrong_type_rejected(saved, tmp_path, value):
    """A header param a reader uses (here the portal stage's thickness) of the wrong type, sign
    or finiteness is refused at load, not met later as a ValueError in the culler."""
    import zlib
    data = saved[1].read_bytes()
    _, _, text_len, _ = struct.unpack_from("<8sIII", data)
    header = json.loads(data[20:20 + text_len])
    header["params"]["thickness"] = "@@"
    text = json.dumps(header).replace('"@@"', value).encode()
    forged = data[:12] + struct.pack("<II", len(text), zlib.crc32(text)) + text + data[20 + text_len:]
    with pytest.raises(PartitionError, match="bad.vmp.*params.thickness"):
        vismobile.load_partition(_write(tmp_path, forged))

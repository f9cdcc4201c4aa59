"""The out-of-core octree: chunked, externally sorted, streamed, parallel; and its mapped file."""
import numpy as np
import pytest

from vismobile.world.camera import Camera
from vismobile.culling import Culler
from vismobile.errors import PartitionError, WorldError
from vismobile.world.mapped import MappedWorld
from vismobile.partition import load_partition, octree
from vismobile.partition.external import build_octree_file
from vismobile.partition.store import map_partition, save_partition
from vismobile.world.world import World

FIELDS = ("node_bounds", "first_child", "child_count", "ref_start", "ref_end", "level_start",
          "tri_refs")


@pytest.fixture(scope="module")
def world_dir(w1_world_dir):
    return w1_world_dir


@pytest.fixture(scope="module")
def world32(world_dir):
    """The same world in memory."""
    return MappedWorld.open(world_dir).load()


@pytest.fixture(scope="module")
def streamed(tmp_path_factory, world_dir):
    out = tmp_path_factory.mktemp("vmp") / "w1.vmp"
    build_octree_file(MappedWorld.open(world_dir), out, depth=4, chunk=1000)
    return out


def test_world_dir_maps_back_the_same_world(world_dir, world32, w1):
    mapped = MappedWorld.open(world_dir)
    assert isinstance(mapped.vertices, np.memmap)
    assert mapped.triangle_count == w1.triangle_count
    assert np.allclose(world32.corners, w1.corners, atol=1e-5)  # float32 of the same triangles
    assert mapped.digest() == world32.digest()
    assert np.array_equal(mapped.extent, world32.extent)


def test_streamed_build_equals_the_in_memory_build(streamed, world32):
    serial = octree.build(world32, depth=4)
    loaded = load_partition(streamed, world32)
    for name in FIELDS:
        assert np.array_equal(getattr(loaded, name), getattr(serial, name)), name
    assert np.array_equal(loaded.extras["octant"], serial.extras["octant"])
    assert loaded.params == serial.params


def test_parallel_build_writes_the_same_bytes(tmp_path, world_dir, streamed):
    out = tmp_path / "parallel.vmp"
    stats = build_octree_file(MappedWorld.open(world_dir), out, depth=4, chunk=2500, jobs=2)
    assert stats["chunks"] == 3
    assert out.read_bytes() == streamed.read_bytes()
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]  # no spill left


def test_mapped_partition_culls_like_the_loaded_one(streamed, world32):
    mapped = map_partition(streamed)
    assert isinstance(mapped.world, MappedWorld) and mapped.world.vertices.dtype == np.float32
    loaded = load_partition(streamed)
    rng = np.random.default_rng(3)
    low, high = world32.extent
    for _ in range(6):
        camera = Camera(rng.uniform(low, high), yaw=rng.uniform(-180, 180),
                        pitch=rng.uniform(-30, 30))
        a, b = Culler(mapped, "vfc").cull(camera), Culler(loaded, "vfc").cull(camera)
        assert np.array_equal(a.triangles, b.triangles)


def test_a_corrupt_reference_section_is_refused(tmp_path, streamed):
    data = bytearray(streamed.read_bytes())
    data[-200] ^= 0xFF  # inside the last sections (references / octants)
    bad = tmp_path / "bad.vmp"
    bad.write_bytes(bytes(data))
    with pytest.raises(PartitionError, match="bad.vmp"):
        map_partition(bad)


def test_an_encoded_file_cannot_be_mapped(tmp_path, world32):
    path = tmp_path / "encoded.vmp"
    save_partition(octree.build(world32, depth=2), path)
    with pytest.raises(PartitionError, match="only streamed"):
        map_partition(path)


def test_a_missing_world_dir_names_the_file(tmp_path):
    with pytest.raises(WorldError, match="vertices.npy"):
        MappedWorld.open(tmp_path)


def test_the_cli_partitions_a_world_dir(tmp_path, world_dir, streamed, capsys):
    from vismobile.app.cli import main

    out = tmp_path / "cli.vmp"
    assert main(["partition", str(world_dir), "--depth", "4", "-o", str(out)]) == 0
    assert out.read_bytes() == streamed.read_bytes()
    assert main(["partition", str(world_dir), "-s", "bsp", "-o", str(out)]) == 2
    assert "octree only" in capsys.readouterr().err
    assert main(["partition", str(world_dir), "-o", str(tmp_path)]) == 2  # a folder, not a file
    assert "is a directory" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cli.vmp"]  # no temporaries left


def test_a_chunk_over_the_reference_limit_is_split(tmp_path, world_dir, streamed, monkeypatch):
    from vismobile.partition import layout

    monkeypatch.setattr(layout, "MAX_REFERENCES", 3000)  # W1 depth 4: ~27,500 references
    out = tmp_path / "split.vmp"
    stats = build_octree_file(MappedWorld.open(world_dir), out, depth=4)
    assert stats["chunks"] > 1
    assert out.read_bytes() == streamed.read_bytes()


def test_the_build_stores_each_nodes_largest_triangles(streamed, world32):
    # occlusion's candidate lists (partition/occluders.py), computed at build from the
    # scattered references: what the stage would compute from the loaded partition.
    from vismobile.partition.occluders import STORED, candidate_lists

    loaded = load_partition(streamed, world32)
    stored = loaded.extras["occluders"]
    assert stored.dtype == np.int32 and stored.shape == (loaded.node_count, STORED)
    expect = candidate_lists(loaded.first_child, loaded.child_count, loaded.ref_start,
                             loaded.ref_end, loaded.tri_refs, world32.vertices,
                             world32.triangles, STORED)
    assert np.array_equal(stored, expect) and (stored[0] >= 0).all()
    assert np.array_equal(map_partition(streamed).extras["occluders"], stored)


def test_occluder_lists_out_of_range_are_refused_with_valid_checksums(tmp_path, streamed):
    import json
    import struct
    import zlib

    from vismobile.partition.external import HEADER_SPACE
    from vismobile.partition.store import PREFIX

    data = bytearray(streamed.read_bytes())
    _, version, length, _ = PREFIX.unpack_from(data, 0)
    header = json.loads(bytes(data[PREFIX.size:PREFIX.size + length]))
    section = next(s for s in header["sections"] if s["name"] == "extras.occluders")
    at = HEADER_SPACE + section["offset"]
    data[at:at + 4] = struct.pack("<i", 1 << 30)  # node 0's first id far past the world
    section["crc32"] = zlib.crc32(bytes(data[at:at + section["nbytes"]]))
    text = json.dumps(header, sort_keys=True, separators=(",", ":")).encode()
    text += b" " * (length - len(text))
    data[:PREFIX.size + length] = PREFIX.pack(bytes(data[:8]), version, length,
                                              zlib.crc32(text)) + text
    bad = tmp_path / "bad.vmp"
    bad.write_bytes(bytes(data))
    for read in (map_partition, load_partition):
        with pytest.raises(PartitionError, match="bad.vmp: inconsistent.*occluders"):
            read(bad)

"""Issue 28's hostile files through the CLI, in this process: every case of tools/hostile.py
(mesh formats, glTF graphs and URIs, .gz, .vmt, .vmp and trajectories as special files,
heightmap files) exits 2 with one stderr line naming the file, no traceback, nothing left
behind. The decompression bombs run here against a lowered limit (the tool runs them at full
size in a child and reports its peak RSS: docs/hardening.md)."""
import gzip
import json
import struct
import importlib.util
import zlib
from pathlib import Path

import pytest

from vismobile.app.cli import main
from vismobile.errors import WorldError
from vismobile.files import limits

_SPEC = importlib.util.spec_from_file_location(
    "hostile", Path(__file__).resolve().parents[1] / "tools" / "hostile.py")
hostile = importlib.util.module_from_spec(_SPEC)
_SPEC.loader.exec_module(hostile)
import hostile_writers as writers  # noqa: E402 - on the path hostile.py puts its folder on

BOMBS = {name for name in hostile.CASES if name.endswith("_bomb")}


@pytest.mark.parametrize("name", sorted(set(hostile.CASES) - BOMBS))
def test_a_hostile_file_is_one_clean_line(capsys, tmp_path, monkeypatch, name):
    monkeypatch.setenv("VISMOBILE_STATUS", "off")
    monkeypatch.chdir(tmp_path)
    argv, named = hostile.CASES[name](tmp_path)
    before = hostile.listing(tmp_path)
    assert main([str(a) for a in argv]) == 2
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in err, err
    assert str(named) in lines[0], lines[0]
    assert hostile.listing(tmp_path) == before


@pytest.mark.parametrize("name, data", [
    ("m.obj.gz", gzip.compress(b"v 0 0 0\n") + gzip.compress(b" " * (8 << 20))),
    ("m.ply.gz", gzip.compress(writers.ply(writers.CUBE_V, writers.CUBE_F)[:-2])
     + gzip.compress(b"\0" * (8 << 20))),
    ("m.stl.gz", gzip.compress(b"solid s\n" + b" " * (8 << 20))),
])
def test_a_gzip_bomb_stops_at_the_limit(capsys, tmp_path, monkeypatch, name, data):
    monkeypatch.setattr(limits, "MAX_BYTES", 1 << 20)
    path = tmp_path / name
    path.write_bytes(data)
    assert main(["info", str(path)]) == 2
    line = capsys.readouterr().err.strip()
    assert str(path) in line and "decompression bomb" in line and "\n" not in line
    assert hostile.listing(tmp_path) == [name]


def test_a_zlib_bomb_in_a_vmt_stops_at_its_samples(capsys, tmp_path):
    path = tmp_path / "t.vmt"
    path.write_bytes(writers.vmt(writers.vmt_header(size=3), zlib.compress(b"\0" * (8 << 20))))
    assert main(["terrain", "info", str(path)]) == 2
    line = capsys.readouterr().err.strip()
    assert str(path) in line and "over the 18 byte limit" in line


def test_inflate_streams_every_gzip_member_and_refuses_what_is_past_them(tmp_path):
    two = gzip.compress(b"ab") + gzip.compress(b"cd")
    assert limits.inflate(two, 4, "x") == b"abcd"
    with pytest.raises(WorldError, match="over the 3 byte limit"):
        limits.inflate(two, 3, "x")
    with pytest.raises(WorldError, match="truncated"):
        limits.inflate(two[:-5], 4, "x")
    with pytest.raises(WorldError, match="garbage"):
        limits.inflate(two + b"zz", 4, "x")
    big = zlib.compress(bytes(range(256)) * 9000)  # several chunks in, several out
    assert limits.inflate(big, 256 * 9000, "x", wbits=15) == bytes(range(256)) * 9000


def test_the_object_limit_is_one_number():
    from vismobile.commands.options import MAX_OBJECTS
    from vismobile.terrain.placement import MAX_OBJECTS as placement_limit
    from vismobile.terrain.store import MAX_OBJECTS as store_limit

    assert MAX_OBJECTS == placement_limit == store_limit


def test_a_well_formed_gltf_with_a_buffer_beside_it_loads(tmp_path):
    import json

    from vismobile.world import World

    doc, binary = writers.gltf()
    doc["buffers"][0]["uri"] = "buffer.bin"
    (tmp_path / "buffer.bin").write_bytes(binary)
    (tmp_path / "m.gltf").write_text(json.dumps(doc))
    world = World.from_file(tmp_path / "m.gltf")
    assert world.triangle_count == 12


def test_the_parsers_own_log_records_are_silenced(capsys, caplog):
    import logging

    with limits.quiet_parser():
        logging.getLogger("trimesh").warning("failed to extract face_normals", exc_info=True)
    logging.getLogger("trimesh").warning("after")
    assert [r.getMessage() for r in caplog.records] == ["after"]


def test_fuzz_has_a_seed_and_an_entry_for_every_surface(tmp_path):
    import sys

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tools"))
    import fuzz
    import fuzz_formats
    import fuzz_options
    from vismobile.terrain import store
    from vismobile.world import World

    cube = World.from_arrays(writers.CUBE_V, writers.CUBE_F, [0] * 12, ["c"])
    seeds = fuzz_formats.format_seeds(cube, tmp_path)
    assert set(seeds) | set(fuzz_options.SEEDS) | {"obj", "vmp", "trajectory"} == set(fuzz.ENTRY)
    for target, datas in seeds.items():  # the files' seeds (the option texts: tests below)
        load, suffix = fuzz.ENTRY[target]
        # the textured GLB entry also renders, and a .vmt's objects take seconds to build
        load = {"glb": fuzz_formats.load_mesh, "vmt": store.load}.get(target, load)
        for k, data in enumerate(datas):  # every seed loads as it is
            path = tmp_path / f"seed{k}{suffix}"
            path.write_bytes(data)
            load(path)


@pytest.mark.parametrize("head", [b"OFF\n8 12 0\n", b"OFF 8 12 0\n", b"OFF\n8 12\n",
                                  b"# a cube\nOFF\n\n# counts\n8 12 0\n"])
def test_off_headers_of_every_layout_load_at_their_tightest(tmp_path, head):
    # one digit per number, no trailing newline: the byte bound is exact and still passes
    from vismobile.world import World

    body = "\n".join([" ".join(map(str, v)) for v in writers.CUBE_V]
                     + ["3 " + " ".join(map(str, f)) for f in writers.CUBE_F])
    (tmp_path / "c.off").write_bytes(head + body.encode())
    assert World.from_file(tmp_path / "c.off").triangle_count == 12


def test_structure_texts_build_or_are_refused_in_one_line(tmp_path):
    """The structure grammar (every kind, its parameters, pvs=) fuzzed through partition's CLI:
    each seed builds, and each seeded mutation builds or is refused with exit code 2."""
    import random
    import sys

    from vismobile.errors import VisMobileError

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tools"))
    import fuzz
    from fuzz_options import STRUCTURE_TEXTS, load_structure

    path = tmp_path / "spec.txt"
    for seed in STRUCTURE_TEXTS:
        path.write_bytes(seed)
        load_structure(path)
    refused = 0
    for case in range(40):
        pick = random.Random(f"structure:{case}").randrange
        data = STRUCTURE_TEXTS[pick(len(STRUCTURE_TEXTS))]
        for _ in range(1 + pick(3)):
            data = fuzz.mutate_bytes(data, pick)
        path.write_bytes(data)
        try:
            load_structure(path)
        except VisMobileError:
            refused += 1
    assert 0 < refused < 40  # the mutations reach both outcomes


@pytest.mark.parametrize("target", ["selection", "scheduler"])
def test_structure_lists_and_schedulers_parse_or_are_refused_in_one_line(tmp_path, target):
    """compare's and tune's --structures lists (+pvs labels too) and --scheduler values
    fuzzed: each seed parses, and each seeded mutation parses or raises a VisMobileError
    (SelectionError, SchedulerError); nothing else escapes."""
    import random
    import sys

    from vismobile.errors import VisMobileError

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tools"))
    import fuzz

    texts = fuzz.fuzz_options.SEEDS[target]
    load = fuzz.ENTRY[target][0]
    path = tmp_path / "case.txt"
    for seed in texts:
        path.write_bytes(seed)
        load(path)
    refused = 0
    for case in range(200):
        pick = random.Random(f"{target}:{case}").randrange
        data = texts[pick(len(texts))]
        for _ in range(1 + pick(3)):
            data = fuzz.mutate_bytes(data, pick)
        path.write_bytes(data)
        try:
            load(path)
        except VisMobileError:
            refused += 1
    assert 0 < refused < 200  # the mutations reach both outcomes


@pytest.mark.parametrize("target", ["animglb", "motion", "playmotion", "fps", "regional"])
def test_animated_inputs_load_or_are_refused_in_one_error(tmp_path, target):
    """Issue 25's inputs (a GLB with node animations, a JSON motion file, one as play --motion
    takes it, --fps values, play --regional choices) fuzzed: each seed loads and poses, and each seeded mutation loads
    or is refused with a VisMobileError (any other exception fails the test)."""
    fuzz = _fuzz_module()
    seeds = fuzz.fuzz_motion.animated_seeds(tmp_path)[target]
    _seeds_load_and_mutations_refuse(fuzz, target, seeds, tmp_path)


def test_page_budgets_parse_or_are_refused_in_one_error(tmp_path):
    """play --page-budget values (MB, (0, 2^20]) fuzzed as issue 25's --fps: every seed parses
    within its range, each mutation parses or is refused with a VisMobileError."""
    fuzz = _fuzz_module()
    _seeds_load_and_mutations_refuse(fuzz, "budget", fuzz.fuzz_options.BUDGET_TEXTS, tmp_path)


@pytest.mark.parametrize("target", ["tifstream", "memory", "vmrpages"])
def test_streamed_geotiffs_memory_values_and_pages_load_or_are_refused(tmp_path, target):
    """Issue 30's out-of-core build and paged Röttger: GeoTIFFs (strips, tiles, BigTIFF;
    tools/fuzz_tiled.py) streamed into a .vmtiles, terrain tile --memory values and .vmrpages
    files fuzzed: each seed builds, parses or pages a frame, each mutation does or is refused
    with a VisMobileError (a build leaving no scratch)."""
    fuzz = _fuzz_module()
    seeds = {**fuzz.fuzz_tiled.tiled_seeds(tmp_path), **fuzz.fuzz_tiled.pages_seeds(tmp_path)}
    _seeds_load_and_mutations_refuse(fuzz, target, seeds[target], tmp_path)


def _fuzz_module():
    import sys

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tools"))
    import fuzz

    return fuzz


def _seeds_load_and_mutations_refuse(fuzz, target, seeds, folder):
    """Each seed runs clean; 40 seeded byte mutations each run clean or are refused with a
    VisMobileError (any other exception fails), and some are refused."""
    import random

    outcomes = {"ok": 0, "error": 0}
    for seed in seeds:
        assert fuzz.run_case(target, seed, folder) == "ok"
    for case in range(40):
        pick = random.Random(f"{target}:{case}").randrange
        data = seeds[pick(len(seeds))]
        for _ in range(1 + pick(3)):
            data = fuzz.mutate_bytes(data, pick)
        outcomes[fuzz.run_case(target, data, folder)] += 1
    assert outcomes["error"] > 0


def test_crafted_pvs_packs_load_or_are_refused_in_one_error(tmp_path, literal):
    """A baked PVS's side stream, pattern bits or shape (partition/pvs_codec.py) edited inside
    and re-compressed (tools/fuzz.py mutate_pvs_pack, CRCs recomputed): each loads or raises
    PartitionError."""
    import random
    import sys

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tools"))
    import fuzz
    from vismobile.errors import PartitionError
    from vismobile.partition import load_partition, partition, save_partition

    rect = literal.rect
    world = literal.world([rect(1, 0.0, (0, 4), (0, 8), 1), rect(1, 3.0, (0, 4), (0, 8), -1),
                           rect(0, 0.0, (0, 3), (0, 4), 1), rect(0, 8.0, (0, 3), (0, 4), -1),
                           rect(2, 0.0, (0, 8), (0, 3), 1), rect(2, 4.0, (0, 8), (0, 3), -1),
                           rect(0, 4.0, (0, 3), (0, 1.5), -1), rect(0, 4.0, (0, 3), (2.5, 4), -1)])
    save_partition(partition(world, "portal", depth=1, pvs="conservative"), tmp_path / "p.vmp")
    seed = (tmp_path / "p.vmp").read_bytes()
    outcomes = {"ok": 0, "refused": 0}
    for case in range(120):
        pick = random.Random(f"pvs:{case}").randrange
        header_len = struct.unpack_from("<8sIII", seed, 0)[2]
        header = json.loads(seed[20:20 + header_len])
        body_start = 20 + header_len + (-(20 + header_len) % 64)
        body = bytearray(seed[body_start:])
        body = fuzz.mutate_pvs_pack(header, body, pick)
        text = json.dumps(header, sort_keys=True, separators=(",", ":")).encode()
        head = struct.pack("<8sIII", seed[:8], 1, len(text), zlib.crc32(text)) + text
        path = tmp_path / f"case{case}.vmp"
        path.write_bytes(head + b"\0" * (-len(head) % 64) + bytes(body))
        try:
            load_partition(path)
            outcomes["ok"] += 1
        except PartitionError as error:
            assert "\n" not in str(error) and str(path) in str(error)
            outcomes["refused"] += 1
    assert outcomes["ok"] and outcomes["refused"]  # both sides reached

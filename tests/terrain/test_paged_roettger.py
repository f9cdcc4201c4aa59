"""Röttger paged in by pages (terrain/paged_roettger.py): every frame's leaves and fans are the
in-memory method's, the pages held stay within the budget while the least recently used go
out, the image matches the in-memory render within normal quantisation, and malformed files are
refused in one line."""
import numpy as np
import pytest

from vismobile.device.profile import get_profile
from vismobile.errors import WorldError
from vismobile.terrain import sources
from vismobile.terrain.paged_roettger import PagedRoettger, write_pages
from vismobile.terrain.paths import path_cameras
from vismobile.terrain.roettger import Roettger


@pytest.fixture(scope="module")
def paged_map(tmp_path_factory):
    hm = sources.diamond_square(513, seed=3, roughness=0.5, relief=0.1)
    roettger = Roettger(hm)
    path = tmp_path_factory.mktemp("pages") / "t.vmrpages"
    write_pages(roettger, path)
    return hm, roettger, path


def test_paged_frames_are_the_in_memory_frames_within_the_budget(paged_map):
    hm, roettger, path = paged_map
    profile = get_profile("ipaq-hx2490b")
    probe = PagedRoettger(path, budget_bytes=64 << 20, thread=False)
    budget = probe.coarse * 48 + probe.grid.nbytes + 110 * probe.slot_bytes  # 110 of 256 pages
    probe.close()
    paged = PagedRoettger(path, budget_bytes=budget)
    points = np.random.default_rng(1).uniform(0, hm.extent, (2, 50))
    assert np.allclose(paged.height_at(*points), hm.height_at(*points), atol=1e-4)
    misses = 0
    try:
        # frames 60 apart around the map: pages come and go
        for camera in path_cameras(hm, "circle", "fast", frames=12, every=60):
            _, count = paged.select(camera, profile.resolution, 2.0)  # ~90 pages a frame
            _, expected = roettger.select(camera, profile.resolution, 2.0)
            assert count == expected
            assert np.array_equal(paged.leaf_rows[:count], roettger.leaf_rows[:expected])
            fans = roettger.update(camera, profile.resolution, 2.0).triangles
            assert np.array_equal(paged.triangles(), fans)
            samples = paged.vertex_records(fans.ravel())[:, :2].copy().view("<u2")[:, 0]
            assert np.array_equal(samples, hm.samples.ravel()[fans.ravel()])
            assert paged.memory_bytes() <= budget
            misses += paged.misses
    finally:
        paged.close()
    assert paged.grown == 0 and paged.evicted > 0 and misses > 0


def test_the_paged_image_matches_the_in_memory_render(paged_map):
    from vismobile.render.terrain import TerrainRenderer
    from vismobile.render.tile_arena import PagedRenderer

    hm, roettger, path = paged_map
    profile = get_profile("ipaq-hx2490b")
    paged = PagedRoettger(path, thread=False)
    renderer, plain = PagedRenderer(paged, profile), TerrainRenderer(hm, profile)
    try:
        for camera in path_cameras(hm, "circle", "slow", frames=2, every=50):
            paged.select(camera, profile.resolution, 2.0)
            renderer.draw_samples(paged.triangles(), camera)
            image = renderer.read_rgb().astype(np.float64)
            plain.draw_samples(roettger.update(camera, profile.resolution, 2.0).triangles,
                               camera)
            mse = ((image - plain.read_rgb()) ** 2).mean()
            assert mse == 0 or 10 * np.log10(255 ** 2 / mse) > 40  # int8 normals only
    finally:
        paged.close()


def test_a_malformed_paged_terrain_is_refused(paged_map, tmp_path):
    _, _, path = paged_map
    data = path.read_bytes()
    for name, bad in (("magic.vmrpages", b"VMTT" + data[4:]),  # a .vmtiles header, not ours
                      ("short.vmrpages", data[:len(data) - 10]),
                      ("coarse.vmrpages", data[:300] + bytes([data[300] ^ 1]) + data[301:])):
        (tmp_path / name).write_bytes(bad)
        with pytest.raises(WorldError, match=name):
            PagedRoettger(tmp_path / name, thread=False)
    import json
    import struct
    import zlib

    length = struct.unpack("<I", data[4:8])[0]
    header = json.loads(data[12:12 + length])
    for k, (key, value) in enumerate((("size", 3), ("levels", 99), ("C", 1.0),
                                      ("spacing", -1.0), ("holes", 1), ("C", "x"))):
        head = json.dumps({**header, key: value}).encode()  # edits behind a valid CRC
        name = f"edit{k}.vmrpages"
        (tmp_path / name).write_bytes(data[:4] + struct.pack("<II", len(head), zlib.crc32(head))
                                      + head + data[12 + length:])
        with pytest.raises(WorldError, match=name):
            PagedRoettger(tmp_path / name, thread=False)
    page = bytearray(data)
    page[-100] ^= 1  # the last page's vertices: refused when that page is read
    (tmp_path / "page.vmrpages").write_bytes(bytes(page))
    paged = PagedRoettger(tmp_path / "page.vmrpages", thread=False)
    with pytest.raises(WorldError, match="page.vmrpages: page 255"):
        paged._read(255)
    paged.close()


def test_terrain_tile_then_play_pages_roettger(paged_map, tmp_path, capsys):
    import csv

    from vismobile.app.cli import main
    from vismobile.terrain import store

    store.save(tmp_path / "t.vmt", sources.diamond_square(129, seed=2))
    out = tmp_path / "t.vmrpages"
    assert main(["terrain", "tile", str(tmp_path / "t.vmt"), "-o", str(out)]) == 0
    assert main(["play", str(out), "--limit", "3", "--lod", "2", "--quiet", "-o",
                 str(tmp_path / "run")]) == 0
    rows = list(csv.DictReader(open(tmp_path / "run" / "frames.csv")))
    assert len(rows) == 3 and all(float(r["error_px"]) <= 2.0 + 1e-9 for r in rows)
    assert int(rows[0]["page_bytes"]) > 0
    capsys.readouterr()
    assert main(["play", str(out), "--terrain-method", "tiles", "-o",
                 str(tmp_path / "bad")]) == 2
    assert "roettger method" in capsys.readouterr().err
    (tmp_path / "bad.vmrpages").write_bytes(out.read_bytes()[:100])
    assert main(["play", str(tmp_path / "bad.vmrpages"), "-o", str(tmp_path / "bad2")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "bad.vmrpages" in err[0]


def test_a_budget_below_one_frame_grows_the_slots_and_says_so(paged_map):
    """A frame needing more pages than the budget holds still gets the in-memory leaves: the
    slots grow (counted in grown) and memory_bytes reports what is held."""
    hm, roettger, path = paged_map
    profile = get_profile("ipaq-hx2490b")
    paged = PagedRoettger(path, budget_bytes=1, thread=False)
    try:
        camera = path_cameras(hm, "circle", "fast", frames=1)[0]
        _, count = paged.select(camera, profile.resolution, 2.0)
        _, expected = roettger.select(camera, profile.resolution, 2.0)
        assert np.array_equal(paged.leaf_rows[:count], roettger.leaf_rows[:expected])
        assert paged.grown > 0 and paged.slots >= len(paged._used()) > 1
        assert paged.memory_bytes() >= paged.slots * paged.slot_bytes
    finally:
        paged.close()

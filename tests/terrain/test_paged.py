"""A terrain paged in by tiles (terrain/paged.py): the in-memory method's selection, its image
within normal quantisation, the records held within the budget, the loader thread reading
ahead, and malformed files refused in one line."""
import numpy as np
import pytest

from vismobile.device.profile import get_profile
from vismobile.errors import WorldError
from vismobile.render.tile_arena import PagedArena, TileArena
from vismobile.terrain import sources
from vismobile.terrain.paged import PagedTiles, write_tiles
from vismobile.terrain.paths import path_cameras
from vismobile.terrain.tiles import TilePyramid, select_tiles


@pytest.fixture(scope="module")
def tiled(tmp_path_factory):
    hm = sources.diamond_square(257, seed=3, roughness=0.5, relief=0.1)
    pyramid = TilePyramid.build(hm, 16)
    path = tmp_path_factory.mktemp("paged") / "t.vmtiles"
    write_tiles(pyramid, path)
    return hm, pyramid, path


def _same_frame(paged, pyramid, arena, plain, camera, profile):
    """Select and draw camera's tiles paged and in memory; assert the same selection and images
    within 40 dB (int8 normals only). Returns the paged selection and image."""
    a = select_tiles(paged.pyramid, camera, profile.resolution, 1.0)
    b = select_tiles(pyramid, camera, profile.resolution, 1.0)
    assert all(np.array_equal(getattr(a, n), getattr(b, n))
               for n in ("level", "ti", "tj", "sides"))
    arena.draw(a, camera)
    image = arena.read_rgb().astype(np.float64)
    plain.draw(b, camera)
    mse = ((image - plain.read_rgb()) ** 2).mean()
    assert mse == 0 or 10 * np.log10(255 ** 2 / mse) > 40
    return a, image


def test_paged_frames_match_the_in_memory_method_within_the_budget(tiled):
    hm, pyramid, path = tiled
    profile = get_profile("ipaq-hx2490b")
    budget = 60 * 4 * 17 * 17  # 60 tiles of the 341
    paged = PagedTiles(path, budget_bytes=budget)
    arena, plain = PagedArena(paged, profile), TileArena(pyramid, profile)
    misses = 0
    points = np.random.default_rng(1).uniform(0, hm.extent, (2, 50))
    assert np.allclose(paged.height_at(*points), hm.height_at(*points), atol=1e-4)
    try:
        for camera in path_cameras(hm, "circle", "fast", frames=8, every=25):
            a, _ = _same_frame(paged, pyramid, arena, plain, camera, profile)
            assert len(paged.cache) <= max(paged.capacity, len(paged.current))
            misses += paged.misses
            paged.read_ahead(a, camera, profile.resolution, 1.0)
    finally:
        paged.close()
    assert misses > 0 and paged.memory_bytes() <= budget + 24 * 341


def test_a_malformed_tiled_terrain_is_refused(tiled, tmp_path):
    _, _, path = tiled
    data = path.read_bytes()
    for name, bad in (("magic.vmtiles", bytes(b ^ 0xFF for b in data[:4]) + data[4:]),
                      ("short.vmtiles", data[:len(data) - 10]),
                      ("stats.vmtiles", data[:200] + bytes([data[200] ^ 1]) + data[201:])):
        (tmp_path / name).write_bytes(bad)
        with pytest.raises(WorldError, match=name):
            PagedTiles(tmp_path / name, thread=False)


def test_terrain_tile_then_play_pages_within_the_budget(tiled, tmp_path, capsys):
    import csv

    from vismobile.app.cli import main
    from vismobile.terrain import store

    hm, _, _ = tiled
    store.save(tmp_path / "t.vmt", hm)
    assert main(["terrain", "tile", str(tmp_path / "t.vmt"), "-o",
                 str(tmp_path / "t.vmtiles")]) == 0
    assert main(["play", str(tmp_path / "t.vmtiles"), "--limit", "12", "--page-budget",
                 "0.05", "--quiet", "-o", str(tmp_path / "run")]) == 0
    rows = list(csv.DictReader(open(tmp_path / "run" / "frames.csv")))
    assert int(rows[0]["page_misses"]) > 0
    assert all(int(r["page_bytes"]) <= 0.05 * (1 << 20) + 24 * 341 for r in rows[1:])
    assert main(["play", str(tmp_path / "t.vmtiles"), "--terrain-method", "roam",
                 "-o", str(tmp_path / "bad")]) == 2
    assert "tiles method" in capsys.readouterr().err


def test_a_terrain_with_holes_pages_and_draws_them_cut(tmp_path):
    """No-data samples page too (normal bytes -128, -128; header holes): the same selection as
    in memory, the image within normal quantisation, the lake's centre cut."""
    from vismobile.render.shaders import CLEAR_RGB
    from vismobile.terrain.heightmap import quantize
    from vismobile.world.camera import Camera

    base = sources.diamond_square(129, seed=4, roughness=0.5, relief=0.1)
    h = base.heights.astype(np.float64)
    i, j = np.mgrid[0:129, 0:129]
    h[(i - 64) ** 2 + (j - 64) ** 2 < 20 ** 2] = np.nan
    h[30, 10:60] = np.nan
    hm = quantize(h, 1.0, "lake")
    pyramid = TilePyramid.build(hm, 16)
    path = tmp_path / "lake.vmtiles"
    write_tiles(pyramid, path)
    profile = get_profile("ipaq-hx2490b")
    paged = PagedTiles(path, thread=False)
    assert paged.heightmap.holes
    arena, plain = PagedArena(paged, profile), TileArena(pyramid, profile)
    top = float(np.nanmax(h))
    cameras = [Camera((64.0, top + 60.0, 64.0), yaw=0, pitch=-89.9, fov=30, aspect=240 / 320,
                      near=0.5, far=400)] + path_cameras(hm, "circle", "fast", frames=3, every=40)
    try:
        for k, camera in enumerate(cameras):
            _, image = _same_frame(paged, pyramid, arena, plain, camera, profile)
            if k == 0:  # from above: the lake's centre shows the clear colour
                assert np.abs(image[160, 120] - np.rint(np.array(CLEAR_RGB) * 255)).max() <= 1
    finally:
        paged.close()
    import struct
    import zlib

    broken = tmp_path / "broken.vmtiles"  # a holes flag that is not a boolean
    data = path.read_bytes().replace(b'"holes": true', b'"holes": 1.00')
    length = struct.unpack("<I", data[4:8])[0]
    head = data[12:12 + length]
    broken.write_bytes(data[:8] + struct.pack("<I", zlib.crc32(head)) + data[12:])
    with pytest.raises(WorldError, match="holes"):
        PagedTiles(broken, thread=False)

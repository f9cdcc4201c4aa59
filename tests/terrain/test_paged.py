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
            a = select_tiles(paged.pyramid, camera, profile.resolution, 1.0)
            b = select_tiles(pyramid, camera, profile.resolution, 1.0)
            assert all(np.array_equal(getattr(a, k), getattr(b, k))
                       for k in ("level", "ti", "tj", "sides"))
            arena.draw(a, camera)
            image = arena.read_rgb().astype(np.float64)
            plain.draw(b, camera)
            mse = ((image - plain.read_rgb()) ** 2).mean()
            assert mse == 0 or 10 * np.log10(255 ** 2 / mse) > 40  # int8 normals only
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

"""Seed 002's holes: no-data samples stored, cut by the alpha test, and the tile method's
horizontal error (Rodrigues's Table 4.1) keeping the cut's silhouette within the knob."""
import numpy as np
import pytest

from vismobile.device.profile import get_profile
from vismobile.errors import WorldError
from vismobile.render.shaders import CLEAR_RGB
from vismobile.render.terrain import TerrainRenderer
from vismobile.terrain import sources, store
from vismobile.terrain.heightmap import quantize
from vismobile.terrain.tiles import (TilePyramid, full_selection, horizontal_error, select_tiles,
                                     selection_mesh)
from vismobile.world.camera import Camera


@pytest.fixture(scope="module")
def holed():
    base = sources.diamond_square(129, seed=9, roughness=0.5, relief=0.08)
    h = base.heights.astype(np.float64)
    i, j = np.mgrid[0:129, 0:129]
    h[(i - 64) ** 2 + (j - 40) ** 2 < 15 ** 2] = np.nan  # a lake of no data
    h[100:103, 10:120] = np.nan  # a thin gap across the map
    return quantize(h, 1.0, "holed")


def test_holes_survive_the_vmt_and_a_corrupt_mask_is_refused(holed, tmp_path):
    path = tmp_path / "h.vmt"
    store.save(path, holed)
    back, _ = store.load(path)
    assert np.array_equal(back.valid, holed.valid) and back.digest() == holed.digest()
    data = bytearray(path.read_bytes())
    data[-3] ^= 0xFF
    (tmp_path / "bad.vmt").write_bytes(bytes(data))
    with pytest.raises(WorldError, match="bad.vmt.*mask"):
        store.load(tmp_path / "bad.vmt")
    whole = sources.diamond_square(17, seed=1)
    store.save(tmp_path / "v1.vmt", whole)
    assert b'"version": 1' in (tmp_path / "v1.vmt").read_bytes()[:400]


def test_horizontal_error_follows_table_4_1():
    valid = np.ones((9, 9), bool)
    valid[4, 2] = False  # the midpoint of the row edge (4, 0)-(4, 4) at stride 4
    e = horizontal_error(valid, 2, 4, 1.0)  # 2x2 tiles of 2 cells at stride 4 (8 cells each)
    assert e.shape == (1, 1) and e[0, 0] == 2.0  # A, B valid, C null: hsize = |AC|
    valid = np.ones((9, 9), bool)
    valid[0, 8] = False  # B of the edge (0, 4)-(0, 8): A and B differ
    assert horizontal_error(valid, 2, 4, 1.0)[0, 0] == 1.0  # hsize / 2
    assert horizontal_error(valid, 2, 1, 1.0).max() == 0.0  # no midpoint at stride 1


def test_full_render_cuts_the_holes(holed):
    profile = get_profile("ipaq-hx2490b")
    renderer = TerrainRenderer(holed, profile)
    pyramid = TilePyramid.build(holed, 16)
    # Straight down over the lake's centre: the clear colour there, ground beside it.
    camera = Camera((40.0, 200.0, 64.0), yaw=0, pitch=-89.9, fov=30, near=1, far=500,
                    aspect=profile.aspect)
    renderer.draw(*selection_mesh(pyramid, full_selection(pyramid, camera)), camera)
    image = renderer.read_rgb()
    clear = np.rint(np.array(CLEAR_RGB) * 255)
    assert np.abs(image[160, 120] - clear).max() <= 1
    assert np.abs(image[5, 5] - clear).max() > 10


def dilate(mask, r):
    out = mask.copy()
    for di in range(-r, r + 1):
        for dj in range(-r, r + 1):
            out |= np.roll(np.roll(mask, di, 0), dj, 1)
    return out


@pytest.fixture(scope="module")
def holed_257():
    """The cut tests' map: 257^2, a lake and a thin gap of no data."""
    base = sources.diamond_square(257, seed=9, roughness=0.5, relief=0.03)
    h = base.heights.astype(np.float64)
    i, j = np.mgrid[0:257, 0:257]
    h[(i - 128) ** 2 + (j - 80) ** 2 < 30 ** 2] = np.nan
    h[200:203, 20:240] = np.nan
    return quantize(h, 1.0, "holed")


def assert_cut_within_2px(holed, draw_full, draw_lod, share):
    """On 6 random views 20-80 units up: the LOD's cut at tau 2 px covers the pixels of the
    full-resolution cut within 2 px (dilation) both ways, with fewer than share x its
    triangles. draw_full(renderer, holed, camera) and draw_lod(renderer, camera, resolution)
    draw and return their triangle counts."""
    profile = get_profile("ipaq-hx2490b")
    renderer = TerrainRenderer(holed, profile)
    clear = np.rint(np.array(CLEAR_RGB) * 255)
    rng = np.random.default_rng(2)
    for _ in range(6):
        x, z = rng.uniform(20, 236, 2)
        camera = Camera((x, float(holed.height_at(x, z)) + rng.uniform(20, 80), z),
                        yaw=rng.uniform(0, 360), pitch=rng.uniform(-70, -20), fov=60,
                        near=0.5, far=800, aspect=profile.aspect)
        full_count = draw_full(renderer, holed, camera)
        full = np.abs(renderer.read_rgb() - clear).max(axis=-1) > 1
        lod_count = draw_lod(renderer, camera, profile.resolution)
        lod = np.abs(renderer.read_rgb() - clear).max(axis=-1) > 1
        assert not (lod & ~dilate(full, 2)).any() and not (full & ~dilate(lod, 2)).any()
        assert lod_count < share * full_count


def test_lod_cut_stays_within_tau_of_the_full_cut(holed_257):
    """At tau 2 px, 6 views 20-80 units up: the LOD's cut lies within 2 px (dilation) of the
    full-resolution cut, at 3-48% of its triangles. Measured: within 1 px with E_h, up to
    6 px on one view with E_h left out."""
    pyramid = TilePyramid.build(holed_257, 8)

    def full(renderer, holed, camera):
        tiles = full_selection(pyramid, camera)
        renderer.draw(*selection_mesh(pyramid, tiles), camera)
        return tiles.triangles

    def lod(renderer, camera, resolution):
        selection = select_tiles(pyramid, camera, resolution, 2.0)
        renderer.draw(*selection_mesh(pyramid, selection), camera)
        return selection.triangles

    assert_cut_within_2px(holed_257, full, lod, 0.5)


def test_terrain_build_pads_a_file_and_reads_its_nodata(tmp_path, capsys):
    from vismobile.app.cli import main

    h = np.add.outer(np.arange(20.0), np.arange(30.0))
    h[5:8, 5:9] = -9999.0
    np.save(tmp_path / "dem.npy", h)
    assert main(["terrain", "build", str(tmp_path / "dem.npy"), "--nodata", "-9999",
                 "-o", str(tmp_path / "dem.vmt")]) == 0
    hm, _ = store.load(tmp_path / "dem.vmt")
    assert hm.size == 33 and hm.spacing == 1.0
    assert (~hm.valid).sum() == 33 * 33 - 20 * 30 + 12
    assert np.allclose(hm.heights[:20, :30][hm.valid[:20, :30]], h[h > -9999], atol=1e-3)
    assert main(["terrain", "info", str(tmp_path / "dem.vmt")]) == 0
    assert "no data" in capsys.readouterr().out


def test_roettger_counts_the_horizontal_error_too(holed_257):
    """Röttger's blocks add Table 4.1's horizontal error (block_horizontal): at tau 2 px its
    cut stays within 2 px of its own full-resolution cut on the holed map's views."""
    from vismobile.study.terrain import draw_four_eight
    from vismobile.terrain.roettger import Roettger, block_horizontal

    valid = np.ones((5, 5), bool)
    valid[0, 2] = False  # the top side's midpoint of the one 4-cell block
    assert block_horizontal(valid, 4, 1.0)[0, 0] == 2.0
    roettger = Roettger(holed_257)

    def lod(renderer, camera, resolution):
        frame = roettger.update(camera, resolution, 2.0)
        renderer.draw_samples(frame.triangles, camera)
        return len(frame.triangles)

    assert_cut_within_2px(holed_257, draw_four_eight, lod, 0.5)


def test_roam_counts_the_horizontal_error_too(holed_257):
    """ROAM's wedgies add Table 4.1's horizontal error (bintree.horizontal_wedgies, nested by
    maximum), as length(e_h, e_v): at tau 2 px its cut stays within 2 px of its own
    full-resolution cut (measured: 1 px with e_h, up to 8 px without)."""
    from vismobile.study.terrain import draw_four_eight
    from vismobile.terrain.bintree import horizontal_wedgies
    from vismobile.terrain.roam import Roam

    valid = np.ones((3, 3), bool)
    valid[0, 1] = False  # an edge diamond's vertex between two valid corners
    e = horizontal_wedgies(valid, 1, 1.0).reshape(3, 3)
    # (0, 1): its corners (0, 0), (0, 2) valid, itself not: hsize = 1; the centre's own
    # diagonal is all valid, but it nests its child (0, 1)
    assert e[0, 1] == 1.0 and e[1, 1] == 1.0 and e[1, 0] == 0.0
    roam = Roam(holed_257)

    def lod(renderer, camera, resolution):
        roam.reset()
        frame = roam.update(camera, resolution, 2.0)
        renderer.draw_samples(frame.triangles, camera)
        return len(frame.triangles)

    assert_cut_within_2px(holed_257, draw_four_eight, lod, 0.2)

"""Persistent vertex slots (render/tile_arena.py): the same images as gathering every frame,
with only new tiles or blocks uploaded."""
import numpy as np

from vismobile.device.profile import get_profile
from vismobile.render.terrain import TerrainRenderer
from vismobile.render.tile_arena import BlockArena, TileArena
from vismobile.terrain import sources
from vismobile.terrain.paths import path_cameras
from vismobile.terrain.roam import Roam
from vismobile.terrain.tiles import TilePyramid, select_tiles, selection_mesh


def cameras(hm):
    return path_cameras(hm, "circle", "fast", frames=4, every=20)


def test_tiles_from_slots_draw_the_gathered_image_and_upload_only_new_tiles():
    hm = sources.diamond_square(257, seed=4, roughness=0.5, relief=0.1)
    profile = get_profile("ipaq-hx2490b")
    pyramid = TilePyramid.build(hm, 16)
    arena, plain = TileArena(pyramid, profile), TerrainRenderer(hm, profile)
    for k, camera in enumerate(cameras(hm)):
        selection = select_tiles(pyramid, camera, profile.resolution, 2.0)
        arena.draw(selection, camera)
        image = arena.read_rgb()
        new = arena.uploaded_tiles
        plain.draw(*selection_mesh(pyramid, selection), camera)
        assert np.array_equal(image, plain.read_rgb())
        arena.draw(selection, camera)  # the same frame again: nothing to upload
        assert arena.uploaded_tiles == 0 and (k > 0 or new == len(selection.level))


def test_blocks_draw_the_gathered_image_with_spills_and_a_small_budget():
    hm = sources.diamond_square(129, seed=6, roughness=0.5, relief=0.1)
    profile = get_profile("ipaq-hx2490b")
    roam = Roam(hm)
    plain = TerrainRenderer(hm, profile)
    roomy = BlockArena(hm, profile, cells=16)
    tight = BlockArena(hm, profile, budget_bytes=3 * 17 * 17 * 28, cells=16)  # 3 slots
    for camera in cameras(hm):
        triangles = roam.update(camera, profile.resolution, 1.0).triangles
        plain.draw_samples(triangles, camera)
        expected = plain.read_rgb()
        for arena in (roomy, tight):
            stats = arena.draw(triangles, camera)
            assert stats.triangles == len(triangles)
            assert np.array_equal(arena.read_rgb(), expected)
        assert tight.spilled > roomy.spilled
        roomy.draw(triangles, camera)
        assert roomy.uploaded_blocks == 0

"""Szenberg's column ray caster (seed 001) against the triangle render of the same map."""
import numpy as np
import pytest

from vismobile.device.profile import get_profile
from vismobile.geometry.boxes import box_mesh
from vismobile.render import SENTINEL
from vismobile.render.szenberg import ColumnCaster, LevelCamera, composite_objects
from vismobile.render.terrain import TerrainRenderer
from vismobile.terrain import sources
from vismobile.terrain.tiles import TilePyramid, full_selection, selection_mesh

PROFILE = get_profile("ipaq-hx2490b")
BASE = 1 << 28


@pytest.fixture(scope="module")
def scene():
    hm = sources.diamond_square(129, seed=3, roughness=0.5, relief=0.2)
    pyramid = TilePyramid.build(hm, 8)
    rng = np.random.default_rng(5)
    xz = rng.uniform(5, 123, (150, 2))
    size = rng.uniform(0.5, 3.0, 150)
    ground = hm.height_at(xz[:, 0], xz[:, 1])
    boxes = np.stack([np.c_[xz[:, 0] - size / 2, ground - 0.5, xz[:, 1] - size / 2],
                      np.c_[xz[:, 0] + size / 2, ground + size, xz[:, 1] + size / 2]], axis=1)
    vertices, triangles = box_mesh(boxes)
    cameras = [LevelCamera((64.0, float(hm.height_at(64, 120)) + 3, 120.0), 0.0,
                           PROFILE.resolution, 200, near=0.1, far=300),
               LevelCamera((10.0, float(hm.heights.max()) + 5, 10.0), -135.0,
                           PROFILE.resolution, 280, near=0.1, far=300)]
    return hm, pyramid, (vertices, triangles), cameras


def psnr(a, b):
    mse = np.mean((a.astype(float) - b.astype(float)) ** 2)
    return np.inf if mse == 0 else 10 * np.log10(255 ** 2 / mse)


def test_prof_table_is_the_window_depth_of_each_slice():
    camera = LevelCamera((0.0, 5.0, 0.0), 30.0, (240, 320), 100, near=0.5, far=200)
    depths = camera.depths()
    forward, _ = camera.axes()
    points = camera.eye + depths[:, None] * forward
    clip = np.c_[points, np.ones(len(points))] @ camera.view_projection().T
    window = (clip[:, 2] / clip[:, 3] + 1) / 2
    assert np.allclose(window, camera.prof(depths), atol=1e-9)
    assert depths[0] == 0.5 and depths[-1] >= 200


@pytest.mark.parametrize("arithmetic,refine", [("float64", False), ("fixed16.16", False),
                                               ("float64", True)])
def test_colour_image_matches_the_triangle_render(scene, arithmetic, refine):
    """PSNR >= 30 dB against the full-resolution triangle render (same lighting), in both
    arithmetics; measured 41-45 dB (Szenberg's slices) and 57-80 dB (refined)."""
    hm, pyramid, _, cameras = scene
    caster = ColumnCaster(hm, arithmetic)
    renderer = TerrainRenderer(hm, PROFILE)
    for camera in cameras:
        image = caster.render(camera, refine=refine)
        renderer.draw(*selection_mesh(pyramid, full_selection(pyramid)), camera)
        assert psnr(image.rgb, renderer.read_rgb()) >= (40 if refine else 30)


def test_objects_are_hidden_where_the_triangle_render_hides_them(scene):
    """Boxes Z-buffered into the refined ray-cast depth: the same boxes show as in the item
    buffer of the triangle render plus the boxes, and all but a few pixels (depth ties where
    a box enters the ground) agree; Szenberg's slice depths (Prof[i], up to one slice behind
    the ground) differ in a few percent of the boxes' pixels at most."""
    hm, pyramid, (vertices, triangles), cameras = scene
    renderer = TerrainRenderer(hm, PROFILE)
    caster = ColumnCaster(hm)
    shown = 0
    for camera in cameras:
        renderer.draw(*selection_mesh(pyramid, full_selection(pyramid)), camera, kind="item")
        renderer.draw_mesh_items(vertices, triangles, camera, BASE)
        ids = renderer.read_ids()
        truth = (ids != SENTINEL) & (ids >= BASE)
        for refine, share in ((True, 0.002), (False, 0.03)):
            sz = composite_objects(caster.render(camera, refine=refine), renderer, vertices,
                                   triangles, camera, BASE)
            mine = sz != SENTINEL
            assert (mine != truth).sum() <= share * truth.sum() + 2
            if refine:
                assert set(np.unique((sz[mine] - BASE) // 12)) == \
                    set(np.unique((ids[truth] - BASE) // 12))
        shown += int(truth.sum())
    assert shown > 1000


def test_fixed_point_works_in_cell_units_and_refuses_maps_beyond_its_range():
    from vismobile.errors import ProfileError
    from vismobile.terrain.heightmap import Heightmap

    ColumnCaster(Heightmap(np.zeros((65, 65), np.uint16), spacing=1000.0), "fixed16.16")
    with pytest.raises(ProfileError):
        ColumnCaster(Heightmap(np.full((65, 65), 60000, np.uint16), z_scale=1.0), "fixed16.16")

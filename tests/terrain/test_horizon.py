"""Horizon occlusion (seed 001) is conservative against the real item buffer."""
import numpy as np
import pytest

from vismobile.device.profile import get_profile
from vismobile.geometry.boxes import box_mesh
from vismobile.render import SENTINEL
from vismobile.render.terrain import TerrainRenderer
from vismobile.terrain.horizon import HorizonCaster, min_mip
from vismobile.terrain.paths import path_cameras
from vismobile.terrain.tiles import full_selection, selection_mesh

PROFILE = get_profile("ipaq-hx2490b")
BASE = 1 << 28  # item ids of the boxes start here


def ground_boxes(heightmap, count, seed):
    rng = np.random.default_rng(seed)
    xz = rng.uniform(0.05, 0.95, (count, 2)) * heightmap.extent
    size = rng.uniform(1.0, 5.0, count)
    ground = heightmap.height_at(xz[:, 0], xz[:, 1])
    low = np.c_[xz[:, 0] - size / 2, ground - 0.5, xz[:, 1] - size / 2]
    high = np.c_[xz[:, 0] + size / 2, ground + size, xz[:, 1] + size / 2]
    return np.stack([low, high], axis=1)


def boxes_seen(renderer, pyramid, camera, vertices, triangles):
    """Ids of the boxes (12 triangles each, box_mesh) the item buffer of the full-resolution
    ground plus the boxes shows."""
    renderer.draw(*selection_mesh(pyramid, full_selection(pyramid, camera)), camera, kind="item")
    renderer.draw_mesh_items(vertices, triangles, camera, BASE)
    ids = renderer.read_ids()
    return np.unique((ids[(ids != SENTINEL) & (ids >= BASE)] - BASE) // 12)


def test_min_mip_is_the_block_minimum(fractal129):
    h = fractal129.heights.astype(np.float64)
    mips = min_mip(h)
    assert len(mips) == 8 and mips[-1].shape == (1, 1) and mips[-1][0, 0] == h.min()
    for k in (0, 3, 5):
        s = 1 << k
        i, j = 1, 2
        assert mips[k][i, j] == h[i * s:(i + 1) * s + 1, j * s:(j + 1) * s + 1].min()


def test_hidden_boxes_are_never_seen(pyramid257):
    """Over a low path, no box the horizon hides shows in the item buffer of the full terrain
    plus the boxes, and the horizon does hide a good share of the boxes in view."""
    from vismobile.geometry.planes import classify_boxes

    hm = pyramid257.heightmap
    boxes = ground_boxes(hm, 300, seed=4)
    vertices, triangles = box_mesh(boxes)
    caster = HorizonCaster(hm, bands=60, step=0.02)
    renderer = TerrainRenderer(hm, PROFILE)
    hidden_total = in_view_total = 0
    for camera in path_cameras(hm, "lemniscate", "fast", frames=4, every=200, eye_height=1.5):
        hidden = caster.cast(camera).hidden(boxes)
        seen = boxes_seen(renderer, pyramid257, camera, vertices, triangles)
        assert not hidden[seen].any()
        in_view = ~classify_boxes(boxes, camera.frustum_planes())[0]
        hidden_total += int((hidden & in_view).sum())
        in_view_total += int(in_view.sum())
    assert hidden_total >= 0.2 * in_view_total > 0


def test_boxes_at_or_behind_the_eye_stay_visible(fractal129):
    caster = HorizonCaster(fractal129, bands=30)
    camera = path_cameras(fractal129, "circle", "fast", frames=1, eye_height=2)[0]
    eye = camera.eye
    around = np.array([[eye - 1, eye + 1]])
    behind = np.array([[eye - 3 * camera.forward - 1, eye - 3 * camera.forward + 1]])
    assert not caster.cast(camera).hidden(np.concatenate([around, behind])).any()
    under = camera.with_(position=(eye[0], float(fractal129.heights.min()) - 10, eye[2]))
    far_box = np.array([[eye + 50 * camera.forward - 1, eye + 50 * camera.forward + 1]])
    assert not caster.cast(under).hidden(far_box).any()  # eye under the ground: no claims


def test_tiles_behind_the_horizon_change_no_pixel(pyramid257):
    """Dropping the tiles the horizon hides (ground lowered by the drawn error) leaves the
    rendered image exactly as it was, and drops something on the low valley path."""
    from vismobile.terrain.tiles import drop_hidden, select_tiles, selection_error

    hm = pyramid257.heightmap
    caster = HorizonCaster(hm, bands=60, step=0.02)
    renderer = TerrainRenderer(hm, PROFILE)
    dropped = 0
    for camera in path_cameras(hm, "valley", "fast", frames=3, every=100, eye_height=1.0):
        selection = select_tiles(pyramid257, camera, PROFILE.resolution, 1.0)
        kept = drop_hidden(pyramid257, selection,
                           caster.cast(camera, selection_error(pyramid257, selection)))
        images = []
        for s in (selection, kept):
            renderer.draw(*selection_mesh(pyramid257, s), camera)
            images.append(renderer.read_rgb())
        assert np.array_equal(images[0], images[1])
        dropped += selection.triangles - kept.triangles
    assert dropped > 0


def test_fixed_point_horizon_never_hides_a_visible_box(pyramid257):
    """The 16.16 cast and test (fixed16.16 profiles): over low paths, no box it hides shows in
    the item buffer of the full terrain plus the boxes; it hides about as much as float64 and
    never a box float64 keeps... within its safety margin (counted, not asserted)."""
    from vismobile.geometry.planes import classify_boxes

    hm = pyramid257.heightmap
    boxes = ground_boxes(hm, 300, seed=6)
    vertices, triangles = box_mesh(boxes)
    fixed_profile = get_profile("ipaq-hx2490b", "fixed16.16")
    fixed = HorizonCaster.for_profile(hm, fixed_profile, bands=60, step=0.02)
    exact = HorizonCaster(hm, bands=60, step=0.02)
    assert fixed.arithmetic == "fixed16.16" and exact.arithmetic == "float64"
    renderer = TerrainRenderer(hm, PROFILE)
    hidden_total = exact_total = in_view_total = 0
    cameras = (path_cameras(hm, "valley", "fast", frames=3, every=150, eye_height=1.5)
               + path_cameras(hm, "lemniscate", "fast", frames=3, every=170, eye_height=1.0))
    for camera in cameras:
        hidden = fixed.cast(camera).hidden(boxes)
        seen = boxes_seen(renderer, pyramid257, camera, vertices, triangles)
        assert not hidden[seen].any()
        in_view = ~classify_boxes(boxes, camera.frustum_planes())[0]
        hidden_total += int((hidden & in_view).sum())
        exact_total += int((exact.cast(camera).hidden(boxes) & in_view).sum())
        in_view_total += int(in_view.sum())
    assert hidden_total >= 0.2 * in_view_total > 0
    assert hidden_total >= 0.9 * exact_total


def test_fixed_point_horizon_refuses_maps_beyond_its_range():
    from vismobile.errors import ProfileError
    from vismobile.terrain.heightmap import Heightmap

    wide = Heightmap(np.zeros((65, 65), np.uint16), spacing=1000.0)
    with pytest.raises(ProfileError):
        HorizonCaster(wide, arithmetic="fixed16.16")
    odd = Heightmap(np.zeros((65, 65), np.uint16), spacing=0.1)
    camera = path_cameras(odd, "circle", "fast", frames=1, eye_height=2)[0]
    with pytest.raises(ProfileError):
        HorizonCaster(odd, arithmetic="fixed16.16").cast(camera)


def test_ground_the_near_plane_clips_never_occludes():
    """Low cameras (eye 1 cm to 5 m up, near 1e-3 to 1) over a steep map: nothing the horizon
    hides, ground tile or box with a buried base, shows in the item buffer, in float64 and
    16.16. Before issue 30 the clipped ground in front of the eye counted as solid and 5 of
    these 40 cameras lost visible ground or boxes (up to 22,293 pixels)."""
    from vismobile.world.camera import Camera
    from vismobile.terrain import sources
    from vismobile.terrain.tiles import TilePyramid, drop_hidden

    hm = sources.diamond_square(129, seed=21, roughness=0.6, relief=0.5)
    pyramid = TilePyramid.build(hm, 8)
    rng = np.random.default_rng(1)
    count = 40
    xz = rng.uniform(0.1, 0.9, (count, 2)) * hm.extent
    up = 10.0 ** rng.uniform(-2, np.log10(5), count)
    near = 10.0 ** rng.uniform(-3, 0, count)
    ground = hm.height_at(xz[:, 0], xz[:, 1])
    cameras = [Camera((x, g + u, z), yaw=float(a), pitch=float(p), fov=75.0, near=float(n),
                      far=1.5 * hm.extent)
               for (x, z), g, u, n, a, p in zip(xz, ground, up, near, rng.uniform(0, 360, count),
                                                rng.uniform(-40, 30, count))]
    boxes = ground_boxes(hm, 200, seed=1)
    vertices, triangles = box_mesh(boxes)
    renderer = TerrainRenderer(hm, PROFILE)
    per_tile = len(pyramid.templates[0])
    casters = [HorizonCaster(hm, bands=60, step=0.02, arithmetic=a)
               for a in ("float64", "fixed16.16")]
    hidden_tiles = 0
    for camera in cameras:
        selection = full_selection(pyramid, camera)
        renderer.draw(*selection_mesh(pyramid, selection), camera, kind="item")
        renderer.draw_mesh_items(vertices, triangles, camera, BASE)
        ids = renderer.read_ids()
        ids = ids[ids != SENTINEL].astype(np.int64)
        seen_tiles = np.unique(ids[ids < BASE] // per_tile)
        seen_boxes = np.unique((ids[ids >= BASE] - BASE) // 12)
        keys = selection.ti * 4096 + selection.tj
        for caster in casters:
            horizon = caster.cast(camera)
            kept = drop_hidden(pyramid, selection, horizon)
            assert np.isin(keys[seen_tiles], kept.ti * 4096 + kept.tj).all()
            assert not horizon.hidden(boxes)[seen_boxes].any()
            hidden_tiles += len(selection.ti) - len(kept.ti)
    assert hidden_tiles > 0

"""The item buffer: exact triangle ids per pixel, sentinel background, depth and face culling."""
import numpy as np
import pytest

from vismobile.world.camera import Camera
from vismobile.open3d_import import raycast_primitive_ids
from vismobile.render import SENTINEL, ItemBufferRenderer, item_buffer, render_rgb
from vismobile.render.shaders import CLEAR_RGB
from vismobile.world.world import World

from .conftest import screen_quad, terrain


def test_quad_fills_exactly_its_pixels(camera, profile):
    # NDC [-0.5, 0.5] x [-0.5, 0.5] is columns 60..179 and rows 80..239 of 240 x 320.
    world = screen_quad(5.0, -0.5, 0.5, -0.5, 0.5)
    ids = item_buffer(world, None, camera, profile)
    assert ids.shape == (320, 240) and ids.dtype == np.uint32
    inside = np.zeros(ids.shape, bool)
    inside[80:240, 60:180] = True
    assert np.all(ids[~inside] == SENTINEL)
    assert np.all((ids[inside] == 0) | (ids[inside] == 1))
    # Triangle 0 is the lower-right half (below the diagonal from bottom-left to top-right).
    rows, cols = np.nonzero(inside)
    below = (239 - rows) < (cols - 60) * (160 / 120) - 1
    above = (239 - rows) > (cols - 60) * (160 / 120) + 1
    assert np.all(ids[rows[below], cols[below]] == 0)
    assert np.all(ids[rows[above], cols[above]] == 1)


def test_row_zero_is_the_top(camera, profile):
    world = screen_quad(5.0, -1.0, 1.0, 0.5, 1.0)  # top quarter of the screen
    ids = item_buffer(world, None, camera, profile)
    assert np.all(ids[:80] != SENTINEL) and np.all(ids[80:] == SENTINEL)


def test_background_is_sentinel(camera, profile):
    world = screen_quad(5.0, -0.5, 0.5, -0.5, 0.5)
    ids = item_buffer(world, [], camera, profile)
    assert np.all(ids == SENTINEL) and SENTINEL == 0xFFFFFFFF


def test_nearer_triangle_hides_the_one_behind_whatever_the_order(camera, profile):
    far = screen_quad(10.0, -0.8, 0.8, -0.8, 0.8, object_id=0)
    near = screen_quad(4.0, -0.3, 0.3, -0.3, 0.3, object_id=1)
    world = World.concatenate([near, far])  # near = ids 0, 1; far = ids 2, 3
    ids = item_buffer(world, None, camera, profile)
    assert np.all(np.isin(ids[130:190, 90:150], [0, 1]))  # centre: only the near quad
    assert np.all(np.isin(ids[40:60, 30:210], [2, 3]))    # the far quad around it
    reversed_world = World.concatenate([far, near])
    swapped = item_buffer(reversed_world, None, camera, profile)
    mapping = np.array([2, 3, 0, 1], dtype=np.uint32)
    remapped = np.where(swapped == SENTINEL, SENTINEL, mapping[swapped % 4])
    assert np.array_equal(remapped, ids)


def test_drawing_a_subset_shows_only_that_subset(camera, profile):
    far = screen_quad(10.0, -0.8, 0.8, -0.8, 0.8)
    near = screen_quad(4.0, -0.3, 0.3, -0.3, 0.3)
    world = World.concatenate([near, far])
    ids = item_buffer(world, [2, 3], camera, profile)
    assert set(np.unique(ids).tolist()) == {2, 3, int(SENTINEL)}


def test_cull_back_removes_back_faces(profile):
    world = screen_quad(5.0, -0.5, 0.5, -0.5, 0.5)  # front face toward +z
    behind = Camera((0.0, 0.0, -10.0), yaw=180.0, aspect=profile.aspect)
    seen = item_buffer(world, None, behind, profile, cull_back=False)
    assert set(np.unique(seen).tolist()) == {0, 1, int(SENTINEL)}
    assert np.all(item_buffer(world, None, behind, profile, cull_back=True) == SENTINEL)
    front = Camera((0.0, 0.0, 0.0), aspect=profile.aspect)
    assert np.array_equal(item_buffer(world, None, front, profile, cull_back=True),
                          item_buffer(world, None, front, profile, cull_back=False))


def test_item_buffer_matches_the_shaded_coverage(profile):
    world = terrain(40, seed=3)
    camera = Camera((0.0, 12.0, 45.0), yaw=10.0, pitch=-25.0, aspect=profile.aspect)
    ids = item_buffer(world, None, camera, profile, cull_back=True)
    rgb = render_rgb(world, np.arange(world.triangle_count), camera, profile, cull_back=True)
    clear = np.rint(np.array(CLEAR_RGB) * 255).astype(np.uint8)
    background = np.all(rgb == clear, axis=2)
    assert 0.05 < background.mean() < 0.95
    assert np.array_equal(background, ids == SENTINEL)


def test_item_buffer_agrees_with_ray_casting(profile):
    world = World.concatenate([terrain(30, seed=1),
                               screen_quad(1.0, -0.2, 0.2, -0.2, 0.2).transformed(8.0,
                                                                                 (0, 5, 10))])
    camera = Camera((0.0, 10.0, 40.0), yaw=-5.0, pitch=-20.0, aspect=profile.aspect)
    ids = item_buffer(world, None, camera, profile).astype(np.int64)
    ids[ids == SENTINEL] = -1
    right, up, forward = camera.basis()
    half = np.tan(np.radians(camera.fov) / 2.0)
    cols, rows = np.meshgrid(np.arange(profile.width), np.arange(profile.height))
    x = ((cols + 0.5) / profile.width * 2 - 1) * half * camera.aspect
    y = (1 - (rows + 0.5) / profile.height * 2) * half
    directions = forward + x[..., None] * right + y[..., None] * up
    origins = np.broadcast_to(camera.eye, directions.shape)
    truth = raycast_primitive_ids(world.vertices, world.triangles, origins.reshape(-1, 3),
                                  directions.reshape(-1, 3)).reshape(ids.shape)
    assert 0.05 < (truth == -1).mean() < 0.95
    # Pixels whose centre lies on a shared edge may go either way.
    assert (truth == ids).mean() > 0.999


def test_renderer_is_reusable_across_frames(profile):
    world = terrain(20, seed=2)
    renderer = ItemBufferRenderer(world, profile)
    cameras = [Camera((0.0, 10.0, 40.0 - 5 * k), yaw=5 * k, pitch=-20.0, aspect=profile.aspect)
               for k in range(3)]
    all_ids = np.arange(world.triangle_count)
    first = [renderer.render(all_ids, c).copy() for c in cameras]
    again = [item_buffer(world, all_ids, c, profile) for c in cameras]
    assert all(np.array_equal(a, b) for a, b in zip(first, again))
    assert not np.array_equal(first[0], first[2])


def test_rejects_ids_outside_the_world(camera, profile):
    world = screen_quad(5.0, -0.5, 0.5, -0.5, 0.5)
    with pytest.raises(ValueError, match=r"\[0, 2\)"):
        item_buffer(world, [0, 2], camera, profile)


def test_cached_renderers_die_with_their_world(camera, profile):
    import gc

    from vismobile.render.item_buffer import _RENDERERS
    from vismobile.render.world_buffers import _CACHE

    world = screen_quad(5.0, -0.5, 0.5, -0.5, 0.5)
    item_buffer(world, None, camera, profile)
    assert world in _RENDERERS and world in _CACHE
    # Worlds that earlier tests in this process left in reference cycles go first, so the count
    # below changes by this world alone (under pytest-xdist the files before this one vary).
    gc.collect()
    before = len(_CACHE)
    del world
    gc.collect()
    assert len(_CACHE) == before - 1

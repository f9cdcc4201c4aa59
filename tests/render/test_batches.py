"""uint16 batching: every index fits 16 bits, and the split never changes the picture."""
import numpy as np
import pytest

from vismobile.world.camera import Camera
from vismobile.render import Renderer, item_buffer
from vismobile.render.batches import batch_count, batch_indices


def test_indices_are_local_to_their_batch_and_below_65536():
    rng = np.random.default_rng(0)
    ids = np.unique(rng.integers(0, 100_000, 30_000))
    indices, starts = batch_indices(ids, 100_000, 21_845)
    assert indices.dtype == np.uint16 and len(starts) == batch_count(100_000, 21_845) + 1 == 6
    for b in range(len(starts) - 1):
        chunk = indices[3 * starts[b]:3 * starts[b + 1]].astype(np.int64)
        assert chunk.max(initial=0) <= 3 * 21_845 - 1 <= 65_534
        rebuilt = b * 21_845 + chunk.reshape(-1, 3) // 3
        assert np.all(rebuilt == rebuilt[:, :1])  # three corners of one triangle
        assert np.array_equal(rebuilt[:, 0], ids[starts[b]:starts[b + 1]])
        assert np.array_equal(chunk.reshape(-1, 3) % 3, np.tile([0, 1, 2], (len(chunk) // 3, 1)))


def test_unsorted_and_repeated_ids_are_sorted_once():
    indices, starts = batch_indices([5, 1, 5, 3], 10, 4)
    assert starts.tolist() == [0, 2, 3, 3]
    assert indices.tolist() == [3, 4, 5, 9, 10, 11, 3, 4, 5]


def test_empty_frame_draws_nothing():
    indices, starts = batch_indices(np.array([], dtype=np.int64), 10, 4)
    assert len(indices) == 0 and starts.tolist() == [0, 0, 0, 0]


def test_refuses_ids_out_of_range_and_oversized_batches():
    with pytest.raises(ValueError, match=r"\[0, 10\)"):
        batch_indices([10], 10, 4)
    with pytest.raises(ValueError, match="65,535"):
        batch_indices([0], 100_000, 21_846)


def test_batch_size_never_changes_the_image(big_terrain, profile):
    # 45,000 triangles = 135,000 vertices: three batches at the uint16 limit.
    camera = Camera((-30.0, 15.0, 45.0), yaw=-30.0, pitch=-25.0, aspect=profile.aspect)
    every = np.arange(big_terrain.triangle_count)
    rng = np.random.default_rng(1)
    some = np.sort(rng.choice(every, 30_000, replace=False))
    for triangles in (every, some):
        reference = None
        for vertices in (65_535, 9_999, 3_000):
            small = profile.with_(max_batch_vertices=vertices)
            renderer = Renderer(big_terrain, small)
            stats = renderer.draw(triangles, camera, cull_back=True)
            assert stats.draw_batches == len(np.unique(triangles // small.batch_triangles))
            assert stats.triangles == len(triangles)
            picture = (renderer.read_rgb(), item_buffer(big_terrain, triangles, camera, small,
                                                          cull_back=True))
            if reference is None:
                reference = picture
                if len(triangles) == len(every):
                    assert stats.draw_batches == 3
            assert np.array_equal(picture[0], reference[0])
            assert np.array_equal(picture[1], reference[1])

"""Ray-cast ground truth against the raster item buffer, and the on-disk truth cache."""
import numpy as np

from vismobile.world.camera import Camera
from vismobile.render import item_buffer
from vismobile.study.groundtruth import (camera_rays, classify_disagreements, compare_truths,
                                         load_truth, raycast_buffer, save_truth,
                                         trajectory_truth)
from vismobile.study.metrics import SENTINEL, VisibleSet
from vismobile.world.world import World


def test_centre_ray_is_forward_and_rows_go_down():
    camera = Camera((1, 2, 3), yaw=30, pitch=10)
    _, directions = camera_rays(camera, 3, 3)
    right, up, forward = camera.basis()
    assert np.allclose(directions[4], forward)
    assert np.dot(directions[1] - directions[7], up) > 0      # row 0 is the top
    assert np.dot(directions[5] - directions[3], right) > 0   # column 0 is the left
    assert np.allclose(directions @ forward, 1.0)


def test_raster_and_rays_agree_on_the_tiny_world(world, trajectory, profile):
    for frame in (0, 3, 7):
        camera = trajectory.camera(frame, profile.aspect)
        for back in (False, True):
            raster = item_buffer(world, None, camera, profile, cull_back=back)
            result = compare_truths(world, camera, raster, cull_back=back)
            assert result["pixel_agreement"] > 0.995
            explained = sum(result[k] for k in ("silhouette", "shared_edge", "coplanar",
                                                "depth_tie", "other"))
            assert explained == result["pixels"] - result["agree"]


def _quad(z, facing_camera):
    vertices = np.array([[-1, -1, z], [1, -1, z], [1, 1, z], [-1, 1, z]], float)
    triangles = np.array([[0, 1, 2], [0, 2, 3]])
    return World(vertices, triangles if facing_camera else triangles[:, ::-1])


def test_back_faces_are_seen_through_only_with_cull_back():
    world = World.concatenate([_quad(-2.0, False), _quad(-4.0, True)])
    camera = Camera((0, 0, 0), aspect=1.0)
    front = raycast_buffer(world, camera, 8, 8)
    through = raycast_buffer(world, camera, 8, 8, cull_back=True)
    assert set(np.unique(front)) <= {0, 1, SENTINEL}
    assert set(np.unique(through)) <= {2, 3, SENTINEL}


def test_hits_beyond_far_or_before_near_are_misses():
    world = _quad(-5.0, True)
    assert (raycast_buffer(world, Camera((0, 0, 0), aspect=1.0, far=4.0), 4, 4)
            == SENTINEL).all()
    assert (raycast_buffer(world, Camera((0, 0, -4.95), aspect=1.0, near=0.1), 4, 4)
            == SENTINEL).all()


def test_disagreements_are_classified():
    world = World.concatenate([_quad(-2.0, True), _quad(-2.0, True)])   # duplicated faces
    camera = Camera((0, 0, 0), aspect=1.0)
    a = np.array([[0, 1], [SENTINEL, 1]], dtype=np.uint32)
    b = np.array([[2, 1], [0, 1]], dtype=np.uint32)
    counts = classify_disagreements(world, camera, a, b)
    assert counts["agree"] == 2 and counts["silhouette"] == 1 and counts["coplanar"] == 1


def test_truth_cache_round_trip(tmp_path, world, trajectory, profile):
    frames = [0, 5]
    cameras = [trajectory.camera(f, profile.aspect) for f in frames]
    calls = []

    def buffer_fn(camera):
        calls.append(camera)
        return item_buffer(world, None, camera, profile)

    first = trajectory_truth(world, cameras, frames, buffer_fn, profile.resolution,
                             trajectory.poses, False, tmp_path)
    again = trajectory_truth(world, cameras, frames, buffer_fn, profile.resolution,
                             trajectory.poses, False, tmp_path)
    assert len(calls) == 2
    for x, y in zip(first, again):
        assert np.array_equal(x.ids, y.ids) and np.array_equal(x.pixels, y.pixels)
    path = next(tmp_path.glob("truth-*.npz"))
    loaded_frames, sets = load_truth(path)
    assert loaded_frames == frames and sets[0].total == 240 * 320


def test_save_truth_empty(tmp_path):
    save_truth(tmp_path / "t.npz", [], [])
    assert load_truth(tmp_path / "t.npz") == ([], [])


def test_visible_set_of_all_background():
    seen = VisibleSet.from_buffer(np.full((2, 2), SENTINEL, dtype=np.uint32))
    assert len(seen.ids) == 0 and seen.total == 4

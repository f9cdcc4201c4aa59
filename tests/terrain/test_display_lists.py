"""Pires's display lists: cached per-chunk index arrays give Röttger's mesh, and a reused
chunk is neither emitted nor uploaded."""
import numpy as np

from vismobile.device.profile import get_profile
from vismobile.render.chunks import ChunkRenderer
from vismobile.render.terrain import TerrainRenderer
from vismobile.terrain.display_lists import DisplayLists
from vismobile.terrain.paths import path_cameras
from vismobile.terrain.roettger import Roettger

PROFILE = get_profile("ipaq-hx2490b")


def canonical(triangles):
    """Triangles as a set-like sorted array, each rotated to start at its smallest id."""
    t = np.asarray(triangles, np.int64).reshape(-1, 3)
    order = (np.argmin(t, axis=1)[:, None] + np.arange(3)) % 3  # keeps the winding
    rolled = np.take_along_axis(t, order, axis=1)
    return rolled[np.lexsort(rolled.T[::-1])]


def test_cached_chunks_are_roettgers_mesh_and_reused_when_still(fractal257):
    cached, rebuilt = DisplayLists(Roettger(fractal257)), \
        DisplayLists(Roettger(fractal257), cache=False)
    plain = Roettger(fractal257)
    for camera in path_cameras(fractal257, "circle", "slow", frames=4, every=50):
        a = cached.update(camera, PROFILE.resolution, 1.0)
        b = rebuilt.update(camera, PROFILE.resolution, 1.0)
        truth = canonical(plain.update(camera, PROFILE.resolution, 1.0).triangles)
        assert np.array_equal(canonical(cached.sample_triangles(a)), truth)
        assert np.array_equal(canonical(rebuilt.sample_triangles(b)), truth)
        assert b.reused == 0 and b.rebuilt == len(b.chunks)
    still = cached.update(camera, PROFILE.resolution, 1.0)
    assert still.rebuilt == 0 and still.reused == len(still.chunks) > 0
    before = dict(zip(still.chunks.tolist(), still.versions.tolist()))
    moved = cached.update(camera.with_(position=np.add(camera.position, (3.0, 0, 0))),
                          PROFILE.resolution, 1.0)
    assert 0 < moved.rebuilt < len(moved.chunks)
    # A chunk's version changes exactly when it was rebuilt this frame.
    bumped = sum(before.get(c, -1) != v for c, v in zip(moved.chunks.tolist(),
                                                         moved.versions.tolist()))
    assert bumped == moved.rebuilt


def test_chunk_renderer_draws_the_same_image_and_uploads_only_changed_chunks(fractal257):
    lists = DisplayLists(Roettger(fractal257))
    renderer = ChunkRenderer(lists, PROFILE)
    plain, plain_renderer = Roettger(fractal257), TerrainRenderer(fractal257, PROFILE)
    cameras = path_cameras(fractal257, "circle", "slow", frames=3)
    uploads = []
    for camera in cameras + [cameras[-1]]:
        frame = lists.update(camera, PROFILE.resolution, 1.0)
        renderer.draw(frame, camera)
        image = renderer.read_rgb()
        plain_renderer.draw_samples(plain.update(camera, PROFILE.resolution, 1.0).triangles,
                                    camera)
        assert np.array_equal(image, plain_renderer.read_rgb())
        uploads.append(renderer.uploaded_bytes)
    # The first frame fills every visible slot; a still camera uploads only the draw commands.
    assert uploads[0] > 10 * uploads[-1]
    assert uploads[-1] == 20 * len(frame.chunks)

"""The terrain renderer and the image-error measurement (real EGL renders, never mocked)."""
import numpy as np

from vismobile.device.profile import get_profile
from vismobile.render import SENTINEL
from vismobile.render.terrain import TerrainRenderer, unproject
from vismobile.study.terrain import TileMethod, image_error, measure, pixel_height_errors
from vismobile.terrain.paths import path_cameras
from vismobile.terrain.tiles import full_selection, selection_mesh

from .conftest import overview_cameras

PROFILE = get_profile("ipaq-hx2490b")


def test_full_render_depth_lies_on_the_ground(pyramid257):
    hm = pyramid257.heightmap
    camera = overview_cameras(hm)[0].with_(aspect=PROFILE.aspect)
    renderer = TerrainRenderer(hm, PROFILE)
    selection = full_selection(pyramid257, camera)
    stats = renderer.draw(*selection_mesh(pyramid257, selection), camera)
    assert stats.triangles == selection.triangles and stats.draw_batches >= 1
    points = unproject(renderer.read_depth(), camera)
    covered = np.isfinite(points[..., 0])
    assert 0.3 < covered.mean() < 1.0  # ground and sky
    p = points[covered]
    assert np.abs(p[:, 1] - hm.height_at(p[:, 0], p[:, 2])).max() < 0.05 * hm.spacing * 10
    assert pixel_height_errors(renderer.read_depth(), camera, hm, PROFILE.resolution).max() < 0.25
    # Item buffer: ids are draw-order triangle indices, background is the sentinel.
    renderer.draw(*selection_mesh(pyramid257, selection), camera, kind="item")
    ids = renderer.read_ids()
    assert ((ids == SENTINEL) == ~covered).mean() > 0.99
    assert ids[ids != SENTINEL].max() < selection.triangles


def test_image_error_metrics():
    a = np.zeros((4, 4, 3), np.uint8)
    b = a.copy()
    assert image_error(a, b) == {"psnr": float("inf"), "differing": 0.0}
    b[0, 0, 1] = 255
    err = image_error(a, b)
    assert err["differing"] == 1 / 16 and np.isclose(err["psnr"], 10 * np.log10(16 * 3))


def test_small_tolerance_is_invisible_and_large_is_not(pyramid257):
    """Against the full render: 0.5 px keeps PSNR >= 40 dB and the measured pixel-height error
    within the knob (plus depth-buffer rounding); 8 px draws fewer triangles and costs PSNR."""
    hm = pyramid257.heightmap
    camera = overview_cameras(hm)[0].with_(aspect=PROFILE.aspect)
    low, high = measure([TileMethod(pyramid257)], pyramid257.heightmap, [camera], [0.5, 8.0], PROFILE)
    assert low["psnr"] >= 40 and low["pixel_height_max"] <= 0.5 + 0.25
    assert high["triangles"] < low["triangles"] <= low["full_triangles"]
    assert high["psnr"] < low["psnr"] and high["differing"] > low["differing"]


def test_paths_are_deterministic_and_above_ground(fractal257):
    for kind in ("circle", "lemniscate"):
        slow = path_cameras(fractal257, kind, "slow", frames=5, every=50)
        fast = path_cameras(fractal257, kind, "fast", frames=5, every=5)
        again = path_cameras(fractal257, kind, "fast", frames=5, every=5)
        assert [c.position for c in fast] == [c.position for c in again]
        for cams in (slow, fast):
            eye = np.array([c.position for c in cams])
            ground = fractal257.height_at(eye[:, 0], eye[:, 2])
            assert np.allclose(eye[:, 1] - ground, fractal257.spacing)
            assert (eye[:, [0, 2]] > 0).all() and (eye[:, [0, 2]] < fractal257.extent).all()
        # Same number of frames: the fast path moves 10x as far along the curve.
        step_slow = np.linalg.norm(np.diff([c.position for c in slow], axis=0)[:, [0, 2]], axis=1)
        step_fast = np.linalg.norm(np.diff([c.position for c in fast], axis=0)[:, [0, 2]], axis=1)
        assert np.isclose(step_fast.mean(), step_slow.mean(), rtol=0.5)


def test_measure_warms_up_without_changing_what_a_path_selects(fractal129):
    # The untimed warm-up frame (numba's first-use compile) leaves each method's frame-to-frame
    # state as a fresh method's: the measured rows select the same triangles.
    from vismobile.study.terrain import build_method

    cameras = [c.with_(aspect=PROFILE.aspect)
               for c in path_cameras(fractal129, "circle", "slow", frames=4, every=8)]
    for name in ("roam", "roettger", "tiles"):
        rows = measure([build_method(name, fractal129, 8)], fractal129, cameras, [1.0], PROFILE,
                       render=False)
        fresh = build_method(name, fractal129, 8)
        expected = [fresh.frame(c, PROFILE.resolution, 1.0)[2] for c in cameras]
        assert [r["triangles"] for r in rows] == expected, name

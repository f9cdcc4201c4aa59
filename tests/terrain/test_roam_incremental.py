"""Incremental ROAM (issue 30): wake-up queues and cached block emission keep every frame
within tau and crack-free, and the per-frame work follows the motion."""
import numpy as np

from vismobile.study.terrain_check import rasterise, reference, screen_errors
from vismobile.terrain.paths import path_cameras
from vismobile.terrain.roam import Roam

from .test_roam import RESOLUTION, _check_mesh


def test_incremental_frames_stay_within_tau_and_crack_free(fractal257):
    """Along slow and fast circles, every coherent incremental frame is within tau on the
    dense lattice (4x finer than the samples), it draws about what the walking ROAM draws,
    and after each path the whole incremental mesh (cull off) is a crack-free cover."""
    truth = reference(fractal257, 4, alternating=True)
    for speed, every in (("slow", 40), ("fast", 3)):
        lazy = Roam(fractal257, walk_above=np.inf)  # never walks for its speed
        eager = Roam(fractal257, incremental=False)  # the walking ROAM
        whole = Roam(fractal257, walk_above=np.inf)
        for camera in path_cameras(fractal257, "circle", speed, frames=6, every=every):
            a = lazy.update(camera, RESOLUTION, 1.0)
            b = eager.update(camera, RESOLUTION, 1.0)
            errors = screen_errors(fractal257, rasterise(fractal257, a.triangles, 4), truth,
                                   camera, RESOLUTION, 4)
            assert len(errors) > 1000 and errors.max() <= 1.0
            assert a.bound_px <= 1.0
            assert 0.9 * len(b.triangles) <= len(a.triangles) <= 1.3 * len(b.triangles)
            whole_frame = whole.update(camera, RESOLUTION, 1.0, cull=False)
        _check_mesh(whole_frame.triangles, fractal257.size)  # the last frame's whole mesh


def test_a_still_or_slow_camera_rescores_little(fractal257):
    """A camera that does not move re-scores nothing and re-emits no block; at 0.1 units a
    frame the work is a small share of a fresh walk's."""
    roam = Roam(fractal257, walk_above=np.inf)
    camera = path_cameras(fractal257, "circle", "slow", frames=1)[0]
    first = roam.update(camera, RESOLUTION, 1.0)
    again = roam.update(camera, RESOLUTION, 1.0)
    assert again.splits == again.merges == 0 and roam.emitter.rebuilt == 0
    assert np.array_equal(np.sort(np.sort(first.triangles, 1), 0),
                          np.sort(np.sort(again.triangles, 1), 0))
    moved = roam.update(camera.with_(position=np.add(camera.position, (0.1, 0, 0))),
                        RESOLUTION, 1.0)
    assert roam.emitter.rebuilt < 0.2 * roam.emitter.per_side ** 2
    assert moved.bound_px <= 1.0


def test_the_hybrid_walks_fast_frames_and_queues_slow_ones_within_tau(fractal257):
    """walk_above: fast frames walk and emit per triangle, slow ones after them reseed the
    queues; every frame stays within tau on the dense lattice, crack-free at the end."""
    truth = reference(fractal257, 4, alternating=True)
    # 2 units a frame (fast circle: 0.25 a frame here), then 0.3 and 0.025 (slow: 0.025)
    fast = path_cameras(fractal257, "circle", "fast", frames=4, every=8)
    slow = path_cameras(fractal257, "circle", "slow", frames=4, start=252, every=1)
    roam = Roam(fractal257, walk_above=1.0)
    whole = Roam(fractal257, walk_above=1.0)
    for camera in fast + slow:
        frame = roam.update(camera, RESOLUTION, 1.0)
        errors = screen_errors(fractal257, rasterise(fractal257, frame.triangles, 4), truth,
                               camera, RESOLUTION, 4)
        assert errors.max() <= 1.0 and frame.bound_px <= 1.0
        last = whole.update(camera, RESOLUTION, 1.0, cull=False)
    assert roam.fast_frames == 3  # the three fast steps; the slow frames queue
    _check_mesh(last.triangles, fractal257.size)


def _within_tau(hm, frame, camera, truth, tau=1.0):
    errors = screen_errors(hm, rasterise(hm, frame.triangles, 4), truth, camera, RESOLUTION, 4)
    assert len(errors) > 1000 and errors.max() <= tau and frame.bound_px <= tau


def test_turning_in_place_unparks_what_comes_into_view(fractal257):
    """Split candidates that were <= tau only because they were outside the frustum are
    parked (tested against the frustum each frame, not re-scored); a camera that only turns
    (no travel: no wake-up is ever due) brings them into view, and every frame stays within
    tau on the dense lattice, as a fresh refinement of the same view does."""
    truth = reference(fractal257, 4, alternating=True)
    base = path_cameras(fractal257, "circle", "slow", frames=1)[0]
    roam = Roam(fractal257, walk_above=np.inf)
    parked = 0
    for k in range(10):
        camera = base.with_(yaw=base.yaw + 37.0 * k)
        frame = roam.update(camera, RESOLUTION, 1.0)
        parked = max(parked, int(roam.pcount[0]))
        _within_tau(fractal257, frame, camera, truth)
        if k:
            assert frame.splits > 0  # the newly seen ground refined without any wake-up
    assert parked > 100


def test_the_default_walks_when_many_wake_ups_are_due(fractal257):
    """The default ROAM is incremental and walks the frames whose due wake-ups exceed a
    share of the split diamonds (walk_share), and the next ones while the eye stays as fast:
    none on a slow path, some on a fast one, and it stops on a slow one again; every frame
    within tau on the dense lattice, crack-free after the fast path."""
    truth = reference(fractal257, 4, alternating=True)
    slow = path_cameras(fractal257, "circle", "slow", frames=5, every=4)
    fast = path_cameras(fractal257, "circle", "fast", frames=5, start=40, every=24)
    roam, whole = Roam(fractal257), Roam(fractal257)
    assert roam.incremental and roam.walk_above is None
    for camera in slow:
        _within_tau(fractal257, roam.update(camera, RESOLUTION, 1.0), camera, truth)
    assert roam.fast_frames == 0
    for camera in fast:
        _within_tau(fractal257, roam.update(camera, RESOLUTION, 1.0), camera, truth)
        last = whole.update(camera, RESOLUTION, 1.0, cull=False)
    assert roam.fast_frames > 0
    _check_mesh(last.triangles, fractal257.size)
    # back to a slow eye: the walking stops (the queues are reseeded), within tau again
    walked = roam.fast_frames
    for camera in path_cameras(fractal257, "circle", "slow", frames=3, start=900, every=4):
        _within_tau(fractal257, roam.update(camera, RESOLUTION, 1.0), camera, truth)
    assert roam.fast_step is None and roam.fast_frames <= walked + 1

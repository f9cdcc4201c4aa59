"""The horizon casts' bands (terrain/horizon_bands.py): the frustum's slope range per band, the
early stops it allows, and the pieces a cast counts."""
import numpy as np
import pytest

from vismobile.terrain.horizon import Horizon, HorizonCaster
from vismobile.terrain.horizon_bands import (frame_bands, frustum_slopes, level_bands,
                                             no_stops)
from vismobile.terrain.horizon_cells import CellCaster
from vismobile.world.camera import Camera


def sampled_slopes(camera, forward, right, tans, samples=60):
    """Per band, the (max, min) slope over a grid of rays across the view rectangle that lie in
    front of the level eye (-inf, +inf where none)."""
    r, u, f = camera.basis()
    ty = np.tan(np.radians(camera.fov) / 2)
    tx = ty * camera.aspect
    s = np.linspace(-1, 1, samples)
    a, b = np.meshgrid(s, s)
    rays = f + (a * tx)[..., None] * r + (b * ty)[..., None] * u
    depth, lateral, up = rays @ forward, rays @ right, rays[..., 1]
    ok = depth > 1e-6
    t, m = lateral[ok] / depth[ok], up[ok] / depth[ok]
    band = np.searchsorted(tans, t, side="right") - 1
    inside = (band >= 0) & (band < len(tans) - 1)
    high = np.full(len(tans) - 1, -np.inf)
    low = np.full(len(tans) - 1, np.inf)
    np.maximum.at(high, band[inside], m[inside])
    np.minimum.at(low, band[inside], m[inside])
    return high, low


@pytest.mark.parametrize("pitch", [-88.0, -75.0, -40.0, -10.0, 0.0, 20.0, 60.0, 80.0, 89.0])
def test_frustum_slopes_bound_every_ray_of_the_band(pitch):
    for yaw in (0.0, 37.0, 200.0):
        camera = Camera((3.0, 2.0, -4.0), yaw=yaw, pitch=pitch, aspect=0.75, fov=45.0)
        forward, right, tans, _, _ = level_bands(camera, 24)
        highs, lows = frustum_slopes(camera, forward, right, tans)
        both = frame_bands(camera, 24)  # the cast's one call gives the same
        assert np.array_equal(both[2], tans) and np.array_equal(both[5], highs)
        assert np.array_equal(both[6], lows)
        high, low = sampled_slopes(camera, forward, right, tans)
        seen = np.isfinite(high)
        assert np.all(highs[seen] >= high[seen] - 1e-12)
        assert np.all(lows[seen] <= low[seen] + 1e-12)
        if abs(pitch) < 60:  # every corner in front: the bounds are the frustum's, not loose
            assert np.isfinite(highs).any() and np.isfinite(lows).any()
            assert np.all(highs[seen] <= high[seen] + 0.05 * (1 + np.abs(high[seen])))


def test_a_stopped_cast_is_a_lower_bound_of_the_full_one():
    # Columns of random heights; a camera looking down stops most bands early. Stopping only
    # lowers the horizon (hides less) and casts fewer pieces.
    rng = np.random.default_rng(4)
    tops = rng.uniform(0, 6, (64, 64))
    caster = CellCaster(tops, tops, spacing=1.0, bands=32, step=0.02)
    import vismobile.terrain.horizon_cells as cells

    for pitch in (-50.0, 0.0, 50.0):
        camera = Camera((32.0, 7.0, 60.0), yaw=10.0, pitch=pitch, aspect=0.75, fov=45.0)
        stopped = caster.cast(camera)
        original = cells.frame_bands
        cells.frame_bands = lambda cam, bands: original(cam, bands)[:5] + no_stops(bands)
        try:
            full = caster.cast(camera)
        finally:
            cells.frame_bands = original
        assert np.all(stopped.values <= full.values)
        assert 0 <= stopped.pieces <= full.pieces <= full.values.size
        if pitch < 0:  # the ground soon beats the frustum's top in every band
            assert 0 < stopped.pieces < full.pieces / 2
        if pitch > 0:  # every solid below the eye, the frustum all above it: nothing to cast
            assert stopped.pieces == 0 < full.pieces


def test_every_cast_counts_its_pieces(fractal129):
    camera = Camera((60.0, float(fractal129.heights.max()) + 3.0, 60.0), yaw=30.0, pitch=-5.0,
                    aspect=0.75)
    for arithmetic in ("float64", "fixed16.16"):
        horizon = HorizonCaster(fractal129, bands=16, step=0.05, arithmetic=arithmetic).cast(camera)
        assert 0 < horizon.pieces <= horizon.values.size
    assert Horizon.nothing(camera.eye).pieces == 0

"""The rasteriser's step 3 over a row's run (hiz.raster._covered_run, written to vectorise)
decides every pixel as the one-by-one path (_covered_pixel) does, bit for bit: the same depth
bounds, centre marks and count of pixels written for the first time, whatever the marks."""
import numpy as np

from vismobile.culling.hiz.raster import _covered_pixel, _covered_run

W, H = 40, 12


def test_run_equals_pixels():
    rng = np.random.default_rng(7)
    firsts = 0
    for case in range(300):
        rr = int(rng.integers(1, H - 1))
        j0 = int(rng.integers(1, W - 2))
        j1 = int(rng.integers(j0, W - 1))
        mask = rng.choice(np.array([0, 1, 1, 1, 3, 5, 2, 4], dtype=np.uint8), W * H)
        depth = np.where(rng.random(W * H) < 0.5, np.inf, rng.uniform(0.5, 30.0, W * H))
        centre = (rng.random(W * H) < 0.2).astype(np.uint8)
        # planes in front, edge-on and behind over parts of the row (1 / z may cross 0)
        a, b = rng.normal(0, 0.05, 2)
        c0_ = rng.normal(0.1, 0.2)
        low = min(a, 0.0) + min(b, 0.0)
        num = 1.0 + 1e-9
        d1, c1 = depth.copy(), centre.copy()
        got = _covered_run(mask, d1, c1, rr * W, j0, j1, a, b * rr, c0_, low, num)
        d2, c2 = depth.copy(), centre.copy()
        want = sum(_covered_pixel(mask, d2, c2, rr * W + i, a, b, c0_, low, i, rr, W, H, 0.5,
                                  1.0, num) for i in range(j0, j1))
        # _covered_pixel leaves listed pixels (a piece mark) to step 3's list: their centre
        # mark comes from there; the run sets it for every centre mark
        listed = (mask > 1) & (mask & 1 == 1)
        c2[listed] = 1
        c2[: rr * W + j0], c2[rr * W + j1:] = centre[: rr * W + j0], centre[rr * W + j1:]
        assert got == want, case
        assert np.array_equal(d1, d2), case  # bit for bit (inf where untouched)
        assert np.array_equal(c1, c2), case
        firsts += got
    assert firsts > 200  # the cases wrote many pixels for the first time

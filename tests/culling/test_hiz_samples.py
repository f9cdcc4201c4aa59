"""The tiled depth buffer's samples (culling/hiz/, occlusion `samples` and `screen`): with
`samples` a covered pixel bounds the occluders over the SAMPLE_HALF square about its centre only,
keeping test_hiz's covered-pixel contract over that square; covers_no_sample flags a triangle only
when it holds no pixel centre of the screen."""
import numpy as np

from vismobile.culling.hiz import SAMPLE_HALF, covers_no_sample

from .test_hiz import (TX, TY, H, W, camera_triangle, check_contract, pixel_centres, quad_at,
                       random_occluders, raster)


def test_sample_squares_keep_the_contract():
    # occlusion `samples`: each pixel bounds only the SAMPLE_HALF square about its centre; the
    # contract holds over that square on test_hiz's scenes (T-junctions, creases, slants, the
    # clip, random occluders): it fails when a boundary is marked against a smaller square or
    # the depth is taken at the centre only.
    frame = [quad_at(4.0, -1, 1, -1, -0.3), quad_at(4.0, -1, 1, 0.3, 1),
             quad_at(4.0, -1, -0.3, -0.3, 0.3), quad_at(4.0, 0.3, 1, -0.3, 0.3)]
    wall = np.array([[[-9.0, -1, 6], [9, 9, 6], [9, -1, 6]],
                     [[-9.0, -1, 6], [-9, 9, 6], [9, 9, 6]]])
    floor = np.array([[[-9.0, -1, 0.5], [-9, -1, 6], [0, -1, 6]],
                      [[-9.0, -1, 0.5], [0, -1, 6], [9, -1, 6]],
                      [[-9.0, -1, 0.5], [9, -1, 6], [9, -1, 0.5]]])
    slant = np.array([[[-3.0, -4, 2], [1.2, 4, 6], [1.2, -4, 6]],
                      [[-3.0, -4, 2], [-3.0, 4, 2], [1.2, 4, 6]]])
    depth = check_contract(np.concatenate(frame), half=SAMPLE_HALF)
    on_t_line = np.broadcast_to((np.abs(np.abs(pixel_centres()[1]) - 0.3) < 0.5 / H)[:, None],
                                (H, W))
    assert not np.isfinite(depth[on_t_line]).any()  # T-junction lines stay open
    check_contract(np.concatenate([wall, floor]), half=SAMPLE_HALF)
    check_contract(np.concatenate([slant, quad_at(5.0, -0.6, 0.9, -0.8, 0.7)]), half=SAMPLE_HALF)
    floor_cut = np.array([[[-2.0, -1, 0.2], [2.0, -1, 4.0], [2.0, -1, 0.2]],
                          [[-2.0, -1, 0.2], [-2.0, -1, 4.0], [2.0, -1, 4.0]]])
    check_contract(floor_cut, clip=2.0, half=SAMPLE_HALF)
    rng = np.random.default_rng(12)
    for _ in range(6):
        check_contract(random_occluders(rng), clip=0.3, samples=5, half=SAMPLE_HALF)


def test_sample_coverage_is_the_centres_neighbourhood():
    # A quad with edges 0.2 px into pixels covers exactly the pixels whose sample squares lie
    # inside it: a ring more than the whole pixels inside it.
    u0, u1, v0, v1 = 6.2 / 12 - 1, 18.8 / 12 - 1, 8.2 / 16 - 1, 24.8 / 16 - 1
    depth = check_contract(quad_at(2.0, u0, u1, v0, v1), half=SAMPLE_HALF)
    us, vs = pixel_centres()
    hu, hv = 2 * SAMPLE_HALF / W, 2 * SAMPLE_HALF / H
    inside = ((us[None, :] - hu >= u0) & (us[None, :] + hu <= u1)
              & (vs[:, None] - hv >= v0) & (vs[:, None] + hv <= v1))
    assert np.array_equal(np.isfinite(depth), inside)
    whole = np.isfinite(raster(quad_at(2.0, u0, u1, v0, v1))[0])
    assert inside.sum() > whole.sum() and not (whole & ~inside).any()


# ---- the sample test (`screen` option): no pixel centre covered ------------------------------

def test_a_triangle_between_pixel_centres_covers_no_sample():
    tri = camera_triangle([[3.6, 4.6], [4.4, 4.6], [4.0, 5.4]], 3.0, W, H)  # inside pixel (4, 4)'s
    assert covers_no_sample(tri[None], 0.1, TX, TY, W, H)[0]                # corner-free middle
    around = camera_triangle([[3.9, 4.4], [5.2, 4.4], [4.5, 5.6]], 3.0, W, H)  # holds (4.5, 4.5)
    assert not covers_no_sample(around[None], 0.1, TX, TY, W, H)[0]


def test_a_thin_sliver_passing_a_centre_closely_is_kept():
    tri = camera_triangle([[2.0, 4.5 + 1e-4], [9.0, 4.5 + 1e-4], [9.0, 4.6]], 3.0, W, H)
    assert not covers_no_sample(tri[None], 0.1, TX, TY, W, H)[0]  # 1e-4 px above the centres
    far_off = camera_triangle([[2.0, 4.6], [9.0, 4.6], [9.0, 4.9]], 3.0, W, H)
    assert covers_no_sample(far_off[None], 0.1, TX, TY, W, H)[0]


def test_sample_test_keeps_triangles_near_or_behind_the_near_plane_and_large_ones():
    tri = camera_triangle([[3.6, 4.6], [4.4, 4.6], [4.0, 5.4]], 3.0, W, H)
    behind = tri.copy()
    behind[0, 2] = 0.05
    big = camera_triangle([[0.2, 0.2], [20.0, 0.3], [10.0, 30.0]], 3.0, W, H)
    assert not covers_no_sample(np.stack([behind, big]), 0.1, TX, TY, W, H, max_samples=8).any()
    assert covers_no_sample(np.zeros((0, 3, 3)), 0.1, TX, TY, W, H).shape == (0,)


def test_sample_test_never_flags_a_triangle_holding_a_centre():
    # Random small triangles; exact rational check of every on-screen centre near each flagged
    # one (centres off the screen are never sampled).
    from fractions import Fraction

    rng = np.random.default_rng(7)
    base = rng.uniform(0, [W, H], (600, 1, 2))
    px = base + rng.normal(scale=rng.uniform(0.05, 1.5, (600, 1, 1)), size=(600, 3, 2))
    tris = np.stack([camera_triangle(p, z, W, H) for p, z in zip(px, rng.uniform(0.5, 20, 600))])
    flagged = covers_no_sample(tris, 0.1, TX, TY, W, H, move=0.0)
    assert 50 < flagged.sum() < 550  # both verdicts occur
    for t in tris[flagged]:
        x = (t[:, 0] / (t[:, 2] * TX) + 1) * 0.5 * W
        y = (t[:, 1] / (t[:, 2] * TY) + 1) * 0.5 * H
        q = [(Fraction(float(a)), Fraction(float(b))) for a, b in zip(x, y)]
        for i in range(max(int(np.floor(x.min())) - 1, 0), min(int(np.ceil(x.max())) + 1, W)):
            for j in range(max(int(np.floor(y.min())) - 1, 0), min(int(np.ceil(y.max())) + 1, H)):
                s = (Fraction(2 * i + 1, 2), Fraction(2 * j + 1, 2))
                e = [(q[(k + 1) % 3][0] - q[k][0]) * (s[1] - q[k][1])
                     - (q[(k + 1) % 3][1] - q[k][1]) * (s[0] - q[k][0]) for k in range(3)]
                assert not (all(v >= 0 for v in e) or all(v <= 0 for v in e)), (t, i, j)

"""Conservative depth buffer: near clipping, fused coverage (shrunk, never grown), far depths,
pyramid rectangle queries."""
import numpy as np

from vismobile.geometry.raster import (clip_near, fused_occluder_depth, occluder_depth, pyramid,
                                       rect_query)

W, H, TX, TY = 24, 32, 0.4, 0.5


def quad_at(z, u0, u1, v0, v1):
    """Two camera-space triangles (shared diagonal) covering NDC [u0,u1] x [v0,v1] at depth z."""
    c = np.array([[u0 * z * TX, v0 * z * TY, z], [u1 * z * TX, v0 * z * TY, z],
                  [u1 * z * TX, v1 * z * TY, z], [u0 * z * TX, v1 * z * TY, z]])
    return np.stack([c[[0, 1, 2]], c[[0, 2, 3]]])


def test_clip_near_keeps_only_the_part_in_front_and_empty_input():
    tri = np.array([[[0.0, 0, -1], [1, 0, 3], [0, 1, 3]]])
    pieces, source = clip_near(tri, 1.0, with_source=True)
    assert len(pieces) == 2 and np.all(pieces[..., 2] >= 1.0 - 1e-12) and set(source) == {0}
    assert len(clip_near(np.zeros((0, 3, 3)), 1.0)) == 0
    assert len(clip_near(tri - [0.0, 0.0, 5.0], 1.0)) == 0  # wholly behind


def test_fused_quad_has_no_crack_along_its_diagonal_unlike_single_triangles():
    tris = quad_at(5.0, -1.0, 1.0, -1.0, 1.0)
    fused = fused_occluder_depth(tris, np.zeros(2, int), W, H, TX, TY)
    single = occluder_depth(tris, W, H, TX, TY)
    inner = (slice(1, -1), slice(1, -1))  # the outer ring touches the quad's own edges
    assert np.isfinite(fused[inner]).all()
    assert not np.isfinite(single[inner]).all()  # the diagonal's pixels
    assert np.allclose(fused[inner], 5.0, rtol=1e-6) and np.all(fused[inner] >= 5.0)


def test_coverage_is_shrunk_to_whole_pixels():
    tris = quad_at(2.0, -0.47, 0.53, -0.47, 0.53)  # edges off the pixel grid
    depth = fused_occluder_depth(tris, np.zeros(2, int), W, H, TX, TY)
    us = -1 + 2 * (np.arange(W) + 0.5) / W
    vs = -1 + 2 * (np.arange(H) + 0.5) / H
    half_u, half_v = 1.0 / W, 1.0 / H
    inside = ((us[None, :] - half_u >= -0.47) & (us[None, :] + half_u <= 0.53)
              & (vs[:, None] - half_v >= -0.47) & (vs[:, None] + half_v <= 0.53))
    assert np.array_equal(np.isfinite(depth), inside)


def test_sloped_occluder_writes_the_farthest_depth_over_each_pixel():
    c = np.array([[-3.0, -3.0, 2.0], [3.0, -3.0, 8.0], [0.0, 4.0, 5.0]])
    depth = fused_occluder_depth(c[None], np.zeros(1, int), W, H, TX, TY)
    rng = np.random.default_rng(1)
    n = np.cross(c[1] - c[0], c[2] - c[0])
    j, i = np.nonzero(np.isfinite(depth))
    for _ in range(200):  # random points inside covered pixels lie on the triangle, nearer
        k = rng.integers(len(i))
        u = -1 + 2 * (i[k] + rng.random()) / W
        v = -1 + 2 * (j[k] + rng.random()) / H
        ray = np.array([u * TX, v * TY, 1.0])
        z = (n @ c[0]) / (n @ ray)
        assert z <= depth[j[k], i[k]]


def test_group_with_a_hole_leaves_the_hole_uncovered():
    outer = quad_at(4.0, -1.0, 1.0, -1.0, 1.0)
    # A frame around a hole: 4 quads; the hole [-0.3, 0.3]^2 must stay uncovered.
    parts = [quad_at(4.0, -1, 1, -1, -0.3), quad_at(4.0, -1, 1, 0.3, 1),
             quad_at(4.0, -1, -0.3, -0.3, 0.3), quad_at(4.0, 0.3, 1, -0.3, 0.3)]
    tris = np.concatenate(parts)
    depth = fused_occluder_depth(tris, np.zeros(len(tris), int), W, H, TX, TY)
    us = -1 + 2 * (np.arange(W) + 0.5) / W
    vs = -1 + 2 * (np.arange(H) + 0.5) / H
    hole = (np.abs(us)[None, :] - 1.0 / W < 0.3) & (np.abs(vs)[:, None] - 1.0 / H < 0.3)
    assert not np.isfinite(depth[hole]).any()
    whole = fused_occluder_depth(outer, np.zeros(2, int), W, H, TX, TY)
    assert np.isfinite(whole[1:-1, 1:-1]).all()


def test_rect_query_bounds_the_true_rectangle_max_and_min():
    rng = np.random.default_rng(2)
    buf = rng.uniform(1, 10, (H, W))
    buf[rng.random((H, W)) < 0.1] = np.inf
    far, near = pyramid(buf, np.maximum), pyramid(buf, np.minimum)
    for _ in range(300):
        x0, y0 = rng.integers(W), rng.integers(H)
        x1, y1 = rng.integers(x0, W), rng.integers(y0, H)
        block = buf[y0:y1 + 1, x0:x1 + 1]
        args = [np.array([v]) for v in (x0, x1, y0, y1)]
        assert rect_query(far, *args, np.max)[0] >= block.max()
        assert rect_query(near, *args, np.min)[0] <= block.min()

"""Conservative union depth buffer: edges split at T-junctions, union coverage (shrunk, never
grown) without cracks at shared edges, T-junctions or creases, far depths, near clipping, exact
sparse-table rectangle maxima, the rectangle-to-pixel scatter, and the pixel-centre sample test."""
import numpy as np

from vismobile.geometry.raster import (SLACK_PX, _rect_pixel_pairs, covers_no_sample, max_table,
                                      rect_max, split_edges, union_depth)

W, H, TX, TY = 24, 32, 0.4, 0.5


def quad_at(z, u0, u1, v0, v1):
    """Two camera-space triangles (shared diagonal) covering NDC [u0,u1] x [v0,v1] at depth z,
    wound counter-clockwise as seen from the eye at the origin (facing it)."""
    c = np.array([[u0 * z * TX, v0 * z * TY, z], [u1 * z * TX, v0 * z * TY, z],
                  [u1 * z * TX, v1 * z * TY, z], [u0 * z * TX, v1 * z * TY, z]])
    return np.stack([c[[0, 2, 1]], c[[0, 3, 2]]])


def depth_of(tris, near=0.1, groups=None):
    """union_depth of camera-space triangles, grouped by exact plane unless groups given."""
    tris = np.asarray(tris, dtype=float)
    pts, idx = np.unique(tris.reshape(-1, 3), axis=0, return_inverse=True)
    idx = idx.reshape(-1, 3)
    n = np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0])
    n /= np.linalg.norm(n, axis=1)[:, None]
    d = np.einsum("ij,ij->i", n, tris[:, 0])
    assert np.all(d < 0), "test triangles must face the eye (counter-clockwise seen from it)"
    n, d = -n, -d  # union_depth wants n away from the eye
    if groups is None:
        _, groups = np.unique(np.column_stack([n, d]), axis=0, return_inverse=True)
    return union_depth(pts, idx, split_edges(pts, idx), np.ravel(groups),
                       np.column_stack([n, d]), near, TX, TY, W, H)


def pixel_centres():
    us = -1 + 2 * (np.arange(W) + 0.5) / W
    vs = -1 + 2 * (np.arange(H) + 0.5) / H
    return us, vs


def test_split_edges_splits_at_t_junctions_and_keeps_winding():
    pts = np.array([[0.0, 0, 0], [2, 0, 0], [2, 2, 0], [1, 0, 0], [1, -1, 0]])
    tri = np.array([[0, 1, 2], [0, 4, 3]])  # corner 3 lies on the first triangle's edge 0 -> 1
    owner, a, b = split_edges(pts, tri)
    first = [(int(x), int(y)) for t, x, y in zip(owner, a, b) if t == 0]
    assert first == [(0, 3), (3, 1), (1, 2), (2, 0)]
    assert [(int(x), int(y)) for t, x, y in zip(owner, a, b) if t == 1] == [(0, 4), (4, 3), (3, 0)]


def test_quad_has_no_crack_along_its_diagonal():
    depth = depth_of(quad_at(5.0, -1.0, 1.0, -1.0, 1.0))
    inner = (slice(1, -1), slice(1, -1))  # the outer ring touches the quad's own edges
    assert np.isfinite(depth[inner]).all()
    assert np.allclose(depth[inner], 5.0, rtol=1e-6) and np.all(depth[inner] >= 5.0)


def test_coverage_is_shrunk_to_whole_pixels():
    depth = depth_of(quad_at(2.0, -0.47, 0.53, -0.47, 0.53))  # edges off the pixel grid
    us, vs = pixel_centres()
    half_u, half_v = 1.0 / W, 1.0 / H
    inside = ((us[None, :] - half_u >= -0.47) & (us[None, :] + half_u <= 0.53)
              & (vs[:, None] - half_v >= -0.47) & (vs[:, None] + half_v <= 0.53))
    assert np.array_equal(np.isfinite(depth), inside)


def test_t_junctions_and_a_hole_fuse_without_cracks_and_leave_the_hole_open():
    # A frame around a hole: 4 quads whose corners make T-junctions on their neighbours' edges.
    parts = [quad_at(4.0, -1, 1, -1, -0.3), quad_at(4.0, -1, 1, 0.3, 1),
             quad_at(4.0, -1, -0.3, -0.3, 0.3), quad_at(4.0, 0.3, 1, -0.3, 0.3)]
    depth = depth_of(np.concatenate(parts))
    us, vs = pixel_centres()
    near_hole = (np.abs(us)[None, :] - 1.0 / W < 0.3) & (np.abs(vs)[:, None] - 1.0 / H < 0.3)
    assert not np.isfinite(depth[near_hole]).any()
    ring = np.zeros((H, W), bool)
    ring[1:-1, 1:-1] = True
    hole_ring = (np.abs(us)[None, :] - 3.0 / W < 0.3) & (np.abs(vs)[:, None] - 3.0 / H < 0.3)
    assert np.isfinite(depth[ring & ~hole_ring]).all()  # no crack along the T-junctions


def test_crease_between_two_planes_is_covered_with_a_safe_depth():
    # A floor (y = -1) meeting a wall (z = 6) at a crease, seen from above the floor.
    wall = np.array([[[-9.0, -1, 6], [9, 9, 6], [9, -1, 6]], [[-9.0, -1, 6], [-9, 9, 6], [9, 9, 6]]])
    floor = np.array([[[-9.0, -1, 0.5], [-9, -1, 6], [9, -1, 6]],
                      [[-9.0, -1, 0.5], [9, -1, 6], [9, -1, 0.5]]])
    depth = depth_of(np.concatenate([wall, floor]))
    assert np.isfinite(depth).all()  # the whole screen, crease included
    crease = int(np.floor((-1 / (6 * TY) + 1) * H / 2))
    assert np.all(depth[crease] >= 6.0)
    alone = depth_of(np.concatenate([wall, floor]), groups=np.arange(4))  # no plane groups
    assert np.array_equal(np.isfinite(alone), np.isfinite(depth)) and np.all(alone >= depth)
    wall_only = depth_of(wall)
    assert not np.isfinite(wall_only[crease]).all()


def test_depth_bounds_the_occluders_everywhere_in_covered_pixels():
    c = np.array([[-3.0, -3.0, 2.0], [0.0, 4.0, 5.0], [3.0, -3.0, 8.0]])
    fold = np.array([[3.0, -3.0, 8.0], [0.0, 4.0, 5.0], [6.0, 3.0, 6.0]])
    tris = np.stack([c, fold])
    depth = depth_of(tris)
    rng = np.random.default_rng(1)
    j, i = np.nonzero(np.isfinite(depth))
    assert len(i)
    for _ in range(400):  # random rays through covered pixels meet an occluder, nearer
        k = rng.integers(len(i))
        u = -1 + 2 * (i[k] + rng.random()) / W
        v = -1 + 2 * (j[k] + rng.random()) / H
        ray = np.array([u * TX, v * TY, 1.0])
        hits = []
        for t in tris:
            n = np.cross(t[1] - t[0], t[2] - t[0])
            z = (n @ t[0]) / (n @ ray)
            p = z * ray
            bary = [np.cross(t[(m + 1) % 3] - t[m], p - t[m]) @ n for m in range(3)]
            if min(bary) >= -1e-9:
                hits.append(z)
        assert hits and min(hits) <= depth[j[k], i[k]]


def test_near_clipping_keeps_only_the_part_in_front():
    # A floor running from behind the eye to depth 10; only its part beyond near is covered.
    floor = np.array([[[-9.0, -1, -5], [-9, -1, 10], [9, -1, 10]],
                      [[-9.0, -1, -5], [9, -1, 10], [9, -1, -5]]])
    depth = depth_of(floor, near=0.5)
    _, vs = pixel_centres()
    below = vs < -1 / (10 * TY) - 2.0 / H
    assert np.isfinite(depth[below][:, 1:-1]).all()
    assert not np.isfinite(depth[~below]).any()
    assert np.all((depth[below] >= 0.5) & (depth[below] <= 10.0 * (1 + 1e-6)))


def test_rect_max_is_the_exact_rectangle_maximum():
    rng = np.random.default_rng(2)
    buf = rng.uniform(1, 10, (H, W))
    buf[rng.random((H, W)) < 0.1] = np.inf
    table = max_table(buf)
    x0, y0 = rng.integers(W, size=300), rng.integers(H, size=300)
    x1, y1 = rng.integers(x0, W), rng.integers(y0, H)
    got = rect_max(table, x0, x1, y0, y1)
    want = [buf[b:d + 1, a:c + 1].max() for a, b, c, d in zip(x0, y0, x1, y1)]
    assert np.array_equal(got, want)


def camera_triangle(px_points, z, width, height, tx=TX, ty=TY):
    """(3, 3) camera-space triangle at depth z whose window coordinates are px_points (3, 2)."""
    p = np.asarray(px_points, dtype=float)
    u = p[:, 0] / (0.5 * width) - 1.0
    v = p[:, 1] / (0.5 * height) - 1.0
    return np.column_stack([u * tx * z, v * ty * z, np.full(3, z)])


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


def test_rect_pixel_pairs_match_the_dense_rectangle_test():
    rng = np.random.default_rng(8)
    corner_px = np.concatenate([rng.uniform(-5, [W + 5, H + 5], (90, 2)),
                                rng.uniform(-50, 80, (30, 2))])  # some large rectangles
    owner = np.repeat(np.arange(40), 3)
    pixels = np.unique(rng.integers(0, W * H, 300))
    r, q = _rect_pixel_pairs(corner_px, owner, 41, pixels, W, H)  # triangle 40 has no points
    got = set(zip(r.tolist(), q.tolist()))
    x0 = np.array([corner_px[owner == k, 0].min() for k in range(40)])
    x1 = np.array([corner_px[owner == k, 0].max() for k in range(40)])
    y0 = np.array([corner_px[owner == k, 1].min() for k in range(40)])
    y1 = np.array([corner_px[owner == k, 1].max() for k in range(40)])
    cx, cy = pixels % W, pixels // W
    meets = ((x0[None] <= cx[:, None] + 1 + SLACK_PX) & (x1[None] >= cx[:, None] - SLACK_PX)
             & (y0[None] <= cy[:, None] + 1 + SLACK_PX) & (y1[None] >= cy[:, None] - SLACK_PX))
    assert got == set(zip(*[a.tolist() for a in np.nonzero(meets)]))
    assert len(got) > 100

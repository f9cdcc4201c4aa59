"""The tiled depth buffer's rasteriser contract (culling/hiz/): a covered pixel (and so a
covered tile) never holds a depth nearer than the nearest occluder anywhere over it, coverage is
shrunk to whole pixels, quads and T-junctions fuse without cracks, holes stay open, and the part
of an occluder nearer than the clip depth covers nothing."""
import numpy as np
import pytest

from vismobile.culling.hiz import build_tiles, rasterise, screen_rect
from vismobile.culling.occluder_mesh import occluder_mesh

W, H, TX, TY = 24, 32, 0.4, 0.5
TILE = (8, 4)


def quad_at(z, u0, u1, v0, v1):
    """Two camera-space triangles (shared diagonal) covering NDC [u0,u1] x [v0,v1] at depth z,
    wound counter-clockwise as seen from the eye at the origin (facing it)."""
    c = np.array([[u0 * z * TX, v0 * z * TY, z], [u1 * z * TX, v0 * z * TY, z],
                  [u1 * z * TX, v1 * z * TY, z], [u0 * z * TX, v1 * z * TY, z]])
    return np.stack([c[[0, 2, 1]], c[[0, 3, 2]]])


def raster(tris, clip=0.1, half=0.5):
    """(H, W) depth bound buffer, tile maxima (rows, cols) and tile coverage of camera-space
    triangles (K, 3, 3) facing the eye at the origin (rotation: identity, forward +z); half:
    the pixels' squares' half-size (0.5 whole pixels, SAMPLE_HALF the samples')."""
    tris = np.asarray(tris, dtype=float).reshape(-1, 3, 3)
    n = np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0])
    n /= np.linalg.norm(n, axis=1)[:, None]
    assert np.all(np.einsum("ij,ij->i", n, -tris[:, 0]) > 0), "triangles must face the eye"
    mesh = occluder_mesh(tris.reshape(-1, 3), np.arange(3 * len(tris)).reshape(-1, 3), n)
    points, tri_points, normals, offsets, groups, start, end, a, b, partner, anyp = mesh
    ids = np.argsort(groups, kind="stable").astype(np.int64)
    depth = np.full(W * H, np.inf)
    mask, centre = np.zeros(W * H, dtype=np.uint8), np.zeros(W * H, dtype=np.uint8)
    crease = np.zeros(W * H)
    stamp = np.full(len(tris), -1, dtype=np.int64)
    rasterise(ids, groups, tri_points, points, normals, offsets, start, end, a, b, partner,
              anyp, stamp, 1, np.zeros(3), np.eye(3), clip, TX, TY, W, H, depth, mask, centre,
              crease, 1e-9, half)
    assert not mask.any() and not centre.any() and not crease.any()  # scratch handed back
    rows, cols = (H + TILE[1] - 1) // TILE[1], (W + TILE[0] - 1) // TILE[0]
    tmax, tany = np.empty(rows * cols), np.empty(rows * cols, dtype=bool)
    tmin = np.empty(rows * cols)
    build_tiles(depth, W, H, *TILE, tmax, tany, tmin)
    assert np.array_equal(tmin, depth.reshape(rows, TILE[1], cols, TILE[0]).min(axis=(1, 3)).ravel())
    return depth.reshape(H, W), tmax.reshape(rows, cols), tany.reshape(rows, cols)


def pixel_centres():
    us = -1 + 2 * (np.arange(W) + 0.5) / W
    vs = -1 + 2 * (np.arange(H) + 0.5) / H
    return us, vs


def nearest_hit(tris, u, v, clip):
    """(n,) depth of the nearest triangle part at depth >= clip on each ray (u TX, v TY, 1)."""
    d = np.stack([u * TX, v * TY, np.ones_like(u)], axis=1)
    best = np.full(len(u), np.inf)
    for p0, p1, p2 in tris:
        e1, e2 = p1 - p0, p2 - p0
        h = np.cross(d, e2)
        det = h @ e1
        with np.errstate(divide="ignore", invalid="ignore"):
            f = 1.0 / det
            s = -p0
            a = f * (h @ s)
            q = np.cross(s, e1)
            b = f * (d @ q)
            t = f * (q @ e2)
            eps = 1e-9  # closed triangles: points on a shared edge hit both
            hit = (a >= -eps) & (b >= -eps) & (a + b <= 1 + eps) & (t >= clip)
        best = np.where(hit, np.minimum(best, t), best)
    return best


def check_contract(tris, clip=0.1, samples=7, half=0.5):
    """Every covered pixel: every sample point over its square of half-size `half` about its
    centre (corners and inside) hits an occluder at depth >= clip no farther than the pixel's
    bound; every tile bounds its pixels."""
    depth, tmax, tany = raster(tris, clip, half)
    rows, cols = np.nonzero(np.isfinite(depth))
    s = np.linspace(0.5 - half, 0.5 + half, samples)
    su, sv = np.meshgrid(s, s)
    for j, i in zip(rows, cols):
        u = -1 + 2 * (i + su.ravel()) / W
        v = -1 + 2 * (j + sv.ravel()) / H
        hits = nearest_hit(tris, u, v, clip)
        assert np.all(hits <= depth[j, i]), (j, i, hits.max(), depth[j, i])
    for ty in range(tmax.shape[0]):
        for tx in range(tmax.shape[1]):
            block = depth[ty * TILE[1]:(ty + 1) * TILE[1], tx * TILE[0]:(tx + 1) * TILE[0]]
            assert tmax[ty, tx] == block.max()
            assert tany[ty, tx] == np.isfinite(block).any()
    return depth


def test_quad_has_no_crack_along_its_diagonal():
    depth = check_contract(quad_at(5.0, -1.0, 1.0, -1.0, 1.0))
    inner = (slice(1, -1), slice(1, -1))  # the outer ring touches the quad's own edges
    assert np.isfinite(depth[inner]).all()
    assert np.allclose(depth[inner], 5.0, rtol=1e-6) and np.all(depth[inner] >= 5.0)


def test_coverage_is_shrunk_to_whole_pixels():
    depth = check_contract(quad_at(2.0, -0.47, 0.53, -0.47, 0.53))  # edges off the pixel grid
    us, vs = pixel_centres()
    half_u, half_v = 1.0 / W, 1.0 / H
    inside = ((us[None, :] - half_u >= -0.47) & (us[None, :] + half_u <= 0.53)
              & (vs[:, None] - half_v >= -0.47) & (vs[:, None] + half_v <= 0.53))
    assert np.array_equal(np.isfinite(depth), inside)


def test_t_junctions_stay_open_and_so_does_the_hole():
    # A frame around a hole: 4 quads whose corners make T-junctions on their neighbours' edges.
    # The GPU may leave a pixel open along a T-junction, so its line is never covered; shared
    # edges (each quad's diagonal) are.
    parts = [quad_at(4.0, -1, 1, -1, -0.3), quad_at(4.0, -1, 1, 0.3, 1),
             quad_at(4.0, -1, -0.3, -0.3, 0.3), quad_at(4.0, 0.3, 1, -0.3, 0.3)]
    depth = check_contract(np.concatenate(parts))
    us, vs = pixel_centres()
    near_hole = (np.abs(us)[None, :] - 1.0 / W < 0.3) & (np.abs(vs)[:, None] - 1.0 / H < 0.3)
    assert not np.isfinite(depth[near_hole]).any()
    on_t_line = np.broadcast_to((np.abs(np.abs(vs) - 0.3) < 1.0 / H)[:, None], (H, W))
    assert not np.isfinite(depth[on_t_line]).any()
    bottom = np.zeros((H, W), bool)
    bottom[1:int(0.35 * H / 2) - 1, 1:-1] = True  # the bottom quad, one pixel in from its edges
    assert np.isfinite(depth[bottom]).all()  # no crack along its diagonal


def test_crease_between_two_planes_is_covered_with_a_safe_depth():
    # A floor (y = -1) meeting a wall (z = 6) at a crease, seen from above the floor: the crease
    # row is covered by the two groups together, with the farther plane's depth.
    wall = np.array([[[-9.0, -1, 6], [9, 9, 6], [9, -1, 6]], [[-9.0, -1, 6], [-9, 9, 6], [9, 9, 6]]])
    floor = np.array([[[-9.0, -1, 0.5], [-9, -1, 6], [9, -1, 6]],
                      [[-9.0, -1, 0.5], [9, -1, 6], [9, -1, 0.5]]])
    depth = check_contract(np.concatenate([wall, floor]))
    assert np.isfinite(depth).all()  # the whole screen, crease included
    crease = int(np.floor((-1 / (6 * TY) + 1) * H / 2))
    assert np.all(depth[crease] >= 6.0)
    wall_only = check_contract(wall)
    assert not np.isfinite(wall_only[crease]).all()


def test_a_crease_with_a_gap_beside_it_stays_open():
    # The wall is two quads meeting at x = 0; the floor meets only the left one, along its whole
    # edge: the crease is covered there, and open where no floor lies in front of the wall.
    left = np.array([[[-9.0, -1, 6], [0, 9, 6], [0, -1, 6]], [[-9.0, -1, 6], [-9, 9, 6], [0, 9, 6]]])
    right = left + np.array([9.0, 0, 0])
    floor = np.array([[[-9.0, -1, 0.5], [-9, -1, 6], [0, -1, 6]],
                      [[-9.0, -1, 0.5], [0, -1, 6], [0, -1, 0.5]]])
    depth = check_contract(np.concatenate([left, right, floor]))
    crease = int(np.floor((-1 / (6 * TY) + 1) * H / 2))
    assert np.isfinite(depth[crease, :W // 2 - 2]).all()
    assert not np.isfinite(depth[crease, W // 2 + 2:]).any()


def test_a_t_junction_on_a_crease_stays_open():
    # Frame 692 of W2's indoor path: a wall corner lying on the ceiling's edge (a T-junction on
    # the crease); the GPU showed a far wall through one pixel there. The crease stays open.
    wall = np.array([[[-9.0, -1, 6], [9, 9, 6], [9, -1, 6]], [[-9.0, -1, 6], [-9, 9, 6], [9, 9, 6]]])
    floor = np.array([[[-9.0, -1, 0.5], [-9, -1, 6], [0, -1, 6]],
                      [[-9.0, -1, 0.5], [0, -1, 6], [9, -1, 6]],
                      [[-9.0, -1, 0.5], [9, -1, 6], [9, -1, 0.5]]])
    depth = check_contract(np.concatenate([wall, floor]))
    crease = int(np.floor((-1 / (6 * TY) + 1) * H / 2))
    assert not np.isfinite(depth[crease]).any()
    assert np.isfinite(depth[crease + 3, 1:-1]).all() and np.isfinite(depth[crease - 3, 1:-1]).all()


def test_tilted_and_overlapping_occluders_bound_the_nearest_surface():
    # A slanted wall (depth 2..6 across the screen) partly in front of a far quad, and a quad
    # behind both: every covered pixel's bound is at least the nearest surface over the pixel.
    slant = np.array([[[-3.0, -4, 2], [1.2, 4, 6], [1.2, -4, 6]],
                      [[-3.0, -4, 2], [-3.0, 4, 2], [1.2, 4, 6]]])
    depth = check_contract(np.concatenate([slant, quad_at(5.0, -0.6, 0.9, -0.8, 0.7),
                                           quad_at(9.0, -1, 1, -1, 1)]))
    assert np.isfinite(depth).mean() > 0.8
    assert depth[np.isfinite(depth)].min() >= 2.0


@pytest.mark.parametrize("clip", [0.5, 2.0, 3.9])
def test_occluders_cut_by_the_clip_depth_cover_only_their_part_beyond_it(clip):
    # A floor-like quad running from depth 0.2 to 4 under the eye, and a wall crossing the
    # clip depth: pixels are covered only by the parts at depth >= clip.
    floor = np.array([[[-2.0, -1, 0.2], [2.0, -1, 4.0], [2.0, -1, 0.2]],
                      [[-2.0, -1, 0.2], [-2.0, -1, 4.0], [2.0, -1, 4.0]]])
    wall = np.array([[[-1.0, -2, 0.3], [1.0, 2, 4.0], [1.0, -2, 4.0]]])
    tris = np.concatenate([floor, wall])
    depth = check_contract(tris, clip=clip)
    assert np.all(depth[np.isfinite(depth)] >= clip)


def random_occluders(rng, count=8) -> np.ndarray:
    """(<= count, 3, 3) random eye-space triangles in view, facing the eye, none edge-on."""
    tris = []
    for _ in range(count):
        z = rng.uniform(0.05, 6.0, 3)
        uv = rng.uniform(-1.5, 1.5, (3, 2))
        t = np.column_stack([uv[:, 0] * z * TX, uv[:, 1] * z * TY, z])
        n = np.cross(t[1] - t[0], t[2] - t[0])
        if abs(n @ -t[0]) < 1e-3:
            continue
        tris.append(t if n @ -t[0] > 0 else t[[0, 2, 1]])
    return np.array(tris)


def test_random_occluders_keep_the_contract():
    rng = np.random.default_rng(11)
    for _ in range(6):
        check_contract(random_occluders(rng), clip=0.3, samples=5)


# ---- the screen's pixel centres ----------------------------------------------------------

def camera_triangle(px_points, z, width, height, tx=TX, ty=TY):
    """(3, 3) camera-space triangle at depth z whose window coordinates are px_points (3, 2)."""
    p = np.asarray(px_points, dtype=float)
    u = p[:, 0] / (0.5 * width) - 1.0
    v = p[:, 1] / (0.5 * height) - 1.0
    return np.column_stack([u * tx * z, v * ty * z, np.full(3, z)])


def test_candidates_are_taken_once_skips_left_out_and_the_bitmap_handed_back(w1_octree):
    from vismobile.culling.hiz import gather_candidates
    from vismobile.culling.tree import Tree

    tree = Tree(w1_octree)
    n, k = tree.node_count, 3
    rng = np.random.default_rng(8)
    lists = rng.integers(-1, 40, (n, k)).astype(np.int64)  # repeats across nodes on purpose
    history = np.array([5, 7, 5, 60], dtype=np.int64)
    bits = np.zeros(tree.world.triangle_count // 64 + 1, dtype=np.uint64)
    out, stack = np.empty(lists.size + len(history), np.int64), np.empty(n + 8, np.int64)
    planes = np.zeros((1, 4))
    planes[0, 3] = 1.0  # every box inside
    eye = tree.lo[0] - 1.0

    def gather(skip):
        count, visited = gather_candidates(tree.lo, tree.hi, tree.first_child, tree.child_count,
                                           tree.nonempty, np.zeros(1, np.int64), planes,
                                           tree.tol, eye, 1e-9, lists, history, skip, bits,
                                           out, stack)
        assert not bits.any() and visited > 0
        return out[:count].copy()

    every = gather(np.zeros(0, np.int64))
    leaves = np.flatnonzero((tree.child_count == 0) & tree.nonempty)
    expect = np.unique(np.concatenate([history, lists[leaves].ravel()]))
    assert len(every) == len(np.unique(every))
    assert np.array_equal(np.sort(every), expect[expect >= 0])
    assert list(every[:3]) == [5, 7, 60]  # history first, in order
    skip = every[1::3]
    assert np.array_equal(gather(skip), every[~np.isin(every, skip)])


def test_facing_occluders_is_the_device_bound_and_the_grazing_test():
    from vismobile.culling.facing import frontfacing
    from vismobile.culling.hiz import facing_occluders
    from vismobile.culling.triangle_backface import GAMMA_8

    rng = np.random.default_rng(21)
    vertices = rng.normal(size=(1500, 3)) * rng.uniform(0.01, 10.0, (1500, 1))
    triangles = np.arange(1500, dtype=np.int32).reshape(-1, 3)
    corners = vertices[triangles]
    cross = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    normals = cross / np.linalg.norm(cross, axis=1, keepdims=True)
    v0, centroids = corners[:, 0].copy(), corners.mean(axis=1)
    ids = rng.permutation(500).astype(np.int64)
    eye = np.array([0.3, -0.2, 0.5])
    for delta, grazing in ((0.0, 1e-6), (1e-3, 0.3), (0.5, 0.0)):
        sure = frontfacing(ids, vertices, triangles, eye, delta, GAMMA_8)
        w, n = eye - v0[ids], normals[ids]
        towards = (n[:, 0] * w[:, 0] + n[:, 1] * w[:, 1]) + n[:, 2] * w[:, 2]
        d = centroids[ids] - eye
        far = np.sqrt((d[:, 0] * d[:, 0] + d[:, 1] * d[:, 1]) + d[:, 2] * d[:, 2])
        expect = sure & (towards > grazing * far)
        for rows, table in ((ids, slice(None)), (np.arange(500), ids)):  # world or frame rows
            got = facing_occluders(ids, vertices, triangles, rows, normals[table], v0[table],
                                   centroids[table], eye, delta, GAMMA_8, grazing)
            assert np.array_equal(got, expect) and 0 < got.sum() < len(ids)
        if grazing == 0.3:
            assert (sure & ~got).any()  # the grazing test dropped some that certainly face


# ---- the centre test (`screen` option): only pixels under the screen's centres are read ------

def centre_test(tris, depth, shift=0.0, tile_near=None, screen=(2 * W, 2 * H)):
    """(hidden, subpixel) of camera-space triangles (K, 3, 3) against the (H, W) depth buffer
    (no device move), with the centre test of an sw x sh screen (sw 0: off); tile_near (rows *
    cols,) the occluders' nearest depth per tile for the local shift (None: no occluder)."""
    from vismobile.culling.hiz import hidden_triangles, shift_table_size, tile_shifts

    tris = np.asarray(tris, dtype=float).reshape(-1, 3, 3)
    cols, rows = W // TILE[0], H // TILE[1]
    flat = np.ascontiguousarray(np.asarray(depth, dtype=float).ravel())
    tmax, tany, tmin = np.empty(rows * cols), np.empty(rows * cols, bool), np.empty(rows * cols)
    build_tiles(flat, W, H, *TILE, tmax, tany, tmin)
    table = np.zeros(shift_table_size(rows, cols))
    near = np.full(rows * cols, np.inf) if tile_near is None else np.asarray(tile_near, float)
    tile_shifts(near, 1e-3, max(TX, TY), rows, cols, table)
    n = len(tris)
    hidden, subpixel, zmin = np.empty(n, bool), np.empty(n, bool), np.empty(n)
    hidden_triangles(np.arange(n), tris.reshape(-1, 3), np.arange(3 * n).reshape(-1, 3),
                     np.zeros(3), np.eye(3), 0.1, TX, TY, W, H, 0.0, shift, 0.0, 0.0, flat,
                     tmax, table, *TILE, True, *screen, 0.0, hidden, subpixel, zmin)
    return hidden, subpixel


def test_a_thin_triangle_along_a_row_boundary_is_hidden_only_at_the_screens_centres():
    # Rows 0..9 of the buffer covered at depth 5, rows 10.. open. A far triangle over rows
    # 9.3 .. 9.995: its rectangle grown by SLACK_PX reaches the open row 10 (kept without a
    # screen), but the 2x screen's centres under it (screen row 19, buffer y 9.75) are all in
    # row 9, covered nearer: hidden with the screen. One reaching y 10.3 holds centre row 20
    # (buffer y 10.25, open): kept either way.
    depth = np.full((H, W), np.inf)
    depth[:10] = 5.0
    thin = camera_triangle([[4.0, 9.3], [14.0, 9.995], [4.0, 9.995]], 20.0, W, H)
    over = camera_triangle([[4.0, 9.3], [14.0, 10.3], [4.0, 10.3]], 20.0, W, H)
    hidden, subpixel = centre_test([thin, over], depth, screen=(0, 0))
    assert not hidden.any() and not subpixel.any()
    hidden, subpixel = centre_test([thin, over], depth)
    assert list(hidden) == [True, False] and not subpixel.any()
    # Behind the covered rows but nearer than their depth: never hidden.
    near = camera_triangle([[4.0, 9.3], [14.0, 9.995], [4.0, 9.995]], 4.0, W, H)
    assert not centre_test([near], depth)[0].any()


def test_the_centre_test_reads_pixels_within_the_occluders_local_shift():
    # The same thin triangle with occluders that may shift by 1.5 buffer pixels: over tiles no
    # near occluder meets the shift is 0 (hidden); with a near occluder over its tiles the
    # pixels within the shift are read, the open row among them (kept).
    depth = np.full((H, W), np.inf)
    depth[:10] = 5.0
    thin = camera_triangle([[4.0, 9.3], [14.0, 9.995], [4.0, 9.995]], 20.0, W, H)
    shift = 1.5 * TY / (0.5 * H)  # tangent units: 1.5 buffer pixels vertically
    cols, rows = W // TILE[0], H // TILE[1]
    far_away = np.full(rows * cols, np.inf)
    far_away[-1] = 0.05  # a near occluder over the last tile only
    hidden, _ = centre_test([thin], depth, shift=shift, tile_near=far_away)
    assert hidden.all()
    over_it = np.full(rows * cols, 0.05)  # shift about 1 pixel
    hidden, _ = centre_test([thin], depth, shift=shift, tile_near=over_it)
    assert not hidden.any()


def test_tile_shift_table_gives_the_exact_maximum_over_any_tile_range():
    from vismobile.culling.hiz import shift_table_size, tile_shift_bound, tile_shifts

    rng = np.random.default_rng(5)
    for rows, cols in ((40, 15), (1, 1), (3, 7), (5, 1)):
        near = rng.uniform(0.05, 5.0, rows * cols)
        near[rng.random(rows * cols) < 0.3] = np.inf
        table = np.zeros(shift_table_size(rows, cols))
        tile_shifts(near, 0.01, 1.2, rows, cols, table)
        per = table[:rows * cols].reshape(rows, cols)
        z = np.where(np.isinf(near), 1.0, near - 0.01)
        expect = np.where(np.isinf(near), 0.0, 0.01 / z * (1 + 1.2 * near / z + 0.01 / z))
        assert np.allclose(per.ravel(), expect, rtol=1e-14, atol=0)
        for _ in range(200):
            r0, r1 = np.sort(rng.integers(0, rows, 2))
            c0, c1 = np.sort(rng.integers(0, cols, 2))
            assert tile_shift_bound(c0, c1, r0, r1, table, rows, cols) \
                == per[r0:r1 + 1, c0:c1 + 1].max()


def test_a_triangle_under_no_centre_of_the_screen_is_dropped_by_the_centre_test():
    # Between two centre rows of the 2x screen (buffer y 9.75 and 10.25), over open pixels.
    depth = np.full((H, W), np.inf)
    # Over open pixels it has no fragment to hide: the buffer's centre test or the sub-pixel
    # test drops it; without a screen it is kept.
    tri = camera_triangle([[4.0, 9.8], [14.0, 10.2], [4.0, 10.2]], 20.0, W, H)
    hidden, subpixel = centre_test([tri], depth)
    assert (hidden | subpixel).all()
    hidden, subpixel = centre_test([tri], depth, screen=(0, 0))
    assert not (hidden | subpixel).any()


# ---- the screen border: occluder points just off screen may shift onto it ----------------------

def border_px(side, d, a):
    """Buffer pixel coordinates (..., 2) of the point at distance d inside `side`'s border (d < 0:
    off screen) and a along it."""
    d, a = np.broadcast_arrays(np.asarray(d, float), np.asarray(a, float))
    return {"left": np.stack([d, a], -1), "right": np.stack([W - d, a], -1),
            "bottom": np.stack([a, d], -1), "top": np.stack([a, H - d], -1)}[side]


def border_shift(side, pixels):
    """Tangent-unit shift moving a point `pixels` buffer pixels across `side`'s border."""
    return pixels * (TX / (0.5 * W) if side in ("left", "right") else TY / (0.5 * H))


def wall_from(side, edge, z=5.0):
    """A camera-space wall at depth z over the screen and beyond, whose only edge near the
    screen lies `edge` pixels inside `side`'s border (negative: off screen)."""
    corners = border_px(side, [edge, 3 * (W + H)], [-(W + H), 2 * (W + H)])
    (x0, y0), (x1, y1) = corners.min(axis=0), corners.max(axis=0)
    return quad_at(z, 2 * x0 / W - 1, 2 * x1 / W - 1, 2 * y0 / H - 1, 2 * y1 / H - 1)


@pytest.mark.parametrize("side", ["left", "right", "bottom", "top"])
@pytest.mark.parametrize("edge, shift_px, near, hidden", [
    (-0.5, 0.8, 0.015, False),  # the edge moves to 0.3 on screen: within the guard band
    (-1.5, 1.8, 0.015, False),  # the edge moves to 0.3 on screen: beyond the band
    (-1.5, 1.8, 5.0, True),     # the same, but no occluder over these tiles shifts that far
    (-40.0, 0.8, 0.015, True),  # the wall still covers the border after any such shift
])
def test_a_wall_ending_just_off_screen_hides_the_border_only_if_no_shift_uncovers_it(
        side, edge, shift_px, near, hidden):
    # A far triangle over 0.1 .. 0.6 pixels inside the border: an occluder edge `edge` pixels
    # off screen, moved by shift_px toward the screen, uncovers its points before 0.3. `near`:
    # the occluders' nearest depth over every tile (0.015: local shifts above 1.8 pixels).
    depth, _, _ = raster(wall_from(side, edge))
    thing = camera_triangle(border_px(side, [0.1, 0.6, 0.1], [10.0, 11.0, 12.0]), 20.0, W, H)
    got, _ = centre_test([thing], depth, shift=border_shift(side, shift_px),
                         tile_near=np.full((H // TILE[1]) * (W // TILE[0]), near), screen=(0, 0))
    assert got[0] == hidden


def test_a_border_pixels_depth_bounds_the_occluder_just_off_screen():
    # A wall receding toward the left border (camera z = 5 - 1.5 x): its depth at buffer x 0,
    # -0.7, -1 is 12.5, 13.7, 14.3. A triangle at depth 13.1 over x 0.1 .. 0.6 shows in front
    # of the wall moved 0.8 pixels right (its point at x 0.1 came from x -0.7): kept. One at
    # depth 15, behind the wall anywhere within the guard band, stays hidden.
    us = 2 * np.array([-3.0, 3.0 * W]) / W - 1
    vs = 2 * np.array([-H, 2.0 * H]) / H - 1
    rays = np.array([[u * TX, v * TY, 1.0] for u, v in
                     ((us[0], vs[0]), (us[1], vs[0]), (us[1], vs[1]), (us[0], vs[1]))])
    c = rays * (5.0 / (1.0 + 1.5 * rays[:, 0]))[:, None]  # on the plane z = 5 - 1.5 x
    depth, _, _ = raster(np.stack([c[[0, 2, 1]], c[[0, 3, 2]]]))
    thing = camera_triangle([[0.1, 10.0], [0.6, 11.0], [0.1, 12.0]], 13.1, W, H)
    assert not centre_test([thing], depth, shift=border_shift("left", 0.8), screen=(0, 0))[0][0]
    assert depth[11, 0] >= 5.0 / (1.0 + 1.5 * TX * (2 * -1.0 / W - 1))  # the wall at x = -1
    deep = camera_triangle([[0.1, 10.0], [0.6, 11.0], [0.1, 12.0]], 15.0, W, H)
    assert centre_test([deep], depth, shift=border_shift("left", 0.8), screen=(0, 0))[0][0]


# ---- the triangle's shape: only pixels its (moved) shape may reach are read ------------------

def shape_test(tris, depth, move=0.0, shift=0.0, screen=(0, 0)):
    """hidden of camera-space triangles (K, 3, 3) against the (H, W) depth buffer, with the
    centre test of an sw x sh screen (sw 0: no screen), each corner moved by up to `move` per
    coordinate (the buffer's and the screen's), occluders by `shift` tangents everywhere."""
    from vismobile.culling.hiz import hidden_triangles, shift_table_size

    tris = np.asarray(tris, dtype=float).reshape(-1, 3, 3)
    cols, rows = W // TILE[0], H // TILE[1]
    flat = np.ascontiguousarray(np.asarray(depth, dtype=float).ravel())
    tmax, tany, tmin = np.empty(rows * cols), np.empty(rows * cols, bool), np.empty(rows * cols)
    build_tiles(flat, W, H, *TILE, tmax, tany, tmin)
    table = np.full(shift_table_size(rows, cols), np.inf)
    n = len(tris)
    hidden, subpixel, zmin = np.empty(n, bool), np.empty(n, bool), np.empty(n)
    hidden_triangles(np.arange(n), tris.reshape(-1, 3), np.arange(3 * n).reshape(-1, 3),
                     np.zeros(3), np.eye(3), 0.1, TX, TY, W, H, move, shift, 0.0, 0.0, flat,
                     tmax, table, *TILE, True, *screen, move, hidden, subpixel, zmin)
    return hidden


def test_a_diagonal_triangle_is_tested_over_its_shape_not_its_rectangle():
    # The buffer covered at depth 5 but for an open block in one corner of a far triangle's
    # rectangle, well outside its shape: hidden (the rectangle alone kept it), also when the
    # occluders may shift by a pixel or its corners move; its mirror image holds the open block
    # and is kept.
    depth = np.full((H, W), 5.0)
    depth[24:, :6] = np.inf
    half = camera_triangle([[2.0, 2.0], [22.0, 2.0], [22.0, 30.0]], 20.0, W, H)
    other = camera_triangle([[2.0, 2.0], [22.0, 30.0], [2.0, 30.0]], 20.0, W, H)
    assert shape_test([half, other], depth).tolist() == [True, False]
    assert shape_test([half[[0, 2, 1]], other[[0, 2, 1]]], depth).tolist() == [True, False]
    pixel = TX / (0.5 * W)
    assert shape_test([half, other], depth, shift=pixel).tolist() == [True, False]
    assert shape_test([half, other], depth, move=0.02).tolist() == [True, False]
    # Open pixels just beside its long edge, within the occluders' shift: kept.
    near_edge = np.full((H, W), 5.0)
    near_edge[20, 15] = np.inf  # the edge passes x = 2 + 20 (y - 2) / 28: 14.9 at y = 20.5
    assert shape_test([half], near_edge).tolist() == [False]
    near_edge[20, 15], near_edge[20, 10] = 5.0, np.inf  # 4.9 pixels off the edge
    assert shape_test([half], near_edge).tolist() == [True]
    assert shape_test([half], near_edge, shift=5.5 * pixel).tolist() == [False]


def moved_points_on_screen(tri, depth, move, rng):
    """(points (N, 3), bound (N,)): random points of 200 copies of the camera-space triangle
    tri (3, 3) with corners moved by up to move per coordinate, those landing on the screen
    of depth (H, W), and the depth bound of the pixel each lands in."""
    moved = tri + rng.uniform(-move, move, size=(200, 3, 3))
    w = rng.dirichlet(np.ones(3), size=(200, 50))
    points = np.einsum("mkc,mcd->mkd", w, moved).reshape(-1, 3)
    x = np.floor((points[:, 0] / points[:, 2] / TX + 1.0) * 0.5 * W).astype(int)
    y = np.floor((points[:, 1] / points[:, 2] / TY + 1.0) * 0.5 * H).astype(int)
    on = (x >= 0) & (x < W) & (y >= 0) & (y < H)
    return points[on], depth[y[on], x[on]]


def test_a_hidden_triangle_has_every_moved_point_behind_the_buffer():
    # The contract with the shape test and device moves: a triangle called hidden has every
    # point of every moved copy (corners moved by up to `move` per coordinate) that lands on
    # screen behind the depth bound of the pixel it lands in.
    rng = np.random.default_rng(32)
    move, checked = 0.03, 0
    for _ in range(60):
        depth = np.full((H, W), rng.uniform(3.0, 6.0))
        for _ in range(rng.integers(1, 6)):  # open blocks
            y, x = rng.integers(0, H), rng.integers(0, W)
            depth[y:y + rng.integers(1, 5), x:x + rng.integers(1, 5)] = np.inf
        px = rng.uniform(-4.0, [W + 4.0, H + 4.0], size=(40, 3, 2))
        tris = np.array([camera_triangle(p, 1.0, W, H) for p in px])
        tris *= rng.uniform(6.0, 12.0, size=(40, 3, 1))  # corners at different depths
        hidden = shape_test(tris, depth, move=move)
        for t in tris[hidden]:
            points, bound = moved_points_on_screen(t, depth, move, rng)
            assert (points[:, 2] > bound).all()
            checked += 1
    assert checked > 50


def test_a_sloping_triangle_is_tested_against_its_plane_depth_per_pixel():
    # Its near corner (z 5) lies over buffer depth 4, its far side (z 30) over depth 12: hidden
    # only because each pixel compares the plane's nearest depth there (1 / z affine in
    # pixels), not the whole triangle's nearest corner. With the deep part of the buffer
    # reaching pixels where the plane is nearer than 12, it is kept.
    tri = camera_triangle([[2.0, 16.0], [22.0, 4.0], [22.0, 28.0]], 1.0, W, H)
    tri *= np.array([5.0, 30.0, 30.0])[:, None]
    for edge, hidden in ((17, True), (14, False)):
        depth = np.full((H, W), 4.0)
        depth[:, edge:] = 12.0
        assert shape_test([tri], depth).tolist() == [hidden]
        assert shape_test([tri], depth, move=0.01).tolist() == [hidden]


def test_plane_depth_keeps_every_moved_point_behind_uneven_buffers():
    # The contract of the per-pixel plane bound: over buffers of uneven depth, a triangle
    # called hidden has every point of every moved copy on screen behind the depth bound of
    # its pixel; and the plane bound hides some whose nearest corner is not behind them all.
    rng = np.random.default_rng(33)
    move, checked, by_plane = 0.02, 0, 0
    for _ in range(60):
        depth = np.repeat(np.repeat(rng.uniform(3.0, 9.0, size=(H // 4, W // 4)), 4, 0), 4, 1)
        px = rng.uniform(-2.0, [W + 2.0, H + 2.0], size=(40, 3, 2))
        tris = np.array([camera_triangle(p, 1.0, W, H) for p in px])
        tris *= rng.uniform(4.0, 14.0, size=(40, 3, 1))
        hidden = shape_test(tris, depth, move=move)
        for t in tris[hidden]:
            points, bound = moved_points_on_screen(t, depth, move, rng)
            assert (points[:, 2] > bound).all()
            by_plane += len(points) > 0 and points[:, 2].min() < bound.max()
            checked += 1
    assert checked > 50 and by_plane > 0



def test_screen_rect_holds_every_moved_points_exact_projection():
    # _projected_bounds divides once per point (reciprocal depth) instead of four times (issue
    # 32): the rectangle must still hold, to the pixel, the exact (rational) projection of each
    # point moved by up to `move` per coordinate (the projection of a box of moves is extreme
    # at its corners), for points near and far, central and grazing, and sit within a pixel of
    # it (grown only by the slack and the move's bound, not by the rounding).
    import math
    from fractions import Fraction as F

    rng = np.random.default_rng(32)
    w, h = 240, 320
    checked = 0
    for case in range(300):
        tx, ty = rng.choice([0.0175, 0.75, 11.4]), rng.choice([0.0175, 0.75, 11.4])
        z = 10.0 ** rng.uniform(-2, 5, 4)
        pts = np.stack([rng.uniform(-1.2, 1.2, 4) * z * tx, rng.uniform(-1.2, 1.2, 4) * z * ty,
                        z], axis=1)
        move = [0.0, 1e-6, 1e-3][case % 3] * float(z.min())
        x0, x1, y0, y1, zmin, testable, onscreen = screen_rect(pts, 1e-3, tx, ty, w, h, move)
        if not (testable and onscreen):
            continue
        px, py = [], []
        for p in pts:
            for k in range(8):
                q = [F(float(p[a])) + F(move) * (1 if k >> a & 1 else -1) for a in range(3)]
                px.append((q[0] / (q[2] * F(float(tx))) + 1) * F(w, 2))
                py.append((q[1] / (q[2] * F(float(ty))) + 1) * F(h, 2))
        fx = [math.floor(v) for v in px if 0 <= v < w]
        fy = [math.floor(v) for v in py if 0 <= v < h]
        assert all(x0 <= v <= x1 for v in fx), case
        assert all(y0 <= v <= y1 for v in fy), case
        if move == 0.0 and len(fx) == len(px) and len(fy) == len(py):  # whole on screen
            assert x0 >= min(fx) - 1 and x1 <= max(fx) + 1, case
            assert y0 >= min(fy) - 1 and y1 <= max(fy) + 1, case
            checked += 1
    assert checked > 20

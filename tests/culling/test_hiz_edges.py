"""The buffer's edge records (culling/hiz/edges.py): a pixel one boundary piece of an occluder
group meets keeps the group's plane and the piece's line, and the triangle test at the
screen's centres reads them: a triangle called hidden is behind the nearest occluder at every
centre it may cover, and triangles along an occluder's outline that the bare buffer keeps are
hidden."""
import numpy as np

from vismobile.culling.hiz import rasterise
from vismobile.culling.hiz.edges import buffer_length
from vismobile.culling.occluder_mesh import occluder_mesh

from .test_hiz import TX, TY, H, W, camera_triangle, nearest_hit, random_occluders, shape_test

SCREEN = (2 * W, 2 * H)


def buffer_of(tris, clip=0.1, records=True, half=0.5):
    """The flat depth buffer of occluders tris (K, 3, 3) facing the eye (test_hiz.raster's
    set-up), with room for edge records (or the bounds alone)."""
    n = np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0])
    n /= np.linalg.norm(n, axis=1)[:, None]
    mesh = occluder_mesh(tris.reshape(-1, 3), np.arange(3 * len(tris)).reshape(-1, 3), n)
    points, tri_points, normals, offsets, groups, start, end, a, b, partner, anyp = mesh
    ids = np.argsort(groups, kind="stable").astype(np.int64)
    depth = np.full(buffer_length(W * H, 3 * len(tris)) if records else W * H, np.inf)
    mask, centre = np.zeros(W * H, dtype=np.uint8), np.zeros(W * H, dtype=np.uint8)
    crease = np.zeros(W * H)
    rasterise(ids, groups, tri_points, points, normals, offsets, start, end, a, b, partner,
              anyp, np.full(len(tris), -1, dtype=np.int64), 1, np.zeros(3), np.eye(3), clip,
              TX, TY, W, H, depth, mask, centre, crease, 1e-9, half)
    assert not mask.any() and not centre.any() and not crease.any()
    return depth


def hidden_of(tested, depth, shift=0.0):
    """hidden of camera-space triangles (K, 3, 3) against a flat buffer of any layout (edge
    records or not), with the centre test of the 2x screen."""
    return shape_test(tested, depth, shift=shift, screen=SCREEN)


def fragments_in_front(tri, occluders, clip):
    """Screen centres (2x screen) within 1e-6 of the triangle tri (3, 3) where it is not
    behind the nearest occluder part at depth >= clip (none there counts as in front)."""
    sw, sh = SCREEN
    i, j = np.meshgrid(np.arange(sw), np.arange(sh))
    u, v = 2 * (i.ravel() + 0.5) / sw - 1, 2 * (j.ravel() + 0.5) / sh - 1
    p = tri[:, :2] / tri[:, 2:] / [TX, TY]
    e = np.array([(p[(k + 1) % 3, 0] - p[k, 0]) * (v - p[k, 1])
                  - (p[(k + 1) % 3, 1] - p[k, 1]) * (u - p[k, 0]) for k in range(3)])
    scale = np.linalg.norm(p - p[[1, 2, 0]], axis=1)[:, None]
    inside = (e >= -1e-6 * scale).all(0) | (e <= 1e-6 * scale).all(0)
    if not inside.any():
        return 0
    normal = np.cross(tri[1] - tri[0], tri[2] - tri[0])
    rays = np.stack([u * TX, v * TY, np.ones_like(u)], 1)[inside]
    z = (normal @ tri[0]) / (rays @ normal)
    return int((z <= nearest_hit(occluders, u[inside], v[inside], clip)).sum())


def outline_triangles(occluders, rng, count):
    """Small camera-space triangles behind the occluders, placed across the screen: many cross
    or touch an occluder's outline."""
    far = occluders[:, :, 2].max() + 1.0
    px = rng.uniform(0.0, [W, H], size=(count, 1, 2)) + rng.uniform(-1.5, 1.5, (count, 3, 2))
    return np.array([camera_triangle(p, far * rng.uniform(1.0, 1.5), W, H) for p in px])


def test_edge_records_hide_only_what_the_nearest_occluder_hides_at_every_centre():
    rng = np.random.default_rng(32)
    checked, by_records = 0, 0
    for _ in range(12):
        occluders = random_occluders(rng, 6)
        occluders = occluders[occluders[:, :, 2].min(1) > 0.3]
        with_records = buffer_of(occluders, clip=0.3)
        bare = buffer_of(occluders, clip=0.3, records=False)
        assert np.array_equal(with_records[:W * H], bare)  # the bounds are unchanged
        tested = outline_triangles(occluders, rng, 200)
        for shift in (0.0, 0.2 * TX / (0.5 * W)):
            hidden = hidden_of(tested, with_records, shift)
            kept_bare = ~hidden_of(tested, bare, shift)
            for t in tested[hidden]:
                assert fragments_in_front(t, occluders, 0.3) == 0
                checked += 1
            by_records += int((hidden & kept_bare).sum())
            assert not (hidden_of(tested, bare, shift) & ~hidden).any()  # records only add
    assert checked > 100 and by_records > 20


def test_a_triangle_beside_a_wall_edge_is_hidden_at_the_screens_centres_only_with_records():
    # A wall at depth 5 whose left edge crosses buffer pixels (x = 10.3 buffer pixels), a far
    # wall at 9 behind everything; a thin triangle at depth 7 lies over the near wall just right
    # of its edge: the edge pixels hold the far wall's bound (9), so the bare buffer keeps it;
    # at every screen centre it covers the near wall is drawn in front of it.
    far = np.stack([camera_triangle([[-2, -2], [W + 2, -2], [W + 2, H + 2]], 9.0, W, H),
                    camera_triangle([[-2, -2], [W + 2, H + 2], [-2, H + 2]], 9.0, W, H)])
    near = np.stack([camera_triangle([[10.3, -3], [W + 3, -3], [W + 3, H + 3]], 5.0, W, H),
                     camera_triangle([[10.3, -3], [W + 3, H + 3], [10.3, H + 3]], 5.0, W, H)])
    occluders = np.concatenate([far, near])
    occluders = np.array([t if np.cross(t[1] - t[0], t[2] - t[0]) @ -t[0] > 0 else t[[0, 2, 1]]
                          for t in occluders])
    tri = camera_triangle([[10.45, 8.2], [10.9, 8.2], [10.45, 14.7]], 7.0, W, H)[None]
    assert hidden_of(tri, buffer_of(occluders)).all()
    assert not hidden_of(tri, buffer_of(occluders, records=False)).any()
    assert fragments_in_front(tri[0], occluders, 0.1) == 0
    # Left of the edge (over the far wall only) it stays.
    left = camera_triangle([[9.2, 8.2], [10.2, 8.2], [9.2, 14.7]], 7.0, W, H)[None]
    assert not hidden_of(left, buffer_of(occluders)).any()

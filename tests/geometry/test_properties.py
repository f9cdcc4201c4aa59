"""Hypothesis property tests: every predicate in vismobile/geometry against a brute-force or exact
reference, on hostile magnitudes (1e-4 .. 1e7), touching and degenerate input."""
from fractions import Fraction

import numpy as np
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from vismobile.world.camera import Camera
from vismobile.geometry.boxes import box_corners, boxes_contain_point
from vismobile.geometry.cones import NEVER, cluster_cones, cones_backfacing
from vismobile.geometry.planes import (classify_boxes, planes_through_eye, points_inside,
                                       slack, spheres_outside)
from vismobile.culling.hiz import screen_rect
from vismobile.geometry.sphere_regions import caps_within, direction_regions, region_caps
from vismobile.geometry.triangle_box import triangles_overlap_boxes

SETTINGS = settings(max_examples=80, deadline=None)
FAR = st.sampled_from([1.0, 1e-4, 1e3, 1e5, 1e7])  # magnitude of an offset applied to a case


def F(x):
    return Fraction(float(x))


def exact_dot(plane, point):
    return F(plane[0]) * F(point[0]) + F(plane[1]) * F(point[1]) + F(plane[2]) * F(point[2]) \
        + F(plane[3])


@st.composite
def plane_sets(draw, count=st.integers(1, 6), offset=0.0):
    k = draw(count)
    raw = np.array(draw(st.lists(st.tuples(*[st.floats(-1, 1)] * 3), min_size=k, max_size=k)))
    length = np.linalg.norm(raw, axis=1, keepdims=True)
    normals = np.where(length > 1e-3, raw / np.maximum(length, 1e-300), [0.0, 1.0, 0.0])
    d = np.array(draw(st.lists(st.floats(-10, 10), min_size=k, max_size=k)))
    return np.column_stack([normals, d - normals @ np.full(3, offset)])


@st.composite
def boxes(draw, offset=0.0):
    lo = np.array(draw(st.tuples(*[st.floats(-10, 10)] * 3))) + offset
    size = np.array(draw(st.tuples(*[st.sampled_from([0.0, 1e-6, 0.5, 3.0])] * 3)))
    return np.array([lo, lo + size])


@st.composite
def offset_case(draw):
    """(offset, planes (K, 4), box (2, 3)) at a random magnitude; planes sometimes touch the box."""
    offset = draw(FAR)
    planes = draw(plane_sets(offset=offset))
    box = draw(boxes(offset=offset))
    if draw(st.booleans()):  # make plane 0 pass exactly through a box corner
        corner = box_corners(box[None])[0, draw(st.integers(0, 7))]
        planes[0, 3] = -float(planes[0, :3] @ corner)
    return offset, planes, box


# ---- planes.py -------------------------------------------------------------------------------

@SETTINGS
@given(offset_case())
def test_classify_boxes_outside_only_when_all_8_corners_are_outside_a_plane(case):
    _, planes, box = case
    tol = slack(box, planes)
    outside, inside = classify_boxes(box[None], planes, tol)
    corners = box_corners(box[None])[0]
    exact = [[exact_dot(p, c) for c in corners] for p in planes]  # (K, 8)
    if outside[0]:
        assert any(max(row) < 0 for row in exact)
    # tight up to the slack: a plane with all corners clearly outside is found
    far_out = any(max(row) < -3 * Fraction(tol) - 1 for row in exact)
    assert outside[0] or not far_out
    # "inside" a plane never holds when a corner is clearly behind it
    for k, row in enumerate(exact):
        assert not (inside[0, k] and min(row) < -Fraction(tol))


@SETTINGS
@given(offset_case())
def test_points_inside_keeps_every_exactly_inside_point(case):
    _, planes, box = case
    corners = box_corners(box[None])[0]
    got = points_inside(corners, planes, slack(corners, planes))
    for c, flag in zip(corners, got):
        if all(exact_dot(p, c) >= 0 for p in planes):
            assert flag


@SETTINGS
@given(offset_case(), st.floats(0, 5))
def test_spheres_outside_never_drops_a_sphere_reaching_inside(case, radius):
    _, planes, box = case
    center = box.mean(axis=0)
    out = spheres_outside(center[None], np.array([radius]), planes, slack(center, planes))
    if out[0]:
        assert any(exact_dot(p, center) < -F(radius) for p in planes)


@SETTINGS
@given(st.tuples(*[st.floats(-1e7, 1e7)] * 3), st.integers(3, 6), st.floats(0.01, 1.5))
def test_planes_through_eye_hold_the_pyramid(eye, sides, spread):
    angles = np.linspace(0, 2 * np.pi, sides, endpoint=False)
    dirs = np.column_stack([spread * np.cos(angles), spread * np.sin(angles), -np.ones(sides)])
    eye = np.asarray(eye)
    for order in (dirs, dirs[::-1]):
        planes = planes_through_eye(eye, order)
        scale = 1e-12 * max(1.0, np.abs(eye).max())
        inner = eye + order.sum(axis=0) / sides  # the pyramid's axis point
        assert np.all(planes[:, :3] @ inner + planes[:, 3] > 0)
        edges = eye + order * 10.0  # on the pyramid's edges: on or inside every plane
        assert np.all(edges @ planes[:, :3].T + planes[:, 3] >= -10 * scale - 1e-9)


# ---- boxes.py --------------------------------------------------------------------------------

@SETTINGS
@given(boxes(offset=0.0), st.tuples(*[st.floats(-12, 14)] * 3))
def test_box_corners_and_containment_are_exact(box, point):
    corners = box_corners(box[None])[0]
    assert {tuple(c) for c in corners} == {(x, y, z) for x in box[:, 0] for y in box[:, 1]
                                           for z in box[:, 2]}
    point = np.asarray(point)
    expect = bool(np.all((box[0] <= point) & (point <= box[1])))
    assert boxes_contain_point(box[None], point)[0] == expect
    assert np.all(boxes_contain_point(box[None], corners[0]))  # closed boxes


# ---- triangle_box.py (SAT) -------------------------------------------------------------------

@SETTINGS
@given(st.tuples(*[st.floats(-3, 3)] * 9), boxes(offset=0.0), FAR)
def test_sat_reports_every_overlap_dense_sampling_finds(flat, box, offset):
    tri = np.asarray(flat).reshape(3, 3) * 3.0 + offset
    box = box + offset
    got = triangles_overlap_boxes(tri[None], box[0], box[1])[0]
    s = np.linspace(0, 1, 13)
    a, b = np.meshgrid(s, s)
    keep = a + b <= 1
    samples = tri[0] + a[keep, None] * (tri[1] - tri[0]) + b[keep, None] * (tri[2] - tri[0])
    samples = np.concatenate([samples, tri])
    if np.any(np.all((samples >= box[0]) & (samples <= box[1]), axis=1)):
        assert got
    # boxes clearly apart from the triangle's own box never overlap
    gap = 1e-6 * (1.0 + abs(offset))
    if np.any(tri.min(axis=0) > box[1] + gap) or np.any(tri.max(axis=0) < box[0] - gap):
        assert not got


def test_sat_degenerate_triangles_and_touching_faces():
    box = np.array([[0.0, 0, 0], [1, 1, 1]])
    point = np.array([[1.0, 0.5, 0.5]] * 3)  # zero-area triangle on a face
    needle = np.array([[2.0, 0.5, 0.5], [1.0, 0.5, 0.5], [2.0, 0.5, 0.5 + 1e-12]])
    away = needle + [1e-3, 0, 0]
    got = triangles_overlap_boxes(np.stack([point, needle, away]), box[0], box[1])
    assert got.tolist() == [True, True, False]


# ---- cones.py --------------------------------------------------------------------------------

@SETTINGS
@given(st.lists(st.tuples(*[st.floats(-1, 1)] * 9), min_size=1, max_size=6),
       st.tuples(*[st.floats(-5, 5)] * 3), FAR)
def test_cone_backfacing_implies_every_triangle_backfacing(flats, eye, offset):
    tri = np.asarray(flats).reshape(-1, 3, 3)
    tri = tri * [1.0, 1.0, 0.05] + [0.0, 0.0, 1.0]  # roughly facing +z: cones form often
    tri = tri + offset
    cross = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    length = np.linalg.norm(cross, axis=1, keepdims=True)
    normals = np.where(length > 0, cross / np.where(length > 0, length, 1), 0.0)
    apex, axis, cutoff = cluster_cones(normals, tri, np.array([0]), np.array([len(tri)]),
                                       scale=max(1.0, offset))
    eye = np.asarray(eye) + offset
    if cones_backfacing(apex, axis, cutoff, eye)[0]:
        assert cutoff[0] != NEVER
        for t in tri:  # exact orientation of the eye against each triangle's own plane
            a, b, c = ([F(x) for x in v] for v in t)
            e1 = [b[i] - a[i] for i in range(3)]
            e2 = [c[i] - a[i] for i in range(3)]
            n = [e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2],
                 e1[0] * e2[1] - e1[1] * e2[0]]
            assert sum(n[i] * (F(eye[i]) - a[i]) for i in range(3)) <= 0


def test_cone_of_an_empty_or_degenerate_cluster_never_culls():
    tri = np.zeros((1, 3, 3))
    apex, axis, cutoff = cluster_cones(np.zeros((1, 3)), tri, np.array([0, 1]), np.array([0, 1]))
    assert cutoff.tolist() == [NEVER, NEVER]
    assert not cones_backfacing(apex, axis, cutoff, np.array([0.0, 0, 5])).any()


# ---- sphere_regions.py -----------------------------------------------------------------------

@SETTINGS
@given(st.lists(st.tuples(*[st.floats(-1, 1)] * 3), min_size=1, max_size=20),
       st.integers(1, 12), st.integers(1, 6))
def test_every_direction_lies_in_its_regions_cap(dirs, yaw_regions, bands):
    dirs = np.asarray(dirs)
    dirs = dirs[np.linalg.norm(dirs, axis=1) > 1e-6]
    assume(len(dirs))
    ids = direction_regions(dirs, yaw_regions, bands)
    centers, radii = region_caps(yaw_regions, bands)
    unit = dirs / np.linalg.norm(dirs, axis=1, keepdims=True)
    angle = np.arccos(np.clip(np.einsum("ij,ij->i", unit, centers[ids]), -1, 1))
    assert np.all(angle <= radii[ids] + 1e-12)


@SETTINGS
@given(st.tuples(*[st.floats(-1, 1)] * 3), st.floats(0.0, 1.5),
       st.lists(st.tuples(*[st.floats(-1, 1)] * 3), min_size=1, max_size=4))
def test_caps_within_means_every_cap_direction_is_within_90_degrees(center, radius, rays):
    center, rays = np.asarray(center), np.asarray(rays)
    assume(np.linalg.norm(center) > 1e-3 and np.all(np.linalg.norm(rays, axis=1) > 1e-3))
    center = center / np.linalg.norm(center)
    if caps_within(center[None], np.array([radius]), rays)[0]:
        # directions on the cap's rim, where the angle to a ray is largest
        helper = np.cross(center, [1.0, 0, 0] if abs(center[0]) < 0.9 else [0, 1.0, 0])
        helper /= np.linalg.norm(helper)
        other = np.cross(center, helper)
        phi = np.linspace(0, 2 * np.pi, 64)
        rim = (np.cos(radius) * center + np.sin(radius) * (np.cos(phi)[:, None] * helper
                                                           + np.sin(phi)[:, None] * other))
        assert np.all(rim @ rays.T >= -1e-9)


# ---- culling/hiz/buffer.py: screen rectangles---------------------------------------------------

@SETTINGS
@given(boxes(offset=0.0), st.floats(0, 360), st.floats(-89, 89),
       st.sampled_from([1.0, 45.0, 170.0]))
def test_screen_rectangle_contains_every_projected_corner(box, yaw, pitch, fov):
    cam = Camera((0.0, 0.0, 20.0), yaw, pitch, fov)
    right, up, forward = cam.basis()
    rotation = np.stack([right, up, forward])
    tx = np.tan(np.radians(fov) / 2) * cam.aspect
    ty = np.tan(np.radians(fov) / 2)
    w, h = 240, 320
    pts = (box_corners(box[None])[0] - cam.eye) @ rotation.T
    x0, x1, y0, y1, zmin, testable, onscreen = screen_rect(pts, cam.near, tx, ty, w, h)
    if not (testable and onscreen):
        return
    assert np.all(pts[:, 2] >= zmin)
    px = (pts[:, 0] / (pts[:, 2] * tx) + 1) * 0.5 * w
    py = (pts[:, 1] / (pts[:, 2] * ty) + 1) * 0.5 * h
    inside = (px >= 0) & (px < w) & (py >= 0) & (py < h)
    assert np.all(np.floor(px[inside]) >= x0) and np.all(np.floor(px[inside]) <= x1)
    assert np.all(np.floor(py[inside]) >= y0) and np.all(np.floor(py[inside]) <= y1)


# ---- camera.frustum_planes (foundation): agrees with the clip-space test -----------------------

@SETTINGS
@given(st.tuples(*[st.floats(-1e7, 1e7)] * 3), st.floats(0, 360), st.floats(-90, 90),
       st.sampled_from([1.0, 45.0, 170.0]), st.tuples(*[st.floats(-1, 1)] * 3),
       st.sampled_from([1e-4, 0.1, 10.0]))
def test_frustum_planes_match_the_clip_volume(eye, yaw, pitch, fov, ndc, near):
    cam = Camera(eye, yaw, pitch, fov, near=near, far=near * 1e4)
    right, up, forward = cam.basis()
    # a point from normalized device coordinates, built in camera space (no world rounding)
    depth = near + (ndc[2] + 1) / 2 * (cam.far - near)
    tv = np.tan(np.radians(fov) / 2)
    local = np.array([ndc[0] * depth * tv * cam.aspect, ndc[1] * depth * tv, depth])
    point = cam.eye + local[0] * right + local[1] * up + local[2] * forward
    dist = cam.frustum_planes() @ np.append(point, 1.0)
    scale = 1e-9 * (np.abs(cam.eye).max() + depth + 1.0)
    assert np.all(dist >= -scale)

"""Arithmetic modes: quantisation, range errors, device-exact plane tests and their error bounds."""
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from vismobile.errors import ProfileError
from vismobile.geometry import arithmetic as ar

MODES = ar.MODES


def exact_distance(planes, points):
    """(N, K) list of exact Fractions of n.p + d for the float64 inputs."""
    return [[sum(Fraction(float(n)) * Fraction(float(x)) for n, x in zip(plane[:3], p))
             + Fraction(float(plane[3])) for plane in planes] for p in points]


def unit_planes(raw):
    raw = np.asarray(raw, dtype=np.float64).reshape(-1, 4)
    length = np.linalg.norm(raw[:, :3], axis=1, keepdims=True)
    raw[:, :3] = np.where(length > 1e-6, raw[:, :3] / np.maximum(length, 1e-300), [1.0, 0, 0])
    return raw


coordinate = st.floats(-3e4, 3e4, allow_nan=False)
small = st.floats(-1.0, 1.0, allow_nan=False)


def test_unknown_mode_is_a_profile_error():
    with pytest.raises(ProfileError, match="unknown arithmetic mode"):
        ar.unit_roundoff("float16")


def test_quantize_float32_matches_numpy_cast():
    x = np.array([0.1, 1e7 + 0.3, -3.3e-5])
    assert np.array_equal(ar.quantize(x, "float32"), x.astype(np.float32).astype(np.float64))


def test_quantize_fixed_lands_on_the_grid():
    q = ar.quantize([0.1, -2.5, 32767.0], "fixed16.16")
    assert np.array_equal(q * 65536, np.rint(q * 65536))
    assert q[1] == -2.5 and abs(q[0] - 0.1) <= 2.0**-17


@pytest.mark.parametrize("value, mode", [(32768.0, "fixed16.16"), (1e39, "float32"),
                                         (np.inf, "float64"), (np.nan, "float32")])
def test_quantize_refuses_what_the_mode_cannot_hold(value, mode):
    with pytest.raises(ProfileError, match="world"):
        ar.quantize([1.0, value], mode, "world")


@given(st.floats(-3e4, 3e4, allow_nan=False), st.sampled_from(MODES))
def test_representation_error_bounds_quantisation(x, mode):
    assert abs(ar.quantize(x, mode) - x) <= ar.representation_error(x, mode)


def test_check_resolution_refuses_a_room_at_1e7_in_float32():
    room = np.array([[0.0, 0, 0], [8, 3, 12]])
    with pytest.raises(ProfileError, match="float32 cannot resolve"):
        ar.check_resolution(room + 1e7, "float32")
    assert ar.check_resolution(room + 1e3, "float32") < 1e-4
    assert ar.check_resolution(room + 1e7, "float64") < 1e-8


def test_check_resolution_fixed_range_and_tiny_worlds():
    room = np.array([[0.0, 0, 0], [8, 3, 12]])
    with pytest.raises(ProfileError, match="range"):
        ar.check_resolution(room + 1e5, "fixed16.16")
    with pytest.raises(ProfileError, match="cannot resolve"):
        ar.check_resolution(room * 1e-4, "fixed16.16")
    ar.check_resolution(room + 1e3, "fixed16.16")


def test_float32_distance_is_the_devices_sequence_of_roundings():
    planes = np.array([[0.6, 0.8, 0.0, -1e4 - 0.1]])
    points = np.array([[1e4 / 3, 7e3 / 3, 0.123]])
    n, p = planes.astype(np.float32), points.astype(np.float32)
    expect = ((p[0, 0] * n[0, 0] + p[0, 1] * n[0, 1]) + p[0, 2] * n[0, 2]) + n[0, 3]
    value, _ = ar.plane_distance(planes, points, "float32")
    assert value[0, 0] == float(expect)


def test_fixed_distance_uses_floor_shift_of_int64_products():
    # 0.5 * 1.5 = 0.75 exactly; -2^-16 * 0.5 floors to -2^-16
    value, _ = ar.plane_distance([[0.5, 0.0, 0.0, 0.0]], [[1.5, 0, 0], [-2.0**-16, 0, 0]],
                                 "fixed16.16")
    assert value[0, 0] == 0.75 and value[1, 0] == -(2.0**-16)


def test_fixed_overflow_is_detected():
    plane = [[1.0, 1.0, 1.0, 0.0]]  # not unit: lets three in-range terms overflow int32
    with pytest.raises(ProfileError, match="overflow"):
        ar.plane_distance(plane, [[30000.0, 30000.0, 0.0]], "fixed16.16")


@settings(max_examples=150, deadline=None)
@given(st.lists(st.tuples(small, small, small, coordinate), min_size=1, max_size=3),
       st.lists(st.tuples(coordinate, coordinate, coordinate), min_size=1, max_size=3),
       st.sampled_from(MODES))
def test_plane_distance_bound_is_rigorous(raw_planes, raw_points, mode):
    planes = unit_planes(raw_planes)
    planes[:, 3] = np.clip(planes[:, 3], -3e4, 3e4)
    points = np.asarray(raw_points, dtype=np.float64)
    try:
        values, bounds = ar.plane_distance(planes, points, mode)
    except ProfileError:
        assert mode == "fixed16.16"  # only fixed point can overflow at these magnitudes
        return
    exact = exact_distance(planes, points)
    for i in range(len(points)):
        for k in range(len(planes)):
            assert abs(Fraction(values[i, k]) - exact[i][k]) <= Fraction(bounds[i, k])


@settings(max_examples=100, deadline=None)
@given(st.tuples(small, small, small, coordinate), st.tuples(coordinate, coordinate, coordinate),
       st.sampled_from(MODES))
def test_distance_error_bound_covers_plane_distance_bound(raw_plane, point, mode):
    plane = unit_planes([raw_plane])
    magnitude = float(np.abs(point).max())
    bound = ar.distance_error_bound(mode, magnitude, abs(plane[0, 3]))
    _, bounds = ar.plane_distance(plane, [point], mode) if mode != "fixed16.16" else (
        None, ar._fixed_bound(plane, np.asarray([point], dtype=float)))
    assert bounds.max() <= bound


@settings(max_examples=150, deadline=None)
@given(st.tuples(small, small, small, st.floats(-1e4, 1e4)),
       st.tuples(*[st.floats(-1e4, 1e4)] * 3), st.sampled_from(MODES))
def test_inflated_plane_keeps_inside_points_inside_in_every_mode(raw_plane, point, mode):
    plane = unit_planes([raw_plane])
    point = np.asarray([point], dtype=np.float64)
    # Move the plane onto the point, the hardest inside case: d = -n.p rounded up, exactly.
    target = -sum(Fraction(float(n)) * Fraction(float(c)) for n, c in zip(plane[0, :3], point[0]))
    plane[0, 3] = float(target)
    if Fraction(plane[0, 3]) < target:
        plane[0, 3] = np.nextafter(plane[0, 3], np.inf)
    assert exact_distance(plane, point)[0][0] >= 0
    inflated = ar.inflate_planes(plane, mode, float(np.abs(point).max()))
    try:
        value, _ = ar.plane_distance(inflated, point, mode)
    except ProfileError:
        assert mode == "fixed16.16"
        return
    assert value[0, 0] >= 0.0


@settings(max_examples=100, deadline=None)
@given(st.tuples(*[st.floats(-1e4, 1e4)] * 3), st.tuples(*[st.floats(0, 50)] * 3),
       st.sampled_from(MODES))
def test_inflated_box_holds_the_rounded_box(lo, size, mode):
    box = np.array([lo, np.add(lo, size)])
    grown = ar.inflate_boxes(box[None], mode)[0]
    rounded = ar.quantize(box, mode)
    assert np.all(grown[0] <= rounded[0]) and np.all(rounded[1] <= grown[1])


@settings(max_examples=100, deadline=None)
@given(st.lists(st.tuples(small, small, small, st.floats(-1e3, 1e3)), min_size=1, max_size=6),
       st.tuples(*[st.floats(-1e3, 1e3)] * 3), st.tuples(*[st.floats(0, 10)] * 3),
       st.sampled_from(MODES))
def test_box_certainly_outside_never_drops_a_box_reaching_every_plane(raw, lo, size, mode):
    planes = unit_planes(raw)
    box = np.array([lo, np.add(lo, size)])
    corners = np.array([[box[(k >> a) & 1, a] for a in range(3)] for k in range(8)])
    exact = exact_distance(planes, corners)  # (8, K)
    reaches_all = all(max(exact[c][k] for c in range(8)) >= 0 for k in range(len(planes)))
    outside = ar.box_certainly_outside(planes, box[None], mode)[0]
    assert not (reaches_all and outside)


def test_box_plane_extremes_pick_the_right_corners():
    planes = np.array([[1.0, 0, 0, 0], [0, -1.0, 0, 0]])
    box = np.array([[[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]]])
    pmax, pbound, nmin, nbound = ar.box_plane_extremes(planes, box, "float64")
    assert pmax.tolist() == [[4.0, -2.0]] and nmin.tolist() == [[1.0, -5.0]]
    assert np.all(pbound > 0) and np.all(nbound > 0)

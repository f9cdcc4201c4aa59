"""`tbfc`: exact per-triangle back-face culling with a device-rounding tolerance: drops what
faces away, keeps what faces the eye or is (nearly) edge-on, never drops what the back-face-
culled item buffer shows, and its bound covers moves of the corners and the eye."""
from fractions import Fraction

import numpy as np
import pytest

from vismobile.world.camera import Camera
from vismobile.culling import Culler
from vismobile.culling.triangle_backface import certainly_backfacing, triangle_cross
from vismobile.partition import partition


def verdict(tris, eye, delta=0.0):
    tris = np.asarray(tris, dtype=float).reshape(-1, 3, 3)
    cross, abs_cross, ea, eb = triangle_cross(tris)
    return certainly_backfacing(cross, abs_cross, ea, eb, tris[:, 0], np.asarray(eye, float),
                                delta)


def exact_det(tri, eye):
    """Sign-exact ((v1 - v0) x (v2 - v0)) . (e - v0) in rational arithmetic."""
    v0, v1, v2 = ([Fraction(float(c)) for c in v] for v in tri)
    e = [Fraction(float(c)) for c in eye]
    a = [v1[k] - v0[k] for k in range(3)]
    b = [v2[k] - v0[k] for k in range(3)]
    w = [e[k] - v0[k] for k in range(3)]
    c = [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
    return sum(c[k] * w[k] for k in range(3))


TRI = [[0.0, 0, 0], [1, 0, 0], [0, 1, 0]]  # counter-clockwise seen from +z


def test_front_facing_triangle_is_kept_and_back_facing_dropped():
    assert not verdict(TRI, [0.2, 0.2, 3.0])[0]
    assert verdict(TRI, [0.2, 0.2, -3.0])[0]


def test_edge_on_and_nearly_edge_on_triangles_are_kept():
    assert not verdict(TRI, [5.0, 5.0, 0.0])[0]           # in the triangle's plane
    assert verdict(TRI, [5.0, 5.0, -1e-12])[0]            # exact inputs: truly behind
    assert not verdict(TRI, [5.0, 5.0, -1e-12], delta=1e-9)[0]  # unless the device may move it
    assert not verdict(TRI, [5.0, 5.0, -1e-6], delta=1e-5)[0]  # within the device's move
    assert verdict(TRI, [5.0, 5.0, -1e-3], delta=1e-5)[0]


def test_empty_input_gives_an_empty_verdict():
    assert verdict(np.zeros((0, 3, 3)), [0.0, 0, 0]).shape == (0,)


def test_degenerate_triangle_is_never_dropped():
    assert not verdict([[0.0, 0, 0], [1, 1, 1], [2, 2, 2]], [3.0, -7.0, 1.0])[0]


def test_never_drops_a_triangle_whose_exact_determinant_is_not_negative():
    # Nearly edge-on eyes at a large coordinate offset: float64 rounding matters here.
    rng = np.random.default_rng(11)
    tris = rng.uniform(-1, 1, (400, 3, 3)) * 10.0 ** rng.integers(-3, 2, (400, 1, 1)) + 1e3
    n = np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0])
    eyes = tris[:, 0] + np.cross(n, rng.normal(size=(400, 3))) * rng.uniform(0.1, 10, (400, 1))
    eyes += n * rng.normal(scale=1e-14, size=(400, 1))
    dropped = certainly_backfacing(*triangle_cross(tris), tris[:, 0], eyes[0], 0.0)  # one eye
    for t, drop in zip(tris, dropped):
        assert not drop or exact_det(t, eyes[0]) < 0
    for t, e in zip(tris, eyes):  # eyes grazing each triangle's own plane
        if verdict(t, e)[0]:
            assert exact_det(t, e) < 0


def test_dropped_triangles_stay_back_facing_when_corners_and_eye_move_by_delta():
    rng = np.random.default_rng(12)
    delta = 1e-3
    tris = rng.uniform(-1, 1, (300, 3, 3))
    eyes = rng.uniform(-3, 3, (300, 3))
    for t, e in zip(tris, eyes):
        if not verdict(t, e, delta)[0]:
            continue
        for _ in range(20):
            moved = t + rng.choice([-delta, delta], size=(3, 3))
            eye = e + rng.choice([-delta, delta], size=3)
            n = np.cross(moved[1] - moved[0], moved[2] - moved[0])
            assert n @ (eye - moved[0]) < 0


def test_culler_tbfc_drops_back_faces_and_never_what_the_culled_item_buffer_shows(kit):
    q = kit.quad
    world = kit.literal_world([q(-1, 1, -1, 1, -4, facing=1.0), q(-1, 1, -1, 1, -6, facing=-1.0),
                               q(-3, 3, -3, 3, -9, facing=1.0)])
    part = partition(world, "octree", depth=2)
    cam = Camera((0.3, 0.2, 0.0), yaw=0.0, pitch=0.0, aspect=kit.ASPECT)
    result = Culler(part, "vfc,tbfc").cull(cam)
    back = np.flatnonzero(world.object_ids == 1)
    assert not np.isin(back, result.triangles).any()
    assert np.isin(np.flatnonzero(world.object_ids != 1), result.triangles).all()
    assert result.stats["tbfc.triangles_tested"] == world.triangle_count
    assert result.stats["tbfc.triangles_culled"] == len(back)


def test_tbfc_on_a_thesis_world_keeps_every_visible_triangle(kit, w1_octree):
    culler = Culler(w1_octree, "vfc,tbfc")
    plain = Culler(w1_octree, "vfc")
    dropped = 0
    for cam in kit.random_cameras(w1_octree, 6, seed=40):
        sent = culler.cull(cam).triangles
        visible = kit.visible_ids(w1_octree.world, cam, True)
        assert np.isin(visible, sent).all(), cam
        dropped += len(plain.cull(cam).triangles) - len(sent)
    assert dropped > 0


def test_negative_tolerances_are_rejected(w1_octree):
    with pytest.raises(ValueError, match="tbfc needs"):
        Culler(w1_octree, "tbfc", tbfc={"relative": -1.0})


def test_tbfc_margin_follows_the_arithmetic_mode(w1_octree):
    # The fixed16.16 grid's step is part of the margin in fixed16.16 only; float modes keep
    # the relative (16 float32 ulps) term alone.
    from vismobile.culling.precision import DEVICE_ABSOLUTE, DEVICE_RELATIVE

    eye = np.array([3.0, 1.0, 2.0])
    deltas = {mode: Culler(w1_octree, "tbfc", arithmetic=mode).stages[0].delta(eye)
              for mode in ("float64", "float32", "fixed16.16")}
    scale = float(np.abs(w1_octree.world.vertices).max())
    assert deltas["fixed16.16"] == pytest.approx(DEVICE_RELATIVE * scale + DEVICE_ABSOLUTE)
    assert deltas["float32"] == deltas["float64"] < DEVICE_RELATIVE * scale * (1 + 1e-9)
    given = Culler(w1_octree, "tbfc", arithmetic="float32", tbfc={"absolute": 1e-3})
    assert given.stages[0].delta(eye) == pytest.approx(DEVICE_RELATIVE * scale + 1e-3)

"""Camera conventions: yaw, pitch, frustum planes and projection."""
import numpy as np
import pytest

from vismobile.world.camera import Camera, yaw_toward


def test_yaw_zero_looks_down_negative_z():
    np.testing.assert_allclose(Camera((0, 0, 0)).forward, [0, 0, -1], atol=1e-12)


def test_yaw_ninety_looks_down_negative_x():
    np.testing.assert_allclose(Camera((0, 0, 0), yaw=90).forward, [-1, 0, 0], atol=1e-12)


def test_positive_pitch_looks_up():
    assert Camera((0, 0, 0), pitch=30).forward[1] > 0.49


def test_basis_is_orthonormal_and_right_handed():
    right, up, forward = Camera((1, 2, 3), yaw=37, pitch=-12).basis()
    m = np.stack([right, up, -forward])
    np.testing.assert_allclose(m @ m.T, np.eye(3), atol=1e-12)
    assert np.linalg.det(m) == pytest.approx(1.0)


def inside(camera, point):
    planes = camera.frustum_planes()
    return bool((planes[:, :3] @ np.asarray(point, float) + planes[:, 3] >= 0).all())


def test_frustum_contains_point_straight_ahead():
    camera = Camera((1, 2, 3), yaw=30)
    assert inside(camera, camera.eye + 10 * camera.forward)


@pytest.mark.parametrize("offset", [-5.0, 0.05, 1001.0])
def test_frustum_rejects_behind_before_near_and_beyond_far(offset):
    camera = Camera((0, 0, 0), yaw=-60, pitch=10)
    assert not inside(camera, camera.eye + offset * camera.forward)


def test_frustum_rejects_points_outside_side_planes():
    camera = Camera((0, 0, 0))
    right, up, forward = camera.basis()
    half_h = np.arctan(np.tan(np.radians(22.5)) * camera.aspect)
    for direction, half in ((right, half_h), (-right, half_h), (up, np.radians(22.5)),
                            (-up, np.radians(22.5))):
        just_in = 10 * forward + 10 * np.tan(half - 1e-3) * direction
        just_out = 10 * forward + 10 * np.tan(half + 1e-3) * direction
        assert inside(camera, just_in) and not inside(camera, just_out)


def test_frustum_normals_are_unit():
    planes = Camera((3, 1, -2), yaw=200, pitch=45).frustum_planes()
    np.testing.assert_allclose(np.linalg.norm(planes[:, :3], axis=1), 1.0)


def test_point_on_left_plane_projects_to_ndc_minus_one():
    camera = Camera((2, 1, 0), yaw=15, pitch=5)
    right, up, forward = camera.basis()
    half_h = np.arctan(np.tan(np.radians(camera.fov) / 2) * camera.aspect)
    point = camera.eye + 7 * forward - 7 * np.tan(half_h) * right
    clip = camera.view_projection() @ np.r_[point, 1.0]
    assert clip[0] / clip[3] == pytest.approx(-1.0)
    assert abs(camera.frustum_planes()[0, :3] @ point + camera.frustum_planes()[0, 3]) < 1e-9


def test_near_and_far_map_to_ndc_depth_bounds():
    camera = Camera((0, 0, 0), near=0.5, far=200)
    for distance, depth in ((0.5, -1.0), (200.0, 1.0)):
        clip = camera.view_projection() @ np.r_[distance * camera.forward, 1.0]
        assert clip[2] / clip[3] == pytest.approx(depth)


@pytest.mark.parametrize("kwargs", [dict(fov=0), dict(fov=180), dict(near=0), dict(near=5, far=1),
                                    dict(aspect=0), dict(yaw=float("nan"))])
def test_invalid_cameras_raise(kwargs):
    with pytest.raises(ValueError):
        Camera((0, 0, 0), **kwargs)


def test_yaw_toward_looks_along_the_direction():
    rng = np.random.default_rng(3)
    for dx, dz in rng.normal(size=(20, 2)):
        forward = Camera((0, 0, 0), yaw=float(yaw_toward(dx, dz))).forward
        assert np.allclose(forward, np.array([dx, 0.0, dz]) / np.hypot(dx, dz))


def array_planes(camera):
    """The frustum planes written with numpy arrays (the formula frustum_planes computes in
    scalars)."""
    right, up, forward = camera.basis()
    half_v = np.radians(camera.fov) / 2.0
    half_h = np.arctan(np.tan(half_v) * camera.aspect)
    normals = np.stack([np.cos(half_h) * right + np.sin(half_h) * forward,
                        -np.cos(half_h) * right + np.sin(half_h) * forward,
                        np.cos(half_v) * up + np.sin(half_v) * forward,
                        -np.cos(half_v) * up + np.sin(half_v) * forward, forward, -forward])
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    x, y, z = camera.eye  # summed in order: a BLAS product may fuse or reorder
    d = -(normals[:, 0] * x + normals[:, 1] * y + normals[:, 2] * z)
    d[4] -= camera.near
    d[5] += camera.far
    return np.column_stack([normals, d])


def test_frustum_planes_have_the_bits_of_the_array_formula():
    rng = np.random.default_rng(8)
    for _ in range(300):
        camera = Camera(rng.uniform(-500, 500, 3), yaw=rng.uniform(-720, 720),
                        pitch=rng.uniform(-90, 90), fov=rng.uniform(1, 179),
                        aspect=rng.uniform(0.2, 5), near=rng.uniform(1e-3, 1),
                        far=rng.uniform(2, 1e4))
        assert np.array_equal(camera.frustum_planes(), array_planes(camera))

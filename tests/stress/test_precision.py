"""culling/precision.py: rounding cameras to a mode, and inflating the frustum (rounding worlds:
World.quantized, tests/test_world.py)."""
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from vismobile.world.camera import Camera
from vismobile.culling import precision
from vismobile.errors import ProfileError
from vismobile.geometry import arithmetic


def test_quantize_camera():
    cam = Camera((0.1, 0.2, 0.3), 10, 20, near=0.1, far=100)
    rounded = precision.quantize_camera(cam, "float32")
    assert rounded.eye.tolist() == cam.eye.astype(np.float32).astype(float).tolist()
    with pytest.raises(ProfileError, match="camera position"):
        precision.quantize_camera(cam.with_(position=(4e4, 0, 0)), "fixed16.16")
    with pytest.raises(ProfileError, match="resolution"):
        precision.quantize_camera(cam.with_(near=1e-6), "fixed16.16")
    with pytest.raises(ProfileError, match="near/far"):
        precision.quantize_camera(cam.with_(far=1e7), "fixed16.16")


def test_conservative_camera_moves_only_the_planes():
    cam = Camera((1.0, 2.0, 3.0), 30, -10)
    wide = precision.conservative_camera(cam, "float32", 1e3)
    assert np.array_equal(wide.eye, cam.eye) and wide.basis()[2].tolist() == cam.forward.tolist()
    diff = wide.frustum_planes() - cam.frustum_planes()
    assert np.all(diff[:, :3] == 0) and np.allclose(diff[:, 3], precision.margin("float32", 1e3))


def test_conservative_planes_drop_planes_the_mode_cannot_hold():
    planes = np.array([[0.0, 0, 1, 5.0], [0, 0, -1, 4e4]])
    out = precision.conservative_planes(planes, "fixed16.16", 10.0)
    assert out[0, 3] > 5.0 and out[1].tolist() == [0, 0, 0, 1]


@settings(max_examples=100, deadline=None)
@given(st.sampled_from(arithmetic.MODES), st.sampled_from([10.0, 1e3, 3e4]),
       st.tuples(*[st.floats(-1, 1)] * 3), st.floats(0, 360), st.floats(-90, 90),
       st.sampled_from([1.0, 45.0, 170.0]), st.tuples(*[st.floats(-1, 1)] * 3))
def test_device_plane_test_keeps_every_rounded_inside_point(mode, scale, eye, yaw, pitch, fov,
                                                             where):
    """A point inside the float64 frustum, rounded to the mode, passes the device's test of the
    inflated planes in that mode: the frustum stays conservative."""
    cam = Camera(np.asarray(eye) * scale * 0.5, yaw, pitch, fov, near=0.01, far=scale)
    right, up, forward = cam.basis()
    depth = 0.01 + (where[2] + 1) / 2 * (scale * 0.4)
    tv = np.tan(np.radians(fov) / 2)
    point = cam.eye + depth * (forward + where[0] * tv * cam.aspect * right + where[1] * tv * up)
    point = np.clip(point, -scale, scale)
    exact = cam.frustum_planes() @ np.append(point, 1.0)
    if np.any(exact < 0):
        return  # clipped out of the frustum: nothing to keep
    planes = precision.conservative_planes(cam.frustum_planes(), mode, scale)
    rounded = arithmetic.quantize(point, mode)
    try:
        values, _ = arithmetic.plane_distance(planes, rounded[None], mode)
    except ProfileError as error:  # fixed point far from the origin: a clear refusal
        assert mode == "fixed16.16" and "overflow" in str(error)
        return
    assert np.all(values >= 0)

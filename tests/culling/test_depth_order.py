"""The device's depth order (issue 32): in float32 a near plane within the device's transform
error of the eye (near 1e-3 at a 1e5 offset) leaves it unable to order depths or to draw an
occluder for sure, so `occlusion` must hide nothing there; elsewhere occluder depths are pushed
back by precision.depth_order. Truth: the device's own item buffers (render/device_view.py)."""
import numpy as np
import pytest

from vismobile.world.camera import Camera
from vismobile.culling import Culler, device_options
from vismobile.culling.precision import depth_order, device_move
from vismobile.partition import partition
from vismobile.device.profile import get_profile
from vismobile.render.device_view import device_buffers, dropped_pixels, shown_ids
from vismobile.world.world import World

OFFSET = 1e5


def two_quads(depth, gap):
    """A large quad facing the eye at `depth` and a small one `gap` behind it, both within the
    large one on screen, at the 1e5 offset (front faces toward +z: the camera looks along -z)."""
    big, small = 0.6 * depth, 0.2 * depth
    back = -depth - gap
    v = np.array([[-big, -big, -depth], [big, -big, -depth], [big, big, -depth],
                  [-big, big, -depth], [-small, -small, back], [small, -small, back],
                  [small, small, back], [-small, small, back]])
    t = np.array([[0, 1, 2], [0, 2, 3], [4, 5, 6], [4, 6, 7]])
    return World(v + [OFFSET, 1.5, OFFSET], t, np.zeros(4, np.int32), ["quads"], "quads")


def camera(yaw, near):
    eye = (OFFSET + 0.37, 1.5 + 0.37 / 3, OFFSET + 0.37 / 7)
    return Camera(eye, yaw, 2.0, 60.0, 0.75, near=near, far=1000.0)


@pytest.mark.parametrize("yaw", [3.0, 7.0])
def test_occlusion_hides_nothing_where_the_device_cannot_order_depths(yaw):
    # Before: the back quad, hidden in exact arithmetic, lost 1 (yaw 3) and 2 (yaw 7) triangles
    # that the float32 device draws through the front one.
    profile = get_profile("ipaq-hx2490b")
    assert profile.vertex_format == "float32"
    world = two_quads(10.0, 5.0)
    cam = camera(yaw, 1e-3)
    culler = Culler(partition(world, "octree", depth=1), "vfc,occlusion,tbfc",
                    **device_options(profile))
    result = culler.cull(cam)
    buffers = device_buffers(world, cam, profile, True)
    assert np.isin(np.unique(buffers["device"]), [2, 3]).any()  # the device shows the back quad
    dropped = np.setdiff1d(shown_ids(buffers), result.triangles)
    assert not len(dropped), f"dropped {dropped.tolist()} ({dropped_pixels(buffers, dropped)} px)"
    assert result.stats["occlusion.unordered"] == 1


def test_occlusion_still_hides_where_the_device_orders_depths():
    profile = get_profile("ipaq-hx2490b")
    world = two_quads(10.0, 5.0)
    culler = Culler(partition(world, "octree", depth=1), "vfc,occlusion,tbfc",
                    **device_options(profile))
    result = culler.cull(camera(3.0, 1.0))  # near 1: the slack is 0.21, the gap 0.5 x depth
    assert "occlusion.unordered" not in result.stats
    assert result.triangles.tolist() == [0, 1]
    buffers = device_buffers(world, camera(3.0, 1.0), profile, True)
    assert not len(np.setdiff1d(shown_ids(buffers), result.triangles))


def test_depth_order_bounds():
    move = 2.0 * device_move("float32", OFFSET)  # the stage's m at the offset: 0.19
    assert depth_order(move, 1e-3) == np.inf and depth_order(move, move / 2) == np.inf
    assert depth_order(move, 1.0) == pytest.approx(2 * move / (2 - move))
    small = depth_order(2.0 * device_move("float32", 40.0), 0.1)  # W2's scale, near 0.1
    assert 1e-4 < small < 1e-3
    # Monotonic: a nearer near plane or a larger error never gives a smaller slack.
    assert depth_order(move, 0.5) > depth_order(move, 1.0) > depth_order(move / 2, 1.0)

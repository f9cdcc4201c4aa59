"""Tiny literal scenes for the renderer tests (camera at the origin looking down -z)."""
import numpy as np
import pytest

from vismobile.world.camera import Camera
from vismobile.device.profile import get_profile
from vismobile.world.world import World

PROFILE = get_profile("ipaq-hx2490b")
HALF = np.tan(np.radians(45.0) / 2.0)  # half height of the view at distance 1


def screen_quad(distance, x0, x1, y0, y1, object_id=0):
    """Two counter-clockwise triangles at z = -distance covering NDC [x0,x1] x [y0,y1]."""
    sx, sy = distance * HALF * PROFILE.aspect, distance * HALF
    corners = np.array([[x0 * sx, y0 * sy], [x1 * sx, y0 * sy], [x1 * sx, y1 * sy],
                        [x0 * sx, y1 * sy]])
    vertices = np.column_stack([corners, np.full(4, -float(distance))])
    return World(vertices, [[0, 1, 2], [0, 2, 3]], [object_id, object_id])


@pytest.fixture
def camera():
    return Camera((0.0, 0.0, 0.0), aspect=PROFILE.aspect)


@pytest.fixture
def profile():
    return PROFILE


def terrain(n, size=50.0, seed=0):
    """(2 n^2)-triangle height field over [-size, size]^2 at y ~ 0, front faces up."""
    rng = np.random.default_rng(seed)
    xs, zs = np.meshgrid(np.linspace(-size, size, n + 1), np.linspace(-size, size, n + 1))
    ys = np.sin(xs * 0.2) * np.cos(zs * 0.15) * 3.0 + rng.uniform(0, 0.2, xs.shape)
    vertices = np.stack([xs, ys, zs], -1).reshape(-1, 3)
    i = (np.arange(n)[:, None] * (n + 1) + np.arange(n)[None, :]).ravel()
    triangles = np.concatenate([np.stack([i, i + n + 1, i + 1], 1),
                                np.stack([i + 1, i + n + 1, i + n + 2], 1)])
    return World(vertices, triangles, (np.arange(len(triangles)) // 500).astype(np.int32))


@pytest.fixture(scope="session")
def big_terrain():
    """A world of 45,000 triangles = 135,000 corners: more than two uint16 batches."""
    return terrain(150)

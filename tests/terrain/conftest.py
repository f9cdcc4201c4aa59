"""Small terrains shared by the terrain tests (129^2 and 257^2, built once per session)."""
import pytest

from vismobile.world.camera import Camera
from vismobile.terrain import sources
from vismobile.terrain.tiles import TilePyramid


@pytest.fixture(scope="session")
def fractal129():
    return sources.diamond_square(129, seed=11, roughness=0.5, relief=0.08)


@pytest.fixture(scope="session")
def fractal257():
    return sources.diamond_square(257, seed=5, roughness=0.5, relief=0.15)


@pytest.fixture(scope="session")
def pyramid129(fractal129):
    return TilePyramid.build(fractal129, 8)


@pytest.fixture(scope="session")
def pyramid257(fractal257):
    return TilePyramid.build(fractal257, 16)


def overview_cameras(heightmap):
    """A few views: low over the terrain, high looking down, from a corner, pitched up."""
    w = heightmap.extent
    top = float(heightmap.heights.max())
    return [Camera((0.5 * w, top + 0.05 * w, 1.05 * w), yaw=0, pitch=-20, fov=60, far=4 * w, near=0.05),
            Camera((0.3 * w, top + 0.6 * w, 0.7 * w), yaw=30, pitch=-60, fov=50, far=4 * w, near=0.05),
            Camera((-0.1 * w, top + 0.02 * w, -0.1 * w), yaw=-135, pitch=-5, fov=70, far=4 * w, near=0.05),
            Camera((0.5 * w, top * 0.5, 0.5 * w), yaw=200, pitch=10, fov=60, far=4 * w, near=0.05)]

"""`portals` keeps what the item buffer shows through the rasteriser's cracks (crack slivers,
culling/portal_cracks.py): the sliver planes hold every line through a gap, and over cells whose
faces meet in a T-junction crease (the room of test_pvs_cracks, its far wall standing on the
floor in strips above a hollow slab) the portals keep the slab seen through it, in every
arithmetic mode; without the slivers they drop it."""
import numpy as np
import pytest

from vismobile.culling import Culler, device_options
from vismobile.culling.portal_cracks import CRACK_SLOPE, sliver_planes
from vismobile.device.profile import get_profile
from vismobile.partition import partition
from vismobile.render import item_buffer

from .test_pvs_cracks import MODES

CAMERAS = 100


def test_sliver_planes_hold_every_line_through_a_gap():
    """Lines from the eye through any point within grow + CRACK_SLOPE x distance of a random
    edge lie inside its sliver's four side planes and its beyond plane past that point."""
    rng = np.random.default_rng(3)
    grow, checked = 1e-4, 0
    for _ in range(200):
        eye = rng.uniform(-5, 5, 3)
        a, b = rng.uniform(-10, 10, (2, 3))
        if rng.random() < 0.2:  # an edge pointing at the eye
            b = eye + (a - eye) * rng.uniform(1.2, 3.0)
        limits = np.array([[0.0, 0.0, 0.0, 1.0]] * 2)
        planes, wide = sliver_planes(eye, a[None], b[None], grow, 0.0, limits)
        if wide[0]:
            continue
        for _ in range(50):
            x = a + rng.random() * (b - a)
            gap = grow + CRACK_SLOPE * np.linalg.norm(x - eye)
            offset = rng.normal(size=3)
            y = x + offset / np.linalg.norm(offset) * gap * rng.random()
            for s in (1.0, 1.5, 10.0, 300.0):
                p = eye + s * (y - eye)
                values = planes[0, :, :3] @ p + planes[0, :, 3]
                assert (values >= -1e-9 * (1 + np.abs(p).max())).all(), (eye, a, b, y, s, values)
                checked += 1
    assert checked > 20000


@pytest.fixture(scope="module")
def crease_cells(literal):
    """Portal cells of the crease room: the room, the slab below it and the strip beyond its
    far wall (y cut at 0.2, z at 4)."""
    world = literal.crease_world()
    return partition(world, "portal", depth=1, slabs=(1, [0.2 / 3, 2.8 / 3], [0.8, 0.2]))


@pytest.mark.parametrize("mode", MODES)
def test_portals_keep_what_shows_through_a_t_junction_crease(kit, literal, crease_cells, mode):
    world = crease_cells.world
    assert crease_cells.extras["grid_y"][1] == pytest.approx(0.2)
    target = np.arange(world.triangle_count - 2, world.triangle_count)
    profile = kit.PROFILE if mode == "float64" else get_profile(kit.PROFILE, mode)
    options = {"arithmetic": "float64"} if mode == "float64" else device_options(profile)
    with_cracks = Culler(crease_cells, "portals", portals={"cracks": True}, **options)
    without = Culler(crease_cells, "portals", portals={"cracks": False}, **options)
    through = dropped_without = 0
    for cam in literal.crease_cameras(profile, CAMERAS):
        ids = item_buffer(world, None, cam, profile, cull_back=False)
        shown = target[np.isin(target, ids)]
        result = with_cracks.cull(cam)
        if "portals.fallbacks" in result.stats:
            continue
        missing = np.setdiff1d(shown, result.triangles)
        assert not len(missing), f"{mode}: dropped {missing} seen through the crease: {cam}"
        through += len(shown) > 0
        dropped_without += len(np.setdiff1d(shown, without.cull(cam).triangles)) > 0
    assert through >= 1  # the rasteriser did open the crease
    assert dropped_without >= 1  # and the portals without slivers lose it

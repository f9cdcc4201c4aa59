"""`pvs` keeps what the item buffer shows through the rasteriser's cracks: a room whose far
wall stands on the floor in strips, their bottom corners on the floor's edge but not its
corners (T-junctions), above a hollow slab. No line through the solid geometry leaves the
room, yet the item buffer shows pixels of the slab's bottom through the crease (W1's drop,
docs/partition.md); the bake lets lines through unshared edges (partition/pvs_cracks.py)."""
import numpy as np
import pytest

from vismobile.culling import Culler, device_options
from vismobile.device.profile import get_profile
from vismobile.partition import partition
from vismobile.render import SENTINEL, item_buffer

MODES = ("float64", "float32", "fixed16.16")
CAMERAS = 100


@pytest.fixture(scope="module")
def crease(literal):
    from vismobile.partition import pvs_cells

    # view cells: the room, the slab below it, and both beyond the far wall (z > 4)
    edges = [np.array([0.0, 4.0]), np.array([0.0, 0.2, 3.0]), np.array([0.0, 4.0, 5.0])]
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(pvs_cells, "paired_edges", lambda world, cells: edges)
        part = partition(literal.crease_world(), "portal", depth=1, pvs="conservative")
    assert len(part.extras["pvs_cells"]) == 4
    return part


@pytest.mark.parametrize("mode", MODES)
def test_pvs_keeps_what_shows_through_a_t_junction_crease(kit, literal, crease, mode):
    world = crease.world
    target = np.arange(world.triangle_count - 2, world.triangle_count)
    profile = kit.PROFILE if mode == "float64" else get_profile(kit.PROFILE, mode)
    options = {"arithmetic": "float64"} if mode == "float64" else device_options(profile)
    culler = Culler(crease, "pvs,vfc", **options)
    through = 0
    for cam in literal.crease_cameras(profile, CAMERAS):
        ids = item_buffer(world, None, cam, profile, cull_back=False)
        shown = np.flatnonzero(np.isin(target, ids))
        result = culler.cull(cam)
        assert "pvs.fallbacks" not in result.stats
        missing = np.setdiff1d(target[shown], result.triangles)
        assert not len(missing), f"{mode}: dropped {missing} seen through the crease: {cam}"
        through += len(shown) > 0
    # the rasteriser did open the crease (else this test would check nothing)
    assert through >= 1


@pytest.fixture(scope="module")
def repaired(literal):
    from vismobile.partition import pvs_cells
    from vismobile.world.tjunctions import repair_tjunctions

    world, _ = repair_tjunctions(literal.crease_world())
    edges = [np.array([0.0, 4.0]), np.array([0.0, 0.2, 3.0]), np.array([0.0, 4.0, 5.0])]
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(pvs_cells, "paired_edges", lambda world, cells: edges)
        # the exact walk's sets (budget=none): the default budget may merge the room's cell
        # with the slab's and so hold the slab, as a coarsened set may
        return partition(world, "portal", depth=1, pvs="conservative", budget="none")


@pytest.mark.parametrize("mode", MODES)
def test_a_repaired_crease_is_sealed(kit, literal, repaired, mode):
    """After --repair tjunctions the crease is no crack and the bake seals its cells: the slab
    below is left out of the room's set, and no crease camera sees it (or anything dropped)."""
    world = repaired.world
    assert world.repair == "tjunctions"
    target = np.flatnonzero(world.centroids[:, 1] == 0.0)  # the slab's bottom, y = 0
    profile = kit.PROFILE if mode == "float64" else get_profile(kit.PROFILE, mode)
    options = {"arithmetic": "float64"} if mode == "float64" else device_options(profile)
    culler = Culler(repaired, "pvs,vfc", **options)
    left_out = 0
    for cam in literal.crease_cameras(profile, CAMERAS):
        ids = item_buffer(world, None, cam, profile, cull_back=False)
        result = culler.cull(cam)
        assert "pvs.fallbacks" not in result.stats
        missing = np.setdiff1d(ids[ids != SENTINEL], result.triangles)
        assert not len(missing), f"{mode}: dropped {missing}: {cam}"
        left_out += not np.isin(target, result.triangles).any()
    assert left_out == CAMERAS  # sealed: the slab is in no room camera's set

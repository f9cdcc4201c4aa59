"""Small worlds for the partition tests: a real mesh and two rooms joined by a doorway."""
import types
from functools import partial
from pathlib import Path

import numpy as np
import pytest

from vismobile.partition.base import gather_ranges
from vismobile.world.world import World

from vismobile.scenes.objects import PACKAGE_MODELS as MODELS


def quad(a, b, c, d):
    return [a, b, c, a, c, d]


def rooms_with_doorway():
    """Two 4 x 3 x 4 rooms side by side (x in [-4, 0] and [0, 4]); the wall x = 0 has a doorway
    z in [1.5, 2.5], y in [0, 2]."""
    v = []
    v += quad((-4, 0, 0), (4, 0, 0), (4, 0, 4), (-4, 0, 4))  # floor
    v += quad((-4, 3, 0), (-4, 3, 4), (4, 3, 4), (4, 3, 0))  # ceiling
    for x in (-4, 4):
        v += quad((x, 0, 0), (x, 3, 0), (x, 3, 4), (x, 0, 4))
    for z in (0, 4):
        v += quad((-4, 0, z), (4, 0, z), (4, 3, z), (-4, 3, z))
    v += quad((0, 0, 0), (0, 3, 0), (0, 3, 1.5), (0, 0, 1.5))  # middle wall, left of door
    v += quad((0, 0, 2.5), (0, 3, 2.5), (0, 3, 4), (0, 0, 4))  # right of door
    v += quad((0, 2, 1.5), (0, 3, 1.5), (0, 3, 2.5), (0, 2, 2.5))  # lintel
    vertices = np.array(v, dtype=float)
    return World(vertices, np.arange(len(v)).reshape(-1, 3), name="rooms")


@pytest.fixture(scope="session")
def cow():
    return World.from_obj(MODELS / "cow.obj.gz")


@pytest.fixture(scope="session")
def suzanne():
    return World.from_obj(MODELS / "suzanne.obj.gz")


@pytest.fixture(scope="session")
def rooms():
    return rooms_with_doorway()
def leaf_pairs(p):
    leaves = p.leaf_ids
    counts = p.ref_end[leaves] - p.ref_start[leaves]
    return np.repeat(leaves, counts), gather_ranges(p.tri_refs, p.ref_start[leaves], p.ref_end[leaves])


def assert_covered(p, overlaps, sample=400, seed=0):
    """Every triangle is referenced by a leaf whose box it overlaps (sampled for the oracle)."""
    leaf, tri = leaf_pairs(p)
    assert np.array_equal(np.unique(tri), np.arange(p.world.triangle_count))
    rng = np.random.default_rng(seed)
    slack = 1e-9 * np.ptp(p.world.extent, axis=0).max()
    corners = p.world.corners
    for t in rng.choice(p.world.triangle_count, min(sample, p.world.triangle_count), replace=False):
        boxes = p.node_bounds[leaf[tri == t]]
        assert any(overlaps(corners[t], b[0], b[1], slack) for b in boxes), t


def assert_exact(p, overlaps, sample=1500, seed=0):
    """No sampled leaf reference is to a triangle that misses the leaf's box."""
    leaf, tri = leaf_pairs(p)
    rng = np.random.default_rng(seed)
    slack = 1e-7 * np.ptp(p.world.extent, axis=0).max()
    corners = p.world.corners
    for k in rng.choice(len(tri), min(sample, len(tri)), replace=False):
        b = p.node_bounds[leaf[k]]
        assert overlaps(corners[tri[k]], b[0], b[1], slack), (leaf[k], tri[k])


@pytest.fixture(scope="session")
def checks(literal):
    """The oracle checks above, for test modules (importlib mode cannot import conftest)."""
    return types.SimpleNamespace(covered=partial(assert_covered, overlaps=literal.clip_overlaps),
                                 exact=partial(assert_exact, overlaps=literal.clip_overlaps),
                                 leaf_pairs=leaf_pairs)


@pytest.fixture(scope="module")
def crease(literal):
    """(world, view grid, grow, tol, room cell): the crease room's four view cells
    (test_pvs_cracks: the slab's bottom shows only through the far wall's T-junction crease)."""
    from vismobile.partition import pvs, pvs_cells

    world = literal.crease_world()
    edges = [np.array([0.0, 4.0]), np.array([0.0, 0.2, 3.0]), np.array([0.0, 4.0, 5.0])]
    grow = pvs.bake_grow(world)
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(pvs_cells, "paired_edges", lambda world, cells: edges)
        g = pvs_cells.view_grid(world, grow=grow)
    tol = pvs.TOLERANCE * float(np.ptp(world.extent, axis=0).max()) + grow
    room = int(np.flatnonzero(np.all(np.isclose(g["cell_bounds"],
                                                [[0, 0.2, 0], [4, 3, 4]]), axis=(1, 2)))[0])
    return world, g, grow, tol, room

"""tools/pvs_crack_share.py's measure: the bake's walk from a cell with the crack portals closed,
all open, and each open alone, on test_pvs_cracks's crease room (the slab's bottom shows only
through the T-junction crease of the far wall and the floor)."""
import importlib.util
from pathlib import Path

import numpy as np
import pytest

from vismobile.partition import pvs, pvs_cells, pvs_cracks

ROOT = Path(__file__).resolve().parents[2]


def _module(path, name):
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_a_crack_alone_adds_what_only_it_shows(literal):
    tool = _module(ROOT / "tools" / "pvs_crack_share.py", "pvs_crack_share")
    crease = _module(ROOT / "tests" / "culling" / "test_pvs_cracks.py", "crease_test")
    world = crease.crease_world(literal)
    edges = [np.array([0.0, 4.0]), np.array([0.0, 0.2, 3.0]), np.array([0.0, 4.0, 5.0])]
    grow = pvs.bake_grow(world)
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(pvs_cells, "paired_edges", lambda world, cells: edges)
        g = pvs_cells.view_grid(world, grow=grow)
    tol = pvs.TOLERANCE * float(np.ptp(world.extent, axis=0).max()) + grow
    walk, crack = tool.walker(world, g, grow, tol, pvs_cracks.CRACK_SLOPE)
    room = int(np.flatnonzero(np.all(np.isclose(g["cell_bounds"],
                                                [[0, 0.2, 0], [4, 3, 4]]), axis=(1, 2)))[0])
    ids = np.flatnonzero(crack)
    closed, everything, added = tool.crack_shares(walk, crack, room, ids)
    slab = np.arange(world.triangle_count - 2, world.triangle_count)
    assert len(ids) >= 1 and not closed[slab].any() and everything[slab].all()
    assert not (closed & ~everything).any()  # opening cracks only adds
    assert added.max() > 0 and added.sum() >= (everything & ~closed).sum() > 0

"""tools/pvs_crack_share.py's measure and tools/pvs_anchored.py's walk, on test_pvs_cracks's
crease room (the slab's bottom shows only through the T-junction crease of the far wall and the
floor): the bake's walk with the crack portals closed, all open and each open alone, and the
anchored walk, which must keep what the crease shows as the bake's does (the sequence walk of
tools/pvs_paths.py: tests/partition/test_pvs_sequences.py)."""
import importlib.util
import sys
from pathlib import Path

import numpy as np

from vismobile.partition import pvs_cracks

ROOT = Path(__file__).resolve().parents[2]


def _module(path, name):
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module  # numba's cache finds a kernel's module by name on load
    spec.loader.exec_module(module)
    return module


def test_a_crack_alone_adds_what_only_it_shows(crease):
    world, g, grow, tol, room = crease
    tool = _module(ROOT / "tools" / "pvs_crack_share.py", "pvs_crack_share")
    walk, crack = tool.walker(world, g, grow, tol, pvs_cracks.CRACK_SLOPE)
    ids = np.flatnonzero(crack)
    closed, everything, added = tool.crack_shares(walk, crack, room, ids)
    slab = np.arange(world.triangle_count - 2, world.triangle_count)
    assert len(ids) >= 1 and not closed[slab].any() and everything[slab].all()
    assert not (closed & ~everything).any()  # opening cracks only adds
    assert added.max() > 0 and added.sum() >= (everything & ~closed).sum() > 0


def test_the_anchored_walk_keeps_what_the_crease_shows(crease):
    world, g, grow, tol, room = crease
    tool = _module(ROOT / "tools" / "pvs_anchored.py", "pvs_anchored")
    bounds, start = g["cell_bounds"], g["cell_start"]
    pcells = g["portal_cells"]
    crack = np.zeros(len(pcells), dtype=bool)
    crack[len(pcells) - int(g["cracks"]):] = True
    common = (room, bounds[room, 0], bounds[room, 1], bounds, pcells,
              np.asarray(g["portal_vertices"], dtype=np.float64).reshape(-1, 4, 3),
              g["cell_portal_start"], g["cell_portals"], start[:-1], start[1:], g["cell_tris"],
              world.corners, grow, tol)
    sets = []
    for blocked in (np.zeros(len(crack), dtype=bool), crack.copy()):
        union = np.zeros(world.triangle_count, dtype=bool)
        anchored = np.zeros(world.triangle_count, dtype=bool)
        assert tool.pvs_kernels_flow(common, 10 ** 6, union, crack, blocked) >= 0
        assert tool.flow_anchored(*common, 10 ** 6, anchored, crack, pvs_cracks.CRACK_SLOPE,
                                  blocked) >= 0
        sets.append((union, anchored))
    slab = np.arange(world.triangle_count - 2, world.triangle_count)
    (union, anchored), (_, closed) = sets
    assert union[slab].all() and anchored[slab].all()  # cracks open: the slab kept
    assert not closed[slab].any()  # cracks closed: no line reaches it

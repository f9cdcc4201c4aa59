"""Per-sequence walks (partition/pvs_sequences.py): the joined cells tile the grid's, the walk keeps
what a crack shows, and the bake's sets (what both walks mark) are within the union walk's and
tighter on W1's repaired rooms."""
import numpy as np

from vismobile.files.loader import repaired
from vismobile.partition import pvs, pvs_cells, pvs_cracks
from vismobile.partition.pvs_sequences import (crack_flags, merge_cells, sequence_grid,
                                               sequences, walk_args)
from vismobile.scenes import build_world


def test_the_sequence_walk_keeps_what_the_crease_shows(crease):
    """Joined cells tile the grid's; the walk (exact, and widened after one arrival per
    crossing) keeps the slab with the cracks open, not without them or with no crack allowed."""
    world, g, grow, tol, room = crease
    joined = merge_cells(g, tol)
    boxes = joined["cell_bounds"]
    assert len(boxes) <= len(g["cell_bounds"])
    volume = lambda b: np.prod(b[:, 1] - b[:, 0], axis=1).sum()  # noqa: E731
    assert np.isclose(volume(boxes), volume(g["cell_bounds"]))
    inside = boxes[joined["member"]]  # every grid cell lies in its joined cell
    assert np.all(inside[:, 0] <= g["cell_bounds"][:, 0] + tol)
    assert np.all(inside[:, 1] >= g["cell_bounds"][:, 1] - tol)
    crack = crack_flags(joined)
    common = walk_args(world, joined, joined["member"][room], *g["cell_bounds"][room], grow, tol)
    slab = np.arange(world.triangle_count - 2, world.triangle_count)
    for exact in (np.iinfo(np.int64).max, 1):
        for blocked, kept in ((np.zeros(len(crack), dtype=bool), True), (crack.copy(), False)):
            visible = np.zeros(world.triangle_count, dtype=bool)
            assert sequences(*common, 10 ** 6, visible, crack, pvs_cracks.CRACK_SLOPE,
                             blocked, exact, -1) >= 0
            assert visible[slab].all() == kept and visible[slab].any() == kept
    capped = np.zeros(world.triangle_count, dtype=bool)  # no crack allowed: like closed
    sequences(*common, 10 ** 6, capped, crack, pvs_cracks.CRACK_SLOPE,
              np.zeros(len(crack), dtype=bool), np.iinfo(np.int64).max, 0)
    assert not capped[slab].any()


def test_w1_repaired_rooms_keep_less_and_nothing_the_union_walk_drops():
    """On W1 repaired (sealed cells), the bake's sets of its largest rooms are subsets of the
    union walk's, and together at most 3/4 of them (measured: 0.58x)."""
    world = repaired(build_world("w1"), "tjunctions")
    grow = pvs.bake_grow(world)
    tol = pvs.TOLERANCE * float(np.ptp(world.extent, axis=0).max()) + grow
    g = pvs_cells.view_grid(world, grow=grow, split=True, planes=True)
    bounds = g["cell_bounds"]
    rooms = np.argsort(-np.prod(bounds[:, 1] - bounds[:, 0], axis=1))[:4]
    union = pvs.bake_cells(world, g, rooms, grow, tol)
    tight = pvs.bake_cells(world, {**g, "joined": sequence_grid(g, tol)}, rooms, grow, tol)
    before = after = 0
    for (u, _, _, _), (t, _, _, _) in zip(union, tight):
        u, t = pvs.ids_of(u), pvs.ids_of(t)
        assert np.isin(t, u).all()
        before, after = before + len(u), after + len(t)
    assert after <= 0.75 * before

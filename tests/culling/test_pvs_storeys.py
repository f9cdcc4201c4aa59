"""A building's view cells split at the slab between its storeys (pvs_cells.building_edges).

Two storeys of two rooms each (faces in), a hollow slab y in [3, 3.2] with no opening, a
hollow wall x in [4, 4.2] on both storeys with a lined doorway (jambs, lintel, threshold) on
the ground floor, and a
finely tiled block in the first room (its triangles pull the quantile boundaries to it, as
W2's and W3's objects did: the view cells then spanned both storeys, and a ground-floor cell's
set held the upper floor).
"""
from __future__ import annotations

import numpy as np
import pytest

from vismobile.partition import partition
from vismobile.partition.pvs_codec import cell_mask, decode
from vismobile.world.tjunctions import repair_tjunctions

from .pvs_cases import (MODES, in_cell_cameras, in_face_plane, keeps_what_cameras_see,
                        near_boundary_cameras)

WIDE, DEEP, WALL, SLAB, HIGH = 8.2, 4.0, (4.0, 4.2), (3.0, 3.2), 6.2


def storeys_world(kit):
    rect, parts = kit.rect, []
    xs = [(0.0, WALL[0]), (WALL[1], WIDE)]
    for y0, y1 in ((0.0, SLAB[0]), (SLAB[1], HIGH)):
        for x0, x1 in xs:
            parts += [rect(1, y0, (0.0, DEEP), (x0, x1), 1),  # floor, ceiling
                      rect(1, y1, (0.0, DEEP), (x0, x1), -1),
                      rect(2, 0.0, (x0, x1), (y0, y1), 1), rect(2, DEEP, (x0, x1), (y0, y1), -1)]
        parts += [rect(0, 0.0, (y0, y1), (0.0, DEEP), 1), rect(0, WIDE, (y0, y1), (0.0, DEEP), -1)]
        for x, facing in ((WALL[0], -1), (WALL[1], 1)):  # the hollow wall, a doorway below
            if y0 == 0.0:
                parts += [rect(0, x, (0.0, 2.0), (0.0, 1.0), facing),
                          rect(0, x, (0.0, 2.0), (2.0, DEEP), facing),
                          rect(0, x, (2.0, y1), (0.0, DEEP), facing)]
            else:
                parts.append(rect(0, x, (y0, y1), (0.0, DEEP), facing))
    parts += [rect(2, 1.0, WALL, (0.0, 2.0), 1), rect(2, 2.0, WALL, (0.0, 2.0), -1),  # jambs
              rect(1, 2.0, (1.0, 2.0), WALL, -1),  # lintel, threshold
              rect(1, 0.0, (1.0, 2.0), WALL, 1)]
    # the block: 2 x 0.9 x 1 m in the first room, its top tiled 24 x 24
    grid = np.linspace(0.0, 1.0, 25)
    for i in range(24):
        for j in range(24):
            parts.append(rect(1, 0.9, (1.5 + grid[i], 1.5 + grid[i + 1]),
                              (1.0 + 2 * grid[j], 1.0 + 2 * grid[j + 1]), 1))
    for x, facing in ((1.0, -1), (3.0, 1)):
        parts.append(rect(0, x, (0.0, 0.9), (1.5, 2.5), facing))
    for z, facing in ((1.5, -1), (2.5, 1)):
        parts.append(rect(2, z, (1.0, 3.0), (0.0, 0.9), facing))
    world, _ = repair_tjunctions(kit.literal_world(parts, name="storeys"))
    return world


@pytest.fixture(scope="module")
def storeys(kit):
    return partition(storeys_world(kit), "portal", depth=1, pvs="conservative")


def upper_in_ground_cells(part) -> int:
    """Upper-storey triangles (above the slab) in the sets of the ground floor's room cells
    (the wall's inside, open to the slab's, sees the back of the upper floor, as it should)."""
    world, x = part.world, part.extras
    boxes = x["pvs_cells"]
    patterns, ids = decode(x, len(boxes), world.triangle_count)
    upper = world.bounds[:, 0, 1] >= SLAB[1] - 1e-9
    ground = np.flatnonzero((boxes[:, 1, 1] <= SLAB[0] + 1e-9)
                            & ((boxes[:, 1, 0] <= WALL[0] + 1e-9)
                               | (boxes[:, 0, 0] >= WALL[1] - 1e-9)))
    return int(sum((cell_mask(patterns, ids, c) & upper).sum() for c in ground))


def test_cells_split_at_both_slab_faces(storeys):
    ys = np.unique(storeys.extras["pvs_cells"][:, :, 1])
    assert np.isclose(ys, SLAB[0]).any() and np.isclose(ys, SLAB[1]).any()
    assert (storeys.extras["pvs_cells"][:, 1, 1] <= SLAB[0] + 1e-9).any()
    assert upper_in_ground_cells(storeys) == 0


@pytest.mark.parametrize("mode", MODES)
def test_storey_cells_keep_what_cameras_see(kit, storeys, mode):
    # inside, on a face, an edge, a corner, and just inside them
    cams = in_cell_cameras(storeys, 40, 3) + near_boundary_cameras(storeys, 24, 4)
    used = keeps_what_cameras_see(storeys, ("pvs,vfc",), cams, mode, kit.PROFILE)
    assert used == sum(not in_face_plane(storeys, cam) for cam in cams) > 0  # in one: fell back

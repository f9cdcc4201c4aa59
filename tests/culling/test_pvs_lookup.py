"""The `pvs` stage's bucketed view-cell lookup (culling/pvs_lookup.py) finds exactly the cells a
test of every box finds, each once, and tests fewer boxes."""
import numpy as np

from vismobile.culling.pvs_lookup import cell_index, find
from vismobile.geometry.boxes import boxes_contain_point


def test_buckets_find_what_testing_every_cell_finds():
    rng = np.random.default_rng(5)
    # quadtree-like squares of 2 and 4 on a 40 x 40 floor, some left out, plus odd boxes
    cells = []
    for x in range(0, 40, 4):
        for z in range(0, 40, 4):
            if rng.uniform() < 0.1:
                continue
            if rng.uniform() < 0.3:
                cells += [[[x + a, 1, z + b], [x + a + 2, 3, z + b + 2]] for a in (0, 2)
                          for b in (0, 2)]
            else:
                cells.append([[x, 1, z], [x + 4, 3, z + 4]])
    cells += [[[-5, 0, 3], [45, 2, 3.5]], [[7, 0, 7], [7, 9, 7]]]  # long and degenerate
    cells = np.array(cells, dtype=np.float64)
    index = cell_index(cells)
    tested = []
    for i in range(3000):
        eye = rng.uniform([-6, 0, -6], [46, 4, 46])
        if i % 3 == 0:  # on a boundary or corner of a cell
            c = cells[rng.integers(len(cells))]
            eye = np.where(rng.uniform(size=3) < 0.5, c[0], c[1])
        pad = float(rng.choice([0.0, 1e-9, 0.3, 2.5]))
        found, count = find(cells, *index, eye, pad)
        assert np.array_equal(found, np.flatnonzero(boxes_contain_point(cells, eye, pad))), eye
        tested.append(count)
    assert np.mean(tested) < len(cells) / 10

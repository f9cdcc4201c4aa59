"""Irregular grid: slab shares, automatic boundaries, exact references."""
import numpy as np
import pytest

import vismobile
from vismobile.partition import grid


def test_thesis_slab_shares(cow, checks):
    p = vismobile.partition(cow, "grid", slabs=((0.2, 0.2, 0.3, 0.3), 1, (0.5, 0.5)))
    low, high = cow.extent
    assert np.allclose(p.extras["grid_x"], low[0] + np.array([0, 0.2, 0.4, 0.7, 1.0]) * (high[0] - low[0]))
    assert len(p.extras["grid_y"]) == 2 and len(p.extras["grid_z"]) == 3
    assert p.depth == 1 and len(p.leaf_ids) <= 8
    checks.covered(p)
    checks.exact(p)


def test_auto_places_boundaries_by_triangle_count(cow, checks):
    p = vismobile.partition(cow, "grid", auto=True, cells=27)
    counts = p.ref_end[p.leaf_ids] - p.ref_start[p.leaf_ids]
    assert p.params["auto"] and len(p.leaf_ids) > 8
    # quantile slabs: no cell holds more than a fifth of the triangles
    assert counts.max() < cow.triangle_count / 5
    checks.covered(p)


def test_counts_are_uniform_slabs():
    edges = grid.slab_edges(0.0, 8.0, 4)
    assert np.array_equal(edges, [0, 2, 4, 6, 8])


@pytest.mark.parametrize("slabs", [((0.5, -0.5), 1, 1), ((), 1, 1), (1, 1), (0, 1, 1)])
def test_bad_slabs(cow, slabs):
    with pytest.raises(ValueError):
        grid.build(cow, slabs=slabs)

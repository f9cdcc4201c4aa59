"""Node boxes shrunk to their references (partition/tight.py): inside the partition's boxes, and
every point of every triangle still inside the shrunk box of a leaf that references it."""
import numpy as np
import pytest

import vismobile
from vismobile.partition.tight import shrunk_bounds


def _points_covered(p, boxes, leaf_pairs, per_triangle=6, seed=0):
    """Each triangle's corners and random points lie in the box of some leaf referencing it
    (within 1e-12 of the world's size: the random points are rounded off their plane)."""
    leaf, tri = leaf_pairs(p)
    rng = np.random.default_rng(seed)
    corners = p.world.corners
    weights = rng.dirichlet(np.ones(3), per_triangle)
    points = np.concatenate([corners, np.einsum("kj,tjd->tkd", weights, corners)], axis=1)
    eps = 1e-12 * np.ptp(p.world.extent, axis=0).max()
    inside = np.zeros((p.world.triangle_count, points.shape[1]), dtype=bool)
    for k in range(0, len(tri), 4096):  # per reference: which of its points its leaf holds
        t, b = tri[k:k + 4096], boxes[leaf[k:k + 4096]]
        q = points[t]
        hit = ((q >= b[:, None, 0] - eps) & (q <= b[:, None, 1] + eps)).all(axis=2)
        np.logical_or.at(inside, t, hit)
    return inside.all()


@pytest.mark.parametrize("name, spec", [("cow", "octree:5"), ("rooms", "octree:4"),
                                        ("suzanne", "grid:6"), ("cow", "kdtree"),
                                        ("rooms", "bsp")])
def test_shrunk_boxes_keep_every_point(request, checks, name, spec):
    p = vismobile.partition(request.getfixturevalue(name), spec)
    boxes = shrunk_bounds(p)
    assert boxes.shape == p.node_bounds.shape
    assert np.all(boxes[:, 0] >= p.node_bounds[:, 0]) and np.all(boxes[:, 1] <= p.node_bounds[:, 1])
    assert np.all(boxes[:, 0] <= boxes[:, 1])
    assert np.array_equal(boxes.astype(np.float32).astype(np.float64), boxes)  # as stored
    assert _points_covered(p, boxes, checks.leaf_pairs)
    inner = np.flatnonzero(p.child_count > 0)
    for node in inner[:200]:  # an inner box holds its children's
        kids = slice(p.first_child[node], p.first_child[node] + p.child_count[node])
        assert np.all(boxes[kids, 0] >= boxes[node, 0]) and np.all(boxes[kids, 1] <= boxes[node, 1])


def test_octree_cells_shrink_to_their_content(rooms):
    # The rooms' walls are planes: a leaf cell on one wall only shrinks to zero thickness
    # across it (the cells where walls meet keep their volume).
    p = vismobile.partition(rooms, "octree", depth=4)
    boxes = shrunk_bounds(p)
    leaves = p.leaf_ids
    cell = np.prod(np.ptp(p.node_bounds[leaves], axis=1), axis=1)
    shrunk = np.prod(np.ptp(boxes[leaves], axis=1), axis=1)
    assert np.all(shrunk <= cell) and np.all(cell > 0)
    assert (shrunk == 0).sum() > len(leaves) // 2 and shrunk.sum() < 0.5 * cell.sum()


def test_a_triangle_touching_a_leaf_within_the_slack_keeps_the_box():
    from vismobile.world.world import World

    # One triangle in the plane x = 0.5 between the two halves; both reference it.
    w = World(np.array([[0, 0, 0], [1, 0, 0], [0, 1, 1], [0.5, 0.2, 0.2], [0.5, 0.8, 0.2],
                        [0.5, 0.5, 0.8]], float), np.array([[0, 1, 2], [3, 4, 5]]))
    p = vismobile.partition(w, "octree", depth=1)
    boxes = shrunk_bounds(p)
    for leaf in p.leaf_ids:
        refs = p.tri_refs[p.ref_start[leaf]:p.ref_end[leaf]]
        if 1 in refs:  # the plane triangle's box (flat in x) clipped to the leaf
            assert boxes[leaf, 0, 0] <= 0.5 <= boxes[leaf, 1, 0]

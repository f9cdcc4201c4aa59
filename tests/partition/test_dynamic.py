"""partition/dynamic.py: the moving objects' BVH. Refitting only the nodes above the objects
that moved (refit_rows) gives the node boxes of a full refit, bit for bit, and its SAH cost up
to rounding; a tree that degrades is rebuilt."""
import numpy as np

from vismobile.partition.dynamic import DynamicBVH, _refit, refit_rows


def boxes_of(rng, m, spread=100.0, size=1.0):
    lo = rng.uniform(-spread, spread, (m, 3))
    return np.stack([lo, lo + rng.uniform(0.1, size, (m, 3))], axis=1)


def test_refit_rows_matches_a_full_refit():
    rng = np.random.default_rng(4)
    boxes = boxes_of(rng, 300)
    bvh = DynamicBVH(boxes)
    for _ in range(20):
        rows = np.unique(rng.integers(0, 300, 25))
        boxes[rows] += rng.normal(0.0, 3.0, (len(rows), 1, 3))
        cost, area_sum = refit_rows(boxes, rows, bvh.order, bvh.lo, bvh.hi, bvh.first,
                                    bvh.start, bvh.count, bvh.parent, bvh.leaf_of,
                                    bvh.node_count, bvh.area_sum)
        bvh.refitted(cost, area_sum, boxes)
        n = bvh.node_count
        lo, hi = bvh.lo[:n].copy(), bvh.hi[:n].copy()
        full = _refit(boxes, bvh.order, lo, hi, bvh.first, bvh.start, bvh.count, n)
        assert np.array_equal(lo, bvh.lo[:n]) and np.array_equal(hi, bvh.hi[:n])
        assert abs(full - bvh.cost) <= 1e-9 * full
        # every object's box lies in its leaf's and the root's
        leaf = bvh.leaf_of
        assert (bvh.lo[leaf] <= boxes[:, 0]).all() and (boxes[:, 1] <= bvh.hi[leaf]).all()
        assert (bvh.lo[0] == boxes[:, 0].min(axis=0)).all()


def test_a_degraded_tree_is_rebuilt():
    rng = np.random.default_rng(5)
    boxes = boxes_of(rng, 200)
    bvh = DynamicBVH(boxes)
    moved = boxes.copy()
    rows = np.arange(200)
    moved[rows] = boxes[rng.permutation(200)]  # every object jumps to another's place
    cost, area_sum = refit_rows(moved, rows, bvh.order, bvh.lo, bvh.hi, bvh.first, bvh.start,
                                bvh.count, bvh.parent, bvh.leaf_of, bvh.node_count,
                                bvh.area_sum)
    assert cost > bvh.rebuild * bvh.built_cost
    assert bvh.refitted(cost, area_sum, moved) and bvh.rebuilds == 1
    assert bvh.cost == bvh.built_cost  # rebuilt over the moved boxes
    assert (bvh.lo[bvh.leaf_of] <= moved[:, 0]).all()


def test_refit_rows_cost_of_a_flat_tree():
    """Every box one point (the root's area 0): each node weighs 1, as in a full refit."""
    boxes = np.zeros((37, 2, 3))
    bvh = DynamicBVH(boxes)
    rows = np.array([3, 20])
    cost, _ = refit_rows(boxes, rows, bvh.order, bvh.lo, bvh.hi, bvh.first, bvh.start,
                         bvh.count, bvh.parent, bvh.leaf_of, bvh.node_count, bvh.area_sum)
    n = bvh.node_count
    full = _refit(boxes, bvh.order, bvh.lo[:n].copy(), bvh.hi[:n].copy(), bvh.first,
                  bvh.start, bvh.count, n)
    assert cost == full == (n - 1) // 2 + 37

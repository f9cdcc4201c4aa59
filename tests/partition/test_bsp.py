"""BSP tree: balance rules, candidate scoring, straddlers on both sides, front-to-back order."""
import numpy as np
import pytest

import vismobile
from vismobile.partition import bsp


def test_cow_bsp_covers_and_planes(cow, checks):
    p = vismobile.partition(cow, "bsp", min_leaf=8, max_depth=24)
    checks.covered(p)
    planes = p.extras["split_planes"]
    assert np.all(np.isnan(planes[p.is_leaf])) and not np.isnan(planes[~p.is_leaf]).any()
    assert np.all(p.child_count[~p.is_leaf] == 2)
    # every interior plane is a triangle plane of the world
    n = planes[~p.is_leaf, :3]
    assert np.allclose(np.linalg.norm(n, axis=1), 1)
    # node bounds hold the AABBs of their referenced triangles
    leaf, tri = checks.leaf_pairs(p)
    tb = cow.bounds[tri]
    assert np.all(p.node_bounds[leaf, 0] <= tb[:, 0]) and np.all(p.node_bounds[leaf, 1] >= tb[:, 1])


def test_children_lie_on_their_side(cow):
    p = bsp.build(cow)
    planes = p.extras["split_planes"]
    corners = cow.corners
    for node in np.flatnonzero(~p.is_leaf)[::7][:60]:
        f = p.first_child[node]
        own = np.unique(p.tri_refs[p.ref_start[node]:p.ref_end[node]])
        d_own = corners[own] @ planes[node, :3] + planes[node, 3]
        for child, sign in ((f, 1), (f + 1, -1)):
            tris = np.unique(p.tri_refs[p.ref_start[child]:p.ref_end[child]])
            d = corners[tris] @ planes[node, :3] + planes[node, 3]
            # each referenced triangle reaches into the child's half-space (straddlers both)
            assert np.all((sign * d).max(axis=1) >= -1e-6)
            # and every triangle of the node reaching clearly into it is referenced there
            assert np.isin(own[(sign * d_own).max(axis=1) > 1e-6], tris).all()


def test_thesis_rule_stops_unbalanced_nodes(cow):
    coarse = bsp.build(cow, balance=(0.99, 1.01), rule="thesis")
    loose = bsp.build(cow, balance=(0.5, 2.0), rule="thesis")
    assert coarse.node_count < loose.node_count
    assert coarse.params["rule"] == "thesis"


def test_balanced_rule_splits_where_the_thesis_rule_stops(cow):
    thesis = bsp.build(cow, candidates=16, rule="thesis")
    balanced = bsp.build(cow, candidates=16)
    assert balanced.stats()["leaves"] > 2 * thesis.stats()["leaves"]
    # a balanced split gives both children at least min_leaf references
    sizes = balanced.ref_end[balanced.leaf_ids] - balanced.ref_start[balanced.leaf_ids]
    assert sizes.min() >= 8


def test_same_seed_same_tree_other_seed_other_tree(suzanne):
    a, b = bsp.build(suzanne, seed=4), bsp.build(suzanne, seed=4)
    for name in a.ARRAYS:
        assert np.array_equal(getattr(a, name), getattr(b, name))
    assert np.array_equal(a.extras["split_planes"], b.extras["split_planes"], equal_nan=True)
    c = bsp.build(suzanne, seed=5)
    assert not np.array_equal(a.extras["split_planes"], c.extras["split_planes"], equal_nan=True)


def test_side_counts_match_per_reference_classification():
    rng = np.random.default_rng(1)
    counts = np.array([1, 5, 40, 3, 130])
    owner = np.repeat(np.arange(len(counts)), counts)
    corners = rng.uniform(-1, 1, (len(owner), 3, 3))
    corners[::9] = corners[::9] * [1, 0, 1]  # some triangles lie in the plane y = 0
    normals = rng.normal(size=(len(counts), 6, 3))
    normals[:, 0] = [0, 1, 0]
    normals /= np.linalg.norm(normals, axis=2, keepdims=True)
    planes = np.concatenate([normals, rng.uniform(-0.3, 0.3, (len(counts), 6, 1))], axis=2)
    planes[:, 0, 3] = 0
    front, back = bsp.side_counts(corners, owner, counts, planes, 1e-9)
    f, b = bsp._classify(corners, planes[owner], 1e-9)
    assert np.array_equal(front, np.stack([f[owner == i].sum(0) for i in range(len(counts))]))
    assert np.array_equal(back, np.stack([b[owner == i].sum(0) for i in range(len(counts))]))
    assert front[:, 0].sum() >= len(owner[::9])  # in-plane triangles count as front


def test_choose_rules():
    counts = np.array([20, 20, 20])
    # candidates: (front, back) -> node 0: in range (10, 10) and lopsided (18, 2);
    # node 1: only lopsided; node 2: nothing separates
    front = np.array([[10, 18], [16, 17], [20, 0]])
    back = np.array([[10, 2], [4, 3], [0, 20]])
    args = ((0.8, 1.25), 2.0, 2)
    assert list(bsp.choose(front, back, counts, "thesis", *args)) == [0, -1, -1]
    assert list(bsp.choose(front, back, counts, "balanced", *args)) == [0, 0, -1]
    # a child below min_leaf disqualifies a balanced split
    assert list(bsp.choose(front, back, counts, "balanced", (0.8, 1.25), 2.0, 5)) == [0, -1, -1]
    # mostly straddlers does not pay off
    assert bsp.choose(np.array([[2]]), np.array([[2]]), np.array([20]), "balanced", *args)[0] == -1


def test_unknown_rule(cow):
    with pytest.raises(ValueError, match="BSP rule"):
        bsp.build(cow, rule="best")


def test_front_to_back_order_is_correct(cow):
    p = bsp.build(cow)
    planes = p.extras["split_planes"]
    rng = np.random.default_rng(3)
    low, high = cow.extent
    for eye in rng.uniform(low - 2, high + 2, (20, 3)):
        order = bsp.front_to_back(p, eye)
        assert sorted(order) == list(p.leaf_ids)
        position = np.empty(p.node_count, dtype=np.int64)
        position[order] = np.arange(len(order))
        # first/last position of each subtree's leaves, bottom-up
        first = np.where(p.is_leaf, position, np.iinfo(np.int64).max)
        last = np.where(p.is_leaf, position, -1)
        for k in range(p.depth, 0, -1):
            nodes = np.arange(p.level_start[k], p.level_start[k + 1])
            parents = np.repeat(np.arange(p.node_count), p.child_count)[nodes - 1]
            np.minimum.at(first, parents, first[nodes])
            np.maximum.at(last, parents, last[nodes])
        inner = np.flatnonzero(~p.is_leaf)
        front = planes[inner, :3] @ eye + planes[inner, 3] >= 0
        near = np.where(front, p.first_child[inner], p.first_child[inner] + 1)
        far = np.where(front, p.first_child[inner] + 1, p.first_child[inner])
        assert np.all(last[near] < first[far])


def test_single_triangle_is_one_leaf():
    from vismobile.world.world import World

    w = World(np.eye(3), np.array([[0, 1, 2]]))
    p = bsp.build(w)
    assert p.node_count == 1 and list(bsp.front_to_back(p, [5, 5, 5])) == [0]

"""BSP tree: balance rule, straddlers on both sides, front-to-back order from any eye."""
import numpy as np

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
    for node in np.flatnonzero(~p.is_leaf)[:50]:
        f = p.first_child[node]
        for child, sign in ((f, 1), (f + 1, -1)):
            tris = p.tri_refs[p.ref_start[child]:p.ref_end[child]]
            d = corners[tris] @ planes[node, :3] + planes[node, 3]
            # each referenced triangle reaches into the child's half-space (straddlers both)
            assert np.all((sign * d).max(axis=1) >= -1e-6)


def test_balance_rule_stops_unbalanced_nodes(cow):
    coarse = bsp.build(cow, balance=(0.99, 1.01))
    loose = bsp.build(cow, balance=(0.5, 2.0))
    assert coarse.node_count < loose.node_count


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
    from vismobile.world import World

    w = World(np.eye(3), np.array([[0, 1, 2]]))
    p = bsp.build(w)
    assert p.node_count == 1 and list(bsp.front_to_back(p, [5, 5, 5])) == [0]

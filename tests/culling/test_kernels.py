"""The compiled kernels against plain numpy references: frustum walk, back-face test; empty
inputs on purpose (the distinct gather: test_gather.py)."""
import numpy as np
import pytest

from vismobile.world.camera import Camera
from vismobile.culling.kernels import frustum_walk, inner_records, node_records
from vismobile.culling.tree import Tree


def test_frustum_walk_keeps_every_triangle_in_the_frustum(w1_octree):
    tree = Tree(w1_octree)
    world = w1_octree.world
    rng = np.random.default_rng(5)
    low, high = world.extent
    for _ in range(6):
        cam = Camera(rng.uniform(low, high), yaw=rng.uniform(0, 360), pitch=rng.uniform(-40, 40),
                     aspect=0.75)
        planes = cam.frustum_planes()
        nodes, visited, tests, culled, *_ = tree.walk(np.zeros(1, np.int64),
                                                   np.zeros(1, np.int64), planes[None])
        sent = np.unique(tree.refs(nodes))
        # Oracle: triangles with a sampled point (barycentric grid) inside every plane.
        bary = np.array([(i, j, 8 - i - j) for i in range(9) for j in range(9 - i)]) / 8.0
        points = np.einsum("sk,tkj->tsj", bary, world.corners)  # (T, S, 3)
        dist = points @ planes[:, :3].T + planes[:, 3]  # (T, S, 6)
        inside = np.flatnonzero((dist >= 0).all(axis=2).any(axis=1))
        assert len(inside)
        assert np.all(np.isin(inside, sent))
        assert visited >= len(nodes) and tests >= visited


def test_frustum_walk_from_no_roots_accepts_nothing():
    lo = np.zeros((1, 3))
    out = np.empty(4, dtype=np.int64)
    stack = [np.empty(4, dtype=np.int64) for _ in range(3)]
    box, links = node_records(np.stack([lo, lo + 1.0], axis=1), np.full(1, -1),
                              np.zeros(1, np.int64), np.ones(1, bool))
    inner = inner_records(box, links)
    count, visited, *_ = frustum_walk(box, links, np.zeros(1, np.int64), 64,
                                      inner, inner.view(links.dtype), True,
                                      np.zeros(0, np.int64), np.zeros(0, np.int64),
                                      np.zeros((1, 6, 4)), 0.0, out, *stack)
    assert count == 0 and visited == 0


def test_node_records_hold_the_bounds_exactly(w1_octree):
    tree = Tree(w1_octree)
    box, links = node_records(tree.node_bounds, tree.first_child, tree.child_count, tree.nonempty)
    assert box.dtype == np.float32  # octree cells are float32 numbers
    assert np.array_equal(box[:, :6].astype(np.float64), tree.node_bounds.reshape(-1, 6))
    assert np.array_equal(links[:, 6], tree.first_child)
    assert np.array_equal(links[:, 7], np.where(tree.nonempty, tree.child_count, -1))
    odd = tree.node_bounds.copy()
    odd[0, 0, 0] -= 1e-12  # not a float32: the records widen to float64, exact again
    box64, links64 = node_records(odd, tree.first_child, tree.child_count, tree.nonempty)
    assert box64.dtype == np.float64 and np.array_equal(box64[:, :6], odd.reshape(-1, 6))
    # the walk reads both the same way
    cam = Camera((5.0, 1.7, 5.0), yaw=30.0, pitch=-10.0, aspect=0.75)
    planes = cam.frustum_planes()[None]
    scratch = [np.empty(tree.node_count + 1, dtype=np.int64) for _ in range(4)]
    results = []
    for b, l in ((box, links), (box64, links64)):
        inner = inner_records(b, l)
        count, *counters = frustum_walk(b, l, tree.read_size, -1, inner, inner.view(l.dtype),
                                        True, np.zeros(1, np.int64),
                                        np.zeros(1, np.int64), planes, tree.tol, *scratch)
        results.append((scratch[0][:count].copy(), counters))
    assert np.array_equal(results[0][0], results[1][0]) and results[0][1] == results[1][1]
    assert len(results[0][0]) > 0


def _subtree_bounds(tree):
    """Reference for inner_records' cover: per node, the least hi and greatest lo of the non-empty
    nodes strictly below it."""
    n = tree.node_count
    parent = np.full(n, -1)
    for node in range(n):
        first, count = tree.first_child[node], tree.child_count[node]
        parent[first:first + count] = node
    least = np.full((n, 3), np.inf)
    most = np.full((n, 3), -np.inf)
    for node in np.flatnonzero(tree.nonempty):
        a = parent[node]
        while a >= 0:
            least[a] = np.minimum(least[a], tree.node_bounds[node, 1])
            most[a] = np.maximum(most[a], tree.node_bounds[node, 0])
            a = parent[a]
    return least, most


@pytest.mark.parametrize("kind", ["octree", "bsp", "grid"])
def test_inner_records_bound_every_node_below(kit, kind):
    tree = Tree(kit.structure("w1", kind))
    cover = inner_records(tree._box, tree._links)
    least, most = _subtree_bounds(tree)
    inner = tree.child_count > 0
    assert len(cover) == np.flatnonzero(inner)[-1] + 1
    assert np.array_equal(cover[:, :3].astype(np.float64), least[:len(cover)])
    assert np.array_equal(cover[:, 3:6].astype(np.float64), most[:len(cover)])


@pytest.mark.parametrize("kind", ["octree", "bsp", "grid"])
def test_covered_walk_sends_the_same_leaves_from_fewer_nodes(kit, kind):
    part = kit.structure("w1", kind)
    tree = Tree(part)
    root = np.zeros(1, np.int64)
    covered_any = 0
    for cam in kit.random_cameras(part, 12, seed=11):
        planes = cam.frustum_planes()[None]
        exact, visited, tests, culled, _, none = tree.walk(root, root, planes)
        nodes, fewer, _, fewer_culled, _, covered = tree.walk(root, root, planes, covering=True)
        assert none == 0 and covered <= len(nodes)
        leaves = tree.leaf_order[tree.leaves_under(exact)]
        leaves_now = tree.leaf_order[tree.leaves_under(nodes)]
        nonempty = tree.nonempty
        assert np.array_equal(np.sort(leaves[nonempty[leaves]]),
                              np.sort(leaves_now[nonempty[leaves_now]]))
        assert np.array_equal(tree.distinct_refs(exact), tree.distinct_refs(nodes))
        assert fewer <= visited and fewer_culled == culled and len(nodes) <= len(exact)
        covered_any += covered
    assert covered_any or kind == "grid"  # it does accept covered nodes (a grid is one level)


def test_octant_leaves_are_tested_from_their_parent_with_the_same_decisions(w1_octree):
    tree = Tree(w1_octree)
    inner = inner_records(tree._box, tree._links)
    ints = inner.view(tree._links.dtype)
    octants = np.flatnonzero(ints[:, 7] == 1)
    assert len(octants)  # an octree's last inner level has octant leaves
    for node in octants[:50]:  # the rule rebuilds every child's box exactly
        first, n = tree.first_child[node], tree.child_count[node]
        for k in range(n):
            code = (int(ints[node, 6]) >> (3 * k)) & 7
            upper = np.array([(code >> i) & 1 for i in range(3)], bool)
            lo = np.where(upper, inner[node, 8:11], tree._box[node, :3])
            hi = np.where(upper, tree._box[node, 3:6], inner[node, 11:14])
            assert np.array_equal(lo, tree._box[first + k, :3])
            assert np.array_equal(hi, tree._box[first + k, 3:6])
    plain = inner.copy()
    plain.view(ints.dtype)[:, 7] = 0  # no octant leaves: every child read from its record
    scratch = [np.empty(tree.node_count + 1, dtype=np.int64) for _ in range(4)]
    for cam in random_walk_cameras(w1_octree):
        planes = cam.frustum_planes()[None]
        results = []
        for records in (inner, plain):
            for covering in (False, True):
                count, *counters = frustum_walk(
                    tree._box, tree._links, tree.read_size, -1, records,
                    records.view(ints.dtype), covering, np.zeros(1, np.int64),
                    np.zeros(1, np.int64), planes, tree.tol, *scratch)
                results.append((scratch[0][:count].copy(), counters))
        for a, b in ((0, 2), (1, 3)):
            assert np.array_equal(results[a][0], results[b][0])
            assert results[a][1] == results[b][1]


def random_walk_cameras(part, count=8, seed=3):
    rng = np.random.default_rng(seed)
    low, high = part.world.extent
    return [Camera(rng.uniform(low, high), yaw=rng.uniform(0, 360), pitch=rng.uniform(-40, 40),
                   aspect=0.75) for _ in range(count)]

"""kd-tree: binned SAH and median splits, straddlers on both sides, tight cells, automatic stop."""
import numpy as np
import pytest

import vismobile
from vismobile.partition import kdtree, load_partition, save_partition
from vismobile.partition.spec import format_spec, parse_spec
from vismobile.world.world import World


def test_cow_kdtree_covers_every_point_of_every_triangle(cow, checks):
    p = vismobile.partition(cow, "kdtree")
    checks.covered(p)
    axis = p.extras["split_axis"]
    assert np.all((axis >= 0) == ~p.is_leaf) and np.all(p.child_count[~p.is_leaf] == 2)
    assert np.isnan(p.extras["split_value"][p.is_leaf]).all()
    # Points sampled on triangles lie in the box of a leaf that references the triangle.
    leaf, tri = checks.leaf_pairs(p)
    rng = np.random.default_rng(1)
    corners = cow.corners
    for t in rng.choice(cow.triangle_count, 300, replace=False):
        w = rng.dirichlet(np.ones(3), 8)
        points = w @ corners[t]
        boxes = p.node_bounds[leaf[tri == t]]
        inside = ((points[:, None] >= boxes[None, :, 0]) & (points[:, None] <= boxes[None, :, 1])
                  ).all(axis=2).any(axis=1)
        assert inside.all(), t


def test_children_split_their_parent_at_the_plane(cow):
    p = kdtree.build(cow)
    axis, value = p.extras["split_axis"], p.extras["split_value"]
    for node in np.flatnonzero(~p.is_leaf)[::5][:80]:
        a, v = axis[node], value[node]
        left, right = p.first_child[node], p.first_child[node] + 1
        assert p.node_bounds[left, 1, a] <= np.nextafter(np.float32(v), np.float32(np.inf))
        assert p.node_bounds[right, 0, a] >= np.nextafter(np.float32(v), np.float32(-np.inf))
        for child in (left, right):  # children inside the parent's box
            assert np.all(p.node_bounds[child, 0] >= p.node_bounds[node, 0])
            assert np.all(p.node_bounds[child, 1] <= p.node_bounds[node, 1])


def test_sah_stops_on_its_own_and_the_ratio_trades_nodes_for_leaf_size(cow):
    cheap, dear = kdtree.build(cow, ratio=1.0), kdtree.build(cow, ratio=64.0)
    assert dear.node_count < cheap.node_count
    assert dear.stats()["max_leaf_refs"] > cheap.stats()["max_leaf_refs"]
    assert cheap.depth < kdtree.auto_depth(cow.triangle_count)  # SAH stopped, not the guard
    one = World(np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0.0]]), np.array([[0, 1, 2]]), name="one")
    assert vismobile.partition(one, "kdtree").node_count == 1


def test_median_split_respects_min_leaf_and_max_depth(cow, checks):
    p = vismobile.partition(cow, "kdtree", split="median", min_leaf=32, max_depth=6)
    checks.covered(p)
    assert p.depth <= 6
    inner = ~p.is_leaf
    assert np.all(p.ref_end[inner] - p.ref_start[inner] > 32)


def test_spec_round_trip_and_bad_parameters():
    spec = "kdtree:split=median,max_depth=12,min_leaf=8"
    kind, params = parse_spec(spec)
    assert (kind, params) == ("kdtree", {"split": "median", "max_depth": 12, "min_leaf": 8})
    assert parse_spec("kdtree:20") == ("kdtree", {"max_depth": 20})
    assert format_spec(*parse_spec("kdtree:20,ratio=4.0")) == "kdtree:20,ratio=4.0"
    world = World(np.eye(3), np.array([[0, 1, 2]]), name="t")
    for bad in ({"split": "middle"}, {"bins": 1}, {"ratio": -1.0}, {"min_leaf": 0},
                {"max_depth": 99}, {"bins": 2.5}, {"depth": 3}):
        with pytest.raises(ValueError):
            vismobile.partition(world, "kdtree", **bad)


def test_vmp_round_trip(cow, tmp_path):
    p = vismobile.partition(cow, "kdtree")
    save_partition(p, tmp_path / "k.vmp")
    q = load_partition(tmp_path / "k.vmp")
    assert q.kind == "kdtree" and q.params == p.params
    for name in p.ARRAYS:
        assert np.array_equal(getattr(p, name), getattr(q, name))
    assert np.array_equal(p.extras["split_axis"], q.extras["split_axis"])

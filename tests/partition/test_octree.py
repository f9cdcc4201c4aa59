"""Octree: exact references, full coverage, validated depth, no empty children."""
import numpy as np
import pytest

import vismobile
from vismobile.partition import octree


def test_cow_depth5_covers_and_is_exact(cow, checks):
    p = vismobile.partition(cow, "octree", depth=5)
    assert p.depth == 5 and p.params == {"depth": 5}
    checks.covered(p)
    checks.exact(p)


def test_empty_children_not_stored(suzanne):
    p = octree.build(suzanne, 3)
    inner = np.flatnonzero(p.child_count > 0)
    assert np.all(p.ref_end - p.ref_start > 0)
    assert p.child_count[inner].max() <= 8 and len(p.leaf_ids) < 8 ** 3
    # all leaves sit at the deepest level, and cells halve their parent
    assert np.all(p.node_levels()[p.leaf_ids] == 3)
    child = p.first_child[0]
    assert np.allclose(np.ptp(p.node_bounds[child], axis=0), np.ptp(p.node_bounds[0], axis=0) / 2,
                       rtol=1e-6)


@pytest.mark.parametrize("depth", [0, 9, 2.5, "5", True])
def test_bad_depth_is_a_clear_error(suzanne, depth):
    with pytest.raises(ValueError, match="octree depth"):
        vismobile.partition(suzanne, "octree", depth=depth)


def test_unknown_kind_and_parameter(suzanne):
    with pytest.raises(ValueError, match="unknown partition kind"):
        vismobile.partition(suzanne, "quadtree")
    with pytest.raises(ValueError, match="unknown parameter"):
        vismobile.partition(suzanne, "octree", dept=3)


def test_triangle_on_cell_boundary_is_in_both_cells():
    from vismobile.world.world import World

    # One triangle lies in the plane x = 0.5 that splits the root: both halves reference it.
    w = World(np.array([[0, 0, 0], [1, 0, 0], [0, 1, 1], [0.5, 0.2, 0.2], [0.5, 0.8, 0.2],
                        [0.5, 0.5, 0.8]], float), np.array([[0, 1, 2], [3, 4, 5]]))
    p = octree.build(w, 1)
    owners = [leaf for leaf in p.leaf_ids if 1 in p.tri_refs[p.ref_start[leaf]:p.ref_end[leaf]]]
    lows = {p.node_bounds[leaf][0, 0] < 0.5 for leaf in owners}
    assert lows == {True, False}


def test_layout_levels_and_ranges(cow):
    p = octree.build(cow, 4)
    p.check()
    for k in range(p.depth):
        nodes = np.arange(p.level_start[k], p.level_start[k + 1])
        inner = nodes[p.child_count[nodes] > 0]
        # children of a level fill the next level in order
        assert p.first_child[inner[0]] == p.level_start[k + 1]
        # a node's range is the union of its children's ranges
        last = p.first_child[inner] + p.child_count[inner] - 1
        assert np.array_equal(p.ref_start[inner], p.ref_start[p.first_child[inner]])
        assert np.array_equal(p.ref_end[inner], p.ref_end[last])


def _numpy_subdivide(world, depth):
    """The octree's decisions written with whole-array numpy (the build before numba): per
    level, the octants each triangle's box meets, the exact test where it meets several."""
    from vismobile.geometry.triangle_box import triangles_overlap_boxes

    boxes = world.extent[None].astype(np.float64)
    node = np.zeros(world.triangle_count, dtype=np.int64)
    tri = np.arange(world.triangle_count, dtype=np.int64)
    levels = []
    for _ in range(depth):
        centre = boxes.mean(axis=1)[node]
        tb = world.bounds[tri]
        low_ok = tb[:, 0] <= centre
        high_ok = (tb[:, 1] >= centre) & (boxes[node, 1] > boxes[node, 0])
        cand = np.where(octree.OCTANT_BITS[None], high_ok[:, None], low_ok[:, None]).all(axis=2)
        keep = cand & (cand.sum(axis=1) == 1)[:, None]
        pair, octant = np.nonzero(cand & (cand.sum(axis=1) > 1)[:, None])
        bits = octree.OCTANT_BITS[octant]
        lo = np.where(bits, centre[pair], boxes[node[pair], 0])
        hi = np.where(bits, boxes[node[pair], 1], centre[pair])
        keep[pair, octant] = triangles_overlap_boxes(world.corners[tri[pair]], lo, hi)
        pair, octant = np.nonzero(keep)
        key, tri = node[pair] * 8 + octant, tri[pair]
        order = np.lexsort((tri, key))
        child_key, node = np.unique(key[order], return_inverse=True)
        tri = tri[order]
        boxes = octree.child_boxes(boxes, child_key // 8, (child_key % 8).astype(np.int8))
        levels.append((boxes, child_key // 8))
    return levels, node, tri


@pytest.mark.parametrize("name, depth", [("cow", 6), ("suzanne", 5)])
def test_compiled_levels_match_the_numpy_formulation(request, name, depth):
    world = request.getfixturevalue(name)
    want, node, tri = _numpy_subdivide(world, depth)
    tris = np.arange(world.triangle_count, dtype=np.int64)
    got, (got_node, got_tri) = octree.subdivide(world, world.extent[None].astype(np.float64),
                                                np.zeros_like(tris), tris, depth)
    assert len(got) == depth
    for (boxes, parent, _), (want_boxes, want_parent) in zip(got, want):
        assert np.array_equal(boxes, want_boxes) and np.array_equal(parent, want_parent)
    assert np.array_equal(got_node, node) and np.array_equal(got_tri, tri)
    assert len(tri) > world.triangle_count  # some triangles straddle cells: the test ran


def test_a_level_refuses_unsorted_references(suzanne):
    from vismobile.partition.layout import check_references
    from vismobile.partition.octree_split import split_level

    boxes = np.repeat(suzanne.extent[None].astype(np.float64), 2, axis=0)
    node = np.array([1, 0], dtype=np.int64)  # box 1's reference before box 0's
    tri = np.array([0, 1], dtype=np.int64)
    with pytest.raises(ValueError, match="sorted by box"):
        split_level(boxes, node, tri, suzanne.vertices, suzanne.triangles, check_references, 1)

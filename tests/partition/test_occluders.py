"""Each node's largest triangles (occlusion's candidate lists) against a numpy reference."""
import numpy as np
import pytest

from vismobile.partition import partition
from vismobile.partition.occluders import CANDIDATES, candidate_lists


@pytest.mark.parametrize("k", [1, CANDIDATES, 9])
def test_node_lists_are_each_subtrees_largest_triangles(w1, k):
    part = partition(w1, "octree", depth=4)
    lists = candidate_lists(part.first_child, part.child_count, part.ref_start, part.ref_end,
                            part.tri_refs, w1.vertices, w1.triangles, k)
    assert lists.shape == (part.node_count, k)
    for node in range(part.node_count):
        ids = np.unique(part.tri_refs[part.ref_start[node]:part.ref_end[node]])
        ids = ids[w1.areas[ids] > 0]
        expect = ids[np.lexsort((ids, -w1.areas[ids]))][:k]  # largest first, ties by id
        got = lists[node]
        assert np.array_equal(got[:len(expect)], expect) and (got[len(expect):] == -1).all()
    # the j largest are the first j columns of the k largest (a stored list serves any j <= k)
    for j in range(1, k):
        assert np.array_equal(lists[:, :j], candidate_lists(
            part.first_child, part.child_count, part.ref_start, part.ref_end, part.tri_refs,
            w1.vertices, w1.triangles, j))
    # float32 vertices (a mapped world) give the lists of the same values in float64
    f32 = w1.vertices.astype(np.float32)
    assert np.array_equal(candidate_lists(part.first_child, part.child_count, part.ref_start,
                                          part.ref_end, part.tri_refs, f32, w1.triangles, k),
                          candidate_lists(part.first_child, part.child_count, part.ref_start,
                                          part.ref_end, part.tri_refs, f32.astype(np.float64),
                                          w1.triangles, k))

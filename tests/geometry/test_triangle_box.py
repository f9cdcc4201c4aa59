"""triangles_overlap_boxes against an independent clipping oracle (literal.clip_overlaps)."""
import numpy as np
from hypothesis import given, settings, strategies as st

from vismobile.geometry.triangle_box import triangles_overlap_boxes


def test_touching_face_is_kept():
    tri = np.array([[[1.0, 0.2, 0.2], [2.0, 0.5, 0.5], [1.0, 0.8, 0.3]]])
    assert triangles_overlap_boxes(tri, [0, 0, 0], [1, 1, 1])[0]


def test_separated_by_edge_axis_is_rejected():
    # AABBs overlap but the triangle passes beside the box corner.
    tri = np.array([[[1.6, -0.5, 0.0], [-0.5, 1.6, 0.0], [1.6, 1.6, 0.0]]])
    tri[..., 2] = 0.5
    tri2 = np.array([[[2.2, 0.0, -1.0], [0.0, 2.2, -1.0], [0.0, 2.2, 2.0]]])
    got = triangles_overlap_boxes(np.concatenate([tri, tri2]), [0, 0, 0], [1, 1, 1])
    assert list(got) == [True, False]


def test_empty_input():
    assert triangles_overlap_boxes(np.zeros((0, 3, 3)), np.zeros((0, 3)), np.zeros((0, 3))).shape == (0,)


def test_degenerate_box_and_triangle():
    flat_box = triangles_overlap_boxes([[[0, 0, 0], [1, 0, 0], [0, 1, 0]]], [0.2, 0.2, 0], [0.3, 0.3, 0])
    line_tri = triangles_overlap_boxes([[[0, 0, 0], [1, 1, 1], [2, 2, 2]]], [3, 3, 3], [4, 4, 4])
    assert flat_box[0] and not line_tri[0]


coords = st.floats(-2, 2, allow_nan=False, width=32)


@settings(max_examples=400, deadline=None)
@given(st.lists(coords, min_size=9, max_size=9), st.lists(coords, min_size=3, max_size=3),
       st.lists(st.floats(0, 1.5, width=32), min_size=3, max_size=3))
def test_agrees_with_clipping_oracle(literal, tri, lo, size):
    tri = np.array(tri, dtype=float).reshape(1, 3, 3)
    lo = np.array(lo, dtype=float)
    hi = lo + np.array(size, dtype=float)
    got = triangles_overlap_boxes(tri, lo, hi)[0]
    scale = 1e-6
    if literal.clip_overlaps(tri[0], lo, hi, -scale):  # clearly overlapping: must say so
        assert got
    if not literal.clip_overlaps(tri[0], lo, hi, scale):  # clearly apart: must say so
        assert not got


def test_random_batch_matches_oracle(literal):
    rng = np.random.default_rng(7)
    tris = rng.uniform(-2, 2, (2000, 3, 3))
    lo = rng.uniform(-1, 0.5, (2000, 3))
    hi = lo + rng.uniform(0.1, 1.0, (2000, 3))
    got = triangles_overlap_boxes(tris, lo, hi)
    want = np.array([literal.clip_overlaps(t, a, b) for t, a, b in zip(tris, lo, hi)])
    assert np.array_equal(got, want)
    assert 0.2 < want.mean() < 0.8


def test_compiled_pair_test_has_the_vectorised_bits():
    # The octree build's per-pair test (triangle_box_one) must give the vectorised answer
    # exactly, slack included: dyadic coordinates make faces, edges and corners touch often.
    from vismobile.geometry.triangle_box_one import triangle_overlaps_box

    rng = np.random.default_rng(11)
    count = 20000
    tris = rng.integers(-6, 7, (count, 3, 3)) / 4.0
    lo = rng.integers(-8, 5, (count, 3)) / 4.0
    hi = lo + rng.integers(0, 9, (count, 3)) / 4.0  # zero-extent boxes included
    tris[: count // 2] += rng.normal(0, 1e-9, (count // 2, 3, 3))  # grazing within the slack
    want = triangles_overlap_boxes(tris, lo, hi)
    got = np.array([triangle_overlaps_box(*t.ravel(), a, b) for t, a, b in zip(tris, lo, hi)])
    assert np.array_equal(got, want)
    assert 0.1 < want.mean() < 0.9

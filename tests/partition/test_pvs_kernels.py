"""The PVS bake's predicates: every separating plane kept lets through every line from the
first set through the second (the bake's soundness rests on it), and clipping keeps every
point on the planes' positive sides."""
import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from vismobile.partition.pvs_kernels import box_vertices, clip_polygon, separators


@settings(max_examples=80)
@given(seed=st.integers(0, 2 ** 32 - 1), box_b=st.booleans())
def test_lines_through_both_sets_stay_on_the_positive_side(seed, box_b):
    rng = np.random.default_rng(seed)
    lo = rng.uniform(-5, 5, 3)
    a = np.empty((8, 3))
    box_vertices(lo, lo + rng.uniform(0.0, 3.0, 3), a)
    if box_b:
        blo = rng.uniform(-8, 8, 3)
        b = np.empty((8, 3))
        box_vertices(blo, blo + rng.uniform(0.0, 2.0, 3), b)
        nb = 8
    else:  # an axis-aligned rectangle somewhere
        axis = rng.integers(3)
        c = rng.uniform(-8, 8, 3)
        u, v = (axis + 1) % 3, (axis + 2) % 3
        du, dv = rng.uniform(0.05, 2.0, 2)
        b = np.tile(c, (4, 1))
        b[:, u] += [-du, du, du, -du]
        b[:, v] += [-dv, -dv, dv, dv]
        nb = 4
    planes = np.empty((192, 4))
    count = separators(a, 8, True, b, nb, planes, 0, box_b)
    # points of the convex sets: random convex combinations of their vertices
    wa = rng.dirichlet(np.ones(8), 400)
    wb = rng.dirichlet(np.ones(nb), 400)
    pa, pb = wa @ a, wb @ b
    t = 1.0 + rng.exponential(3.0, (400, 1))
    x = pa + t * (pb - pa)
    for plane in planes[:count]:
        side = x @ plane[:3] + plane[3]
        assert side.min() >= -1e-9 * (1 + np.abs(x).max())


def test_clip_keeps_the_positive_side():
    square = np.array([[0.0, 0, 0], [2, 0, 0], [2, 2, 0], [0, 2, 0]] + [[0, 0, 0]] * 44)
    plane = np.array([[1.0, 0.0, 0.0, -1.0]])  # x >= 1
    n = clip_polygon(square, 4, plane, 1, 0.0, np.empty((48, 3)))
    assert n == 4 and np.allclose(np.sort(square[:n, 0]), [1, 1, 2, 2])
    gone = np.array([[-1.0, 0.0, 0.0, -5.0]])  # x <= -5: nothing left
    assert clip_polygon(square, n, gone, 1, 0.0, np.empty((48, 3))) == 0

"""The PVS bake's predicates: every separating plane kept lets through every line from the
first set through the second (the bake's soundness rests on it), and clipping keeps every
point on the planes' positive sides."""
import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from vismobile.partition.pvs_kernels import (_flat_rectangle, axis_planes, box_vertices,
                                             clip_polygon, grow_box_step, separators)


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


@settings(max_examples=80)
@given(seed=st.integers(0, 2 ** 32 - 1))
def test_axis_planes_let_through_every_line_beyond_the_entry(seed):
    rng = np.random.default_rng(seed)
    s_lo = rng.uniform(-5, 5, 3)
    s_hi = s_lo + rng.uniform(0.0, 3.0, 3)
    e_lo = rng.uniform(-8, 8, 3)
    e_hi = e_lo + rng.uniform(0.0, 2.0, 3) * (rng.uniform(size=3) < 0.7)  # flat sometimes
    planes = np.empty((8, 4))
    count = axis_planes(s_lo, s_hi, e_lo, e_hi, planes, 0)
    pa = s_lo + rng.uniform(0, 1, (400, 3)) * (s_hi - s_lo)
    pb = e_lo + rng.uniform(0, 1, (400, 3)) * (e_hi - e_lo)
    x = pa + (1.0 + rng.exponential(3.0, (400, 1))) * (pb - pa)
    for plane in planes[:count]:
        assert (x @ plane[:3] + plane[3]).min() >= -1e-9 * (1 + np.abs(x).max())


def test_axis_planes_cut_an_exit_back_toward_the_source():
    # the source lies wholly below x = 7.266 (the entry's plane): beyond the entry a line has
    # x >= 7.266, so an exit portal at x = 6.047 is out of reach; the separators through the
    # sets' edges and vertices leave part of it (found by a random search over boxes)
    s_lo = np.array([-4.54012819, -3.25164462, -3.08201283])
    s_hi = np.array([-2.92921195, -1.89852796, -0.21012973])
    e_lo = np.array([7.26642139, 4.74473777, 2.74540214])
    e_hi = np.array([7.26642139, 6.62224142, 2.7906376])
    entry = np.empty((8, 3))
    assert _flat_rectangle(e_lo, e_hi, entry) == 4
    src = np.empty((8, 3))
    box_vertices(s_lo, s_hi, src)
    x, (y0, y1), (z0, z1) = 6.04718195, (4.4410657, 5.64555667), (1.37867163, 2.67431799)
    exit_quad = np.array([[x, y0, z0], [x, y1, z0], [x, y1, z1], [x, y0, z1]])
    for with_axis in (False, True):
        planes = np.empty((192, 4))
        count = axis_planes(s_lo, s_hi, e_lo, e_hi, planes, 0) if with_axis else 0
        count = separators(src, 8, True, entry, 4, planes, count, False)
        poly = np.zeros((48, 3))
        poly[:4] = exit_quad
        left = clip_polygon(poly, 4, planes, count, 1e-9, np.empty((48, 3)))
        assert (left == 0) == with_axis


def test_a_growing_box_steps_beyond_its_points_within_the_face():
    box = np.full((1, 2, 3), np.inf)
    box[0, 1] = -np.inf
    face = np.array([[0.0, 1.0, 0.0], [4.0, 1.0, 4.0]])
    cand = np.array([[1.0, 1.0, 1.0], [2.0, 1.0, 2.0]])
    assert grow_box_step(box, 0, cand, 2, 0.5, face, 0.0)
    assert np.array_equal(box[0], [[1.0, 1.0, 1.0], [2.0, 1.0, 2.0]])  # the first: exact
    assert not grow_box_step(box, 0, cand, 2, 0.5, face, 0.0)
    grown = np.array([[0.8, 1.0, 1.0], [3.9, 1.0, 2.0]])
    assert grow_box_step(box, 0, grown, 2, 0.5, face, 0.0)
    # x steps 0.5 past the new points, kept within the face; y stays flat; z did not move
    assert np.allclose(box[0], [[0.3, 1.0, 1.0], [4.0, 1.0, 2.0]])


BOX_EDGES = [(0, 1), (2, 3), (4, 5), (6, 7), (0, 2), (1, 3), (4, 6), (5, 7), (0, 4), (1, 5),
             (2, 6), (3, 7)]


def _plain_separators(a, a_box, b, b_box, limit):
    """separators without the probes, in plain Python (the same float operations in the same
    order): every candidate plane's sides over all of both sets."""
    out = []

    def attempt(p, q, r):
        e = [q[c] - p[c] for c in range(3)]
        w = [r[c] - p[c] for c in range(3)]
        n = [e[1] * w[2] - e[2] * w[1], e[2] * w[0] - e[0] * w[2], e[0] * w[1] - e[1] * w[0]]
        length = float(np.sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]))
        scale = float(np.sqrt((e[0] * e[0] + e[1] * e[1] + e[2] * e[2])
                              * (w[0] * w[0] + w[1] * w[1] + w[2] * w[2])))
        if length <= 1e-9 * scale or length == 0.0:
            return
        n = [n[0] / length, n[1] / length, n[2] / length]
        d = -(n[0] * p[0] + n[1] * p[1] + n[2] * p[2])
        fa = [n[0] * x[0] + n[1] * x[1] + n[2] * x[2] + d for x in a]
        fb = [n[0] * x[0] + n[1] * x[1] + n[2] * x[2] + d for x in b]
        if max(fa) <= min(fb):
            out.append([n[0], n[1], n[2], d - 0.5 * (max(fa) + min(fb))])
        elif max(fb) <= min(fa):
            out.append([-n[0], -n[1], -n[2], -d + 0.5 * (min(fa) + max(fb))])

    for first, second, box in ((a, b, a_box), (b, a, b_box)):
        edges = BOX_EDGES if box else [(k, (k + 1) % len(first)) for k in range(len(first))]
        for i, j in edges:
            for r in second:
                if len(out) < limit:
                    attempt(first[i], first[j], r)
    return np.array(out).reshape(-1, 4)


@settings(max_examples=120)
@given(seed=st.integers(0, 2 ** 32 - 1), box_b=st.booleans(), snap=st.booleans())
def test_separators_probed_keep_exactly_the_plain_search_planes(seed, box_b, snap):
    """The probes (pvs_kernels._try) only drop planes the full test drops: the planes kept,
    and their order, are bit for bit those of the plain search, also for sets that touch,
    share a face's plane or sit on a grid of coordinates (snap: ties between the sides)."""
    rng = np.random.default_rng(seed)
    pick = (lambda n: rng.integers(-4, 5, n) * 0.5) if snap else (lambda n: rng.uniform(-4, 4, n))
    lo = pick(3)
    a = np.empty((8, 3))
    box_vertices(lo, lo + np.abs(pick(3)) + 0.5, a)
    blo = pick(3)
    bhi = blo + np.abs(pick(3)) + 0.25
    if not box_b:  # a crossing box lying in its portal's plane: a rectangle
        axis = rng.integers(3)
        bhi[axis] = blo[axis]
    b = np.empty((8, 3))
    b = b[:_flat_rectangle(blo, bhi, b)]
    limit = 192 if rng.random() < 0.8 else int(rng.integers(1, 12))
    planes = np.empty((limit, 4))
    count = separators(a, 8, True, b.copy(), len(b), planes, 0, len(b) == 8)
    assert np.array_equal(planes[:count], _plain_separators(a, True, b, len(b) == 8, limit))

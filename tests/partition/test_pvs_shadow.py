"""The outdoor PVS's shadow kernels (partition/pvs_shadow.py) from one sample point, against exact
segment-prism tests: a step hides only points whose line from the sample crosses a column, a
bin holding a column's corner or two columns' silhouette sides takes a step, and a triangle is
hidden only when every point of it is."""
import numpy as np

from .test_pvs_street import segment_hits_prism
from vismobile.partition import pvs_shadow as sh


def columns(count, rng, spread=40.0):
    """count rotated rectangles (footprints, counter-clockwise) 2-8 wide, 4-30 high, away from
    the origin (the sample's x-z point)."""
    polys, tops = [], []
    while len(polys) < count:
        c = rng.uniform(-spread, spread, 2)
        if np.hypot(*c) < 8.0:
            continue
        a = rng.uniform(0, np.pi)
        u = np.array([np.cos(a), -np.sin(a)]) * rng.uniform(1, 4)
        v = np.array([np.sin(a), np.cos(a)]) * rng.uniform(1, 4)
        polys.append(np.array([c - u - v, c + u - v, c + u + v, c - u + v]))
        tops.append(rng.uniform(4.0, 30.0))
    return polys, np.array(tops)


def turn(p):
    """The turn at p's second corner (> 0: counter-clockwise)."""
    (ax, az), (bx, bz) = p[1] - p[0], p[2] - p[1]
    return ax * bz - az * bx


def steps_of(polys, tops, sample):
    """The sample's steps, counts, and (BINS + 1,) bin edge angles (no slack)."""
    starts = np.concatenate([[0], np.cumsum([len(p) for p in polys])]).astype(np.int64)
    steps = np.empty((sh.BINS, sh.PAIRS))
    slopes = np.empty((sh.BINS, sh.PAIRS))
    count = np.zeros(sh.BINS, dtype=np.int64)
    edges = -np.pi + np.arange(sh.BINS + 1) * (2.0 * np.pi / sh.BINS)
    sh.sample_steps(*sample, np.concatenate(polys), starts, tops, np.ones(len(tops), bool),
                    0.0, 0.0, steps, slopes, count, np.cos(edges), np.sin(edges),
                    np.empty((4, 3)), np.empty((2, sh.BINS, sh.PIECES, 3)),
                    np.zeros((2, sh.BINS), dtype=np.int64))
    return steps, slopes, count, edges


def hidden_point(q, sample, steps, slopes, count):
    """A point under some step of its bin (as the triangle test reads them, a point's part)."""
    dx, dz = q[0] - sample[0], q[2] - sample[2]
    b = int(np.floor((np.arctan2(dz, dx) + np.pi) / (2.0 * np.pi / sh.BINS))) % sh.BINS
    d = np.hypot(dx, dz)
    return any(steps[b, i] <= d and sample[1] + slopes[b, i] * d > q[1]
               for i in range(count[b]))


def test_steps_hide_only_points_whose_line_crosses_a_column():
    rng = np.random.default_rng(5)
    said = truly = both = 0
    for trial in range(6):
        polys, tops = columns(14, rng)
        sample = np.array([0.0, rng.uniform(1.0, 4.0), 0.0])
        steps, slopes, count, _ = steps_of(polys, tops, sample)
        for _ in range(1500):
            q = np.array([rng.uniform(-60, 60), rng.uniform(0.0, 25.0), rng.uniform(-60, 60)])
            hid = hidden_point(q, sample, steps, slopes, count)
            blocked = any(segment_hits_prism(sample, q, p, h) for p, h in zip(polys, tops))
            assert blocked or not hid, (trial, q)
            said += hid
            truly += blocked
            both += hid and blocked
    assert truly > 1000 and said > 0.97 * truly  # the fused steps miss few blocked points


def test_a_corner_and_two_columns_sides_in_one_bin_take_a_step():
    width = 2.0 * np.pi / sh.BINS
    b = 700
    mid = -np.pi + (b + 0.5) * width
    u = np.array([np.cos(mid), np.sin(mid)])
    # a square seen corner-on, the corner's direction in the middle of bin b: no wall's wedge
    # holds the whole bin, the silhouette does
    c = 20.0 * u
    w = np.array([u[1], -u[0]])
    square = np.array([c - 2 * u, c + 2 * w, c + 2 * u, c - 2 * w])
    if turn(square) < 0:
        square = square[::-1].copy()
    steps, slopes, count, _ = steps_of([square], np.array([10.0]), np.array([0.0, 1.0, 0.0]))
    assert count[b] == 1 and 18.0 <= steps[b, 0] < 18.1
    # two blocks whose silhouettes' sides fall in bin b, overlapping there: together they hide it
    side = [mid - 0.3 * width, mid + 0.3 * width]

    def block(angle, toward, distance):
        """A 4 x 4 block at distance whose silhouette side nearest `toward` lies at angle."""
        r = np.array([np.cos(angle), np.sin(angle)])
        n = np.array([-r[1], r[0]]) * toward  # away from the other block
        corner = distance * r
        p = np.array([corner, corner + 4 * r, corner + 4 * r + 4 * n, corner + 4 * n])
        if turn(p) < 0:
            p = p[::-1].copy()
        return p

    pair = [block(side[0], 1.0, 30.0), block(side[1], -1.0, 25.0)]
    steps, slopes, count, _ = steps_of(pair, np.array([12.0, 9.0]), np.array([0.0, 1.0, 0.0]))
    assert count[b] >= 1 and steps[b, :count[b]].min() >= 30.0 - 1e-9
    assert steps_of(pair[:1], np.array([12.0]), np.array([0.0, 1.0, 0.0]))[2][b] == 0
    assert steps_of(pair[1:], np.array([9.0]), np.array([0.0, 1.0, 0.0]))[2][b] == 0


def test_triangles_are_hidden_only_when_all_of_them_is():
    """Random ground and wall triangles behind random columns, from one sample (cell_hidden,
    no slack): a hidden one has every point (corners, edges, inside) behind a column; and a
    long triangle whose near end lies in other bins than its far end is hidden (its least
    distance taken per bin)."""
    rng = np.random.default_rng(9)
    polys, tops = columns(16, rng)
    starts = np.concatenate([[0], np.cumsum([len(p) for p in polys])]).astype(np.int64)
    sample = np.array([[0.0, 2.0, 0.0]])
    # behind a long wall seen obliquely: its nearest corner (10, 6) lies where the wall is near,
    # its far end where the wall is 20 away, farther than that corner
    polys.append(np.array([[5.0, 2.0], [60.0, 2.0], [60.0, 4.0], [5.0, 4.0]]))
    tops = np.append(tops, 20.0)
    starts = np.append(starts, starts[-1] + 4)
    tris = [np.array([[10.0, 0.0, 6.0], [60.0, 0.0, 6.0], [60.0, 0.0, 10.0]])]
    for _ in range(1500):
        c = rng.uniform(-60, 60, 2)
        if rng.uniform() < 0.6:  # on the ground
            xz = c + rng.uniform(-6, 6, (3, 2))
            tris.append(np.column_stack([xz[:, 0], np.zeros(3), xz[:, 1]]))
        else:  # a wall piece
            d = rng.uniform(-4, 4, 2)
            h = rng.uniform(1, 20)
            tris.append(np.array([[*c, 0.0], [*(c + d), 0.0], [*(c + d), h]])[:, [0, 2, 1]])
    corners = np.ascontiguousarray(np.array(tris))
    groups = np.arange(len(tris) + 1, dtype=np.int64)  # one triangle per group
    boxes = np.zeros((len(tris), 5))
    hidden = np.ones(len(tris), dtype=bool)
    sh.cell_hidden(sample, np.concatenate(polys), starts, tops, np.ones(len(tops), bool), 0.0,
                   0.0, corners, groups, np.arange(len(tris), dtype=np.int64), boxes, 0.0,
                   hidden)
    assert hidden[0] and 100 < hidden.sum() < len(tris)
    for t in np.flatnonzero(hidden):
        for w in np.vstack([np.eye(3), rng.dirichlet([1, 1, 1], 40), [[0.5, 0.5, 0]]]):
            q = w @ corners[t]
            assert any(segment_hits_prism(sample[0], q, p, h) for p, h in zip(polys, tops)), t

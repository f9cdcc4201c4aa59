"""ROAM's bintree of diamonds (roam.py describes it): a diamond's geometry from its split
vertex, the nested wedgie thickness e(v) per diamond, bottom-up, and which diamonds may merge or
split."""
from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True, inline="always")
def _low(x):
    """Lowest set bit of x (2^62 for 0, above every coordinate)."""
    return x & -x if x != 0 else 1 << 62


@njit(cache=True, inline="always")
def _geometry(r, c, n, g):
    """Diamond of split vertex (r, c): g[0], g[1] = apexes (row -1 when off the map),
    g[2], g[3] = hypotenuse ends. Returns (h, square): h the step from the vertex to its
    corners (children are virtual half-cell points when an edge diamond has h == 1), square
    when the hypotenuse is a diagonal."""
    S = 1 << n
    a, b = _low(r), _low(c)
    h = min(a, b)
    if a == b:  # square centre: the hypotenuse is one diagonal of the 2h square
        if _low(r - h) == 2 * h:
            ra, rb = r - h, r + h
        else:
            ra, rb = r + h, r - h
        if _low(c - h) == 2 * h:
            ca, cb = c - h, c + h
        else:
            ca, cb = c + h, c - h
        g[0, 0], g[0, 1] = ra, cb
        g[1, 0], g[1, 1] = rb, ca
        g[2, 0], g[2, 1] = ra, ca
        g[3, 0], g[3, 1] = rb, cb
    elif a > b:  # on a row: horizontal hypotenuse, apexes above and below
        g[2, 0], g[2, 1] = r, c - h
        g[3, 0], g[3, 1] = r, c + h
        g[0, 0], g[0, 1] = r - h, c
        g[1, 0], g[1, 1] = r + h, c
    else:
        g[2, 0], g[2, 1] = r - h, c
        g[3, 0], g[3, 1] = r + h, c
        g[0, 0], g[0, 1] = r, c - h
        g[1, 0], g[1, 1] = r, c + h
    for k in range(2):
        if g[k, 0] < 0 or g[k, 0] > S or g[k, 1] < 0 or g[k, 1] > S:
            g[k, 0] = -1
    return h, a == b


@njit(cache=True, inline="always")
def _children_worst(g, error, N, worst):
    """max(worst, the error of each child of the diamond g (_geometry): the midpoint of an
    apex (on the map) and a hypotenuse end), so that errors nest."""
    for k in range(2):
        if g[k, 0] < 0:
            continue
        for e in range(2, 4):
            mr = (g[k, 0] + g[e, 0]) // 2
            mc = (g[k, 1] + g[e, 1]) // 2
            worst = max(worst, error[mr * N + mc])
    return worst


@njit(cache=True)
def wedgies(heights, n):
    """(N*N,) float64 nested wedgie thickness per split vertex (0 at the four corners)."""
    N = heights.shape[0]
    error = np.zeros(N * N)
    g = np.empty((4, 2), np.int64)
    for s in range(n):
        h = 1 << s
        for square in range(2):  # edge diamonds of step h first: square centres need them
            for r in range(0, N, h):
                for c in range(0, N, h):
                    a, b = _low(r), _low(c)
                    if min(a, b) != h or (a == b) != (square == 1):
                        continue
                    hh, sq = _geometry(r, c, n, g)
                    local = abs(heights[r, c] - 0.5 * (heights[g[2, 0], g[2, 1]]
                                                        + heights[g[3, 0], g[3, 1]]))
                    worst = 0.0
                    if sq or hh > 1:
                        worst = _children_worst(g, error, N, worst)
                    error[r * N + c] = local + worst
    return error


@njit(cache=True)
def horizontal_wedgies(valid, n, spacing):
    """(N*N,) float64 seed 002's horizontal error per split vertex v on maps with no data
    (Rodrigues's Table 4.1 over the diamond's hypotenuse A-v-B: hsize = |Av| when A and B
    agree and v differs, hsize / 2 when A and B differ), nested as a maximum over its
    children, like the tiles' (tiles.horizontal_error)."""
    N = valid.shape[0]
    error = np.zeros(N * N)
    g = np.empty((4, 2), np.int64)
    for s in range(n):
        h = 1 << s
        for square in range(2):
            for r in range(0, N, h):
                for c in range(0, N, h):
                    a, b = _low(r), _low(c)
                    if min(a, b) != h or (a == b) != (square == 1):
                        continue
                    hh, sq = _geometry(r, c, n, g)
                    va, vb = valid[g[2, 0], g[2, 1]], valid[g[3, 0], g[3, 1]]
                    half = np.sqrt(float((r - g[2, 0]) ** 2 + (c - g[2, 1]) ** 2)) * spacing
                    local = 0.0
                    if va != vb:
                        local = 0.5 * half
                    elif va != valid[r, c]:
                        local = half
                    worst = local
                    if sq or hh > 1:
                        worst = _children_worst(g, error, N, worst)
                    error[r * N + c] = worst
    return error


@njit(cache=True)
def wedgie_ranges(heights, error, n):
    """(lo, hi) (N*N,) float32 height range of each diamond's wedgies: its corners' heights
    -+ e(v), rounded outward."""
    N = heights.shape[0]
    lo = np.zeros(N * N, np.float32)
    hi = np.zeros(N * N, np.float32)
    g = np.empty((4, 2), np.int64)
    S = N - 1
    for r in range(N):
        for c in range(N):
            if (r == 0 or r == S) and (c == 0 or c == S):
                continue
            _geometry(r, c, n, g)
            y0, y1 = np.inf, -np.inf
            for k in range(4):
                if g[k, 0] >= 0:
                    y = heights[g[k, 0], g[k, 1]]
                    y0, y1 = min(y0, y), max(y1, y)
            v = r * N + c
            a, b = y0 - error[v], y1 + error[v]
            fa, fb = np.float32(a), np.float32(b)
            if fa > a:
                fa = np.nextafter(fa, np.float32(-np.inf))
            if fb < b:
                fb = np.nextafter(fb, np.float32(np.inf))
            lo[v], hi[v] = fa, fb
    return lo, hi


@njit(cache=True, inline="always")
def _box(wedge, v, N):
    """(x0, x1, z0, z1) in samples and (y0, y1) world of the box holding diamond v's wedgies:
    every diamond spans +-h samples around its vertex, h its lowest set coordinate bit."""
    S = N - 1
    r, c = v // N, v % N
    x = r | c
    h = x & -x
    return (max(c - h, 0), min(c + h, S), max(r - h, 0), min(r + h, S), wedge[v, 0],
            wedge[v, 1])


@njit(cache=True, inline="always")
def _is_corner(r, c, S):
    return (r == 0 or r == S) and (c == 0 or c == S)


@njit(cache=True, inline="always")
def _leaf_children(split, v, n, N, g, every):
    """Split diamond (not a corner) whose in-mesh triangles all have leaf children (every), or
    one of whose triangles has two leaf children (not every); a virtual diamond (h == 1, not
    square) has no children and is both."""
    if split[v] == 0 or _is_corner(v // N, v % N, N - 1):
        return False
    h, sq = _geometry(v // N, v % N, n, g)
    if not sq and h == 1:
        return True
    for k in range(2):
        if g[k, 0] < 0:
            continue
        free = True
        for e in range(2, 4):
            if split[((g[k, 0] + g[e, 0]) // 2) * N + (g[k, 1] + g[e, 1]) // 2]:
                free = False
        if free != every:  # every: a triangle with a split child; any: a free triangle
            return free
    return every


@njit(cache=True, inline="always")
def _mergeable(split, v, n, N, g):
    """Split diamond none of whose children is split (its four triangles' children are leaves)."""
    return _leaf_children(split, v, n, N, g, True)


@njit(cache=True, inline="always")
def _half_mergeable(split, v, n, N, g):
    """Split diamond with a triangle whose two children are leaves (Samec's merge unit: two
    leaves into their parent); the diamond's other triangle may have split children, which
    his forced merge merges first. Every mergeable diamond is half-mergeable."""
    return _leaf_children(split, v, n, N, g, False)


@njit(cache=True, inline="always")
def _candidate(split, v, n, N, g):
    """Unsplit diamond with at least one triangle in the mesh (a parent split)."""
    if split[v]:
        return False
    _geometry(v // N, v % N, n, g)
    for k in range(2):
        if g[k, 0] >= 0 and split[g[k, 0] * N + g[k, 1]]:
            return True
    return False


@njit(cache=True, inline="always")
def _triangles_of(v, n, N, g):
    """Triangles of diamond v (2, or 1 on the border)."""
    _geometry(v // N, v % N, n, g)
    return (g[0, 0] >= 0) + (g[1, 0] >= 0)

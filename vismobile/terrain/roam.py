"""ROAM (Duchaineau et al. 1997) as Samec 2003 (seed 003) and Pires 2003 describe it.

A right-triangle bintree over the (2^n+1)^2 heightmap: two root triangles share the diagonal
(0, 0)-(S, S) (S = N - 1); splitting a triangle T = (apex, v0, v1) at its hypotenuse midpoint
vc gives T0 = (vc, apex, v0) and T1 = (vc, v1, apex). T and its base neighbour (across the
hypotenuse) form a diamond; only diamonds split, both halves at once, and a coarser base
neighbour is split first (forced split, recursively), so the mesh never has a T-junction.

Diamonds are stored by their split vertex: every sample except the four map corners is the
hypotenuse midpoint of exactly one diamond, so the mesh state is one byte per sample
(split[v]), with flat arrays and no per-triangle objects. A diamond's apexes are its parents
(the diamonds that must be split for its triangles to exist, one on the border), its four
children are the midpoints of its legs. The finest diamonds (one coordinate odd, the other
even) split into half cells; the finest triangles form the 4-8 mesh of alternating diagonals,
the same full-resolution surface as Röttger's finest fans (`Heightmap.height_at(alternating=
True)`).

Error: nested wedgie thickness per diamond, bottom-up,
    e(v) = |h(v) - (h(v0) + h(v1)) / 2| + max(e(children of v)),   0 below the finest level,
which is at least the seed's per-triangle e_T = max(e_T0, e_T1) + |...| for both triangles of
the diamond, so the full-resolution surface over each of its triangles lies within +-e(v) of
the triangle's plane, and a parent's wedgie encloses its children's.

Priority in pixels: p(v) = lambda_b * e(v) / d(v), d the distance from the eye to the box that
holds the diamond's wedgies (its corners' x-z extent, their heights -+ e(v)), lambda_b the
off-axis bound of tiles.pixel_scale. Every vertical gap inside a leaf is a segment inside that
box, so it projects to at most p pixels: when no leaf candidate has p > tau, every
full-resolution sample in the frustum is drawn within tau pixels (this is the seed's projected
wedgie, made a strict bound instead of evaluated at the three vertices). Diamonds whose box is
outside the frustum get priority 0 (they merge away, and their triangles are not emitted);
frustum flags are IN / OUT / PARTIAL per diamond, and only PARTIAL diamonds test their
triangles one by one.

Frame: start from last frame's mesh; recompute the priorities of the split queue (unsplit
diamonds with at least one triangle in the mesh) and of the merge queue (split diamonds none
of whose children is split); merge while the lowest merge priority is <= tau (or the mesh is
over the budget), then split the highest-priority leaf (with its forced splits) while its
priority is > tau and the whole forced chain fits the budget. In budget mode, a blocked split
first merges cheaper diamonds (ROAM's max(Qs) > min(Qm) exchange), within a bounded number of
operations. Without a budget, a split candidate scored <= tau is not re-scored until the eye
has travelled d - lambda_b e / tau (the seed's deferred wait-lists, from distance alone).

Geomorphing: a vertex created by a split moves from the midpoint of its hypotenuse to its
height over `geomorph` frames (h_t = (1 - t) (h(v0) + h(v1)) / 2 + t h(v)). On each of its
triangles the drawn surface is then a blend of the parent's plane and the children's, so its
gap to the ground is at most e(v): while a vertex morphs, the screen error is bounded by its
diamond's priority p(v) (which was > tau when it split) instead of by tau. Merges pop.
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
from numba import njit

from .heightmap import Heightmap
from .quadtree import box_visible
from .tiles import pixel_scale

OUT, PARTIAL, IN = 0, 1, 2


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
                        for k in range(2):
                            if g[k, 0] < 0:
                                continue
                            for e in range(2, 4):
                                mr = (g[k, 0] + g[e, 0]) // 2
                                mc = (g[k, 1] + g[e, 1]) // 2
                                worst = max(worst, error[mr * N + mc])
                    error[r * N + c] = local + worst
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


@njit(cache=True)
def _flag(planes, x0, y0, z0, x1, y1, z1):
    """OUT when the box is outside one plane, IN when inside all, else PARTIAL (exact for the
    box, in float64; the box itself errs large)."""
    inside = True
    for p in range(planes.shape[0]):
        a, b, c_, d = planes[p, 0], planes[p, 1], planes[p, 2], planes[p, 3]
        hi = (a * (x1 if a >= 0 else x0) + b * (y1 if b >= 0 else y0)
              + c_ * (z1 if c_ >= 0 else z0) + d)
        if hi < 0:
            return OUT
        lo = (a * (x0 if a >= 0 else x1) + b * (y0 if b >= 0 else y1)
              + c_ * (z0 if c_ >= 0 else z1) + d)
        if lo < 0:
            inside = False
    return IN if inside else PARTIAL


@njit(cache=True, inline="always")
def _score(wedge, spacing, v, N, eye, planes, lam, cull):
    """Priority in pixels of diamond v (0 when its box is outside the frustum and cull)."""
    x0, x1, z0, z1, y0, y1 = _box(wedge, v, N)
    x0, x1, z0, z1 = x0 * spacing, x1 * spacing, z0 * spacing, z1 * spacing
    if cull and _flag(planes, x0, y0, z0, x1, y1, z1) == OUT:
        return 0.0
    e = wedge[v, 2]
    if e <= 0.0:
        return 0.0
    dx = max(x0 - eye[0], 0.0, eye[0] - x1)
    dy = max(y0 - eye[1], 0.0, eye[1] - y1)
    dz = max(z0 - eye[2], 0.0, eye[2] - z1)
    d = np.sqrt(dx * dx + dy * dy + dz * dz)
    if d <= 0.0:
        return np.inf
    return lam * e / d


@njit(cache=True, inline="always")
def _slack(wedge, spacing, v, N, eye, lam, tau):
    """How far the eye may travel (any direction, any turn) before diamond v's priority can
    exceed tau: d - lambda_b e / tau with d the distance to its wedgie box (errs short)."""
    x0, x1, z0, z1, y0, y1 = _box(wedge, v, N)
    dx = max(x0 * spacing - eye[0], 0.0, eye[0] - x1 * spacing)
    dy = max(y0 - eye[1], 0.0, eye[1] - y1)
    dz = max(z0 * spacing - eye[2], 0.0, eye[2] - z1 * spacing)
    return np.sqrt(dx * dx + dy * dy + dz * dz) - lam * wedge[v, 2] / tau


# Binary min-heaps on parallel arrays (keys float64, values int64); _reserve grows them.
@njit(cache=True)
def _reserve(keys, vals, size, extra):
    if size + extra <= keys.shape[0]:
        return keys, vals
    nk = np.empty(2 * (size + extra), np.float64)
    nv = np.empty(2 * (size + extra), np.int64)
    nk[:size] = keys[:size]
    nv[:size] = vals[:size]
    return nk, nv


@njit(cache=True, inline="always")
def _push(keys, vals, size, key, val):
    i = size
    keys[i], vals[i] = key, val
    while i > 0:
        p = (i - 1) >> 1
        if keys[p] < keys[i] or (keys[p] == keys[i] and vals[p] <= vals[i]):
            break
        keys[p], keys[i] = keys[i], keys[p]
        vals[p], vals[i] = vals[i], vals[p]
        i = p
    return size + 1


@njit(cache=True)
def _pop(keys, vals, size):
    size -= 1
    keys[0], vals[0] = keys[size], vals[size]
    i = 0
    while True:
        lft = 2 * i + 1
        if lft >= size:
            break
        m = lft
        rgt = lft + 1
        if rgt < size and (keys[rgt] < keys[lft]
                           or (keys[rgt] == keys[lft] and vals[rgt] < vals[lft])):
            m = rgt
        if keys[i] < keys[m] or (keys[i] == keys[m] and vals[i] <= vals[m]):
            break
        keys[m], keys[i] = keys[i], keys[m]
        vals[m], vals[i] = vals[i], vals[m]
        i = m
    return size


@njit(cache=True, inline="always")
def _is_corner(r, c, S):
    return (r == 0 or r == S) and (c == 0 or c == S)


@njit(cache=True, inline="always")
def _mergeable(split, v, n, N, g):
    """Split diamond none of whose children is split (its four triangles' children are leaves)."""
    if split[v] == 0 or _is_corner(v // N, v % N, N - 1):
        return False
    h, sq = _geometry(v // N, v % N, n, g)
    if not sq and h == 1:
        return True
    for k in range(2):
        if g[k, 0] < 0:
            continue
        for e in range(2, 4):
            if split[((g[k, 0] + g[e, 0]) // 2) * N + (g[k, 1] + g[e, 1]) // 2]:
                return False
    return True


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


@njit(cache=True)
def _compact(alive, count, split, head):
    """Keep the split entries of alive[:count], sorted and unique; alive[:head] is already
    sorted (last frame's list), so only the new tail is sorted and merged in (a full sort of
    a sorted list with a short random tail degenerates: 6-9 ms for 49k entries). Returns the
    new count."""
    k = 0
    for i in range(head):
        if split[alive[i]]:
            alive[k] = alive[i]
            k += 1
    tail = np.empty(count - head, np.int64)
    t = 0
    for i in range(head, count):
        if split[alive[i]]:
            tail[t] = alive[i]
            t += 1
    tail = np.sort(tail[:t])
    merged = np.empty(k + t, np.int64)
    i = j = m = 0
    last = -1
    while i < k or j < t:
        if j >= t or (i < k and alive[i] <= tail[j]):
            x = alive[i]
            i += 1
        else:
            x = tail[j]
            j += 1
        if x != last:
            merged[m] = x
            m += 1
            last = x
    alive[:m] = merged[:m]
    return m


@njit(cache=True)
def _push_children(wedge, spacing, n, N, split, qs, stamp, x, eye, planes, lam, tau,
                   cull, every, sk, sv, ns, low, g):
    """Queue x's unsplit children for splitting, each once per frame; only those above tau
    unless every (budget mode). Returns the queue and the largest priority left out."""
    h, sq = _geometry(x // N, x % N, n, g)
    if sq or h > 1:
        for k in range(2):
            if g[k, 0] < 0:
                continue
            for e in range(2, 4):
                m = ((g[k, 0] + g[e, 0]) // 2) * N + (g[k, 1] + g[e, 1]) // 2
                if split[m] == 0 and qs[m] != stamp:
                    q = _score(wedge, spacing, m, N, eye, planes, lam, cull)
                    qs[m] = stamp
                    if every or q > tau:
                        ns = _push(sk, sv, ns, -q, m)
                    else:
                        low = max(low, q)
    return ns, low


@njit(cache=True)
def _merge(wedge, spacing, n, N, split, qs, qm, stamp, v, p, eye, planes, lam, tau,
           cull, every, sk, sv, ns, mk, mv, nm, low, g, g2):
    """Merge diamond v (priority p): it rejoins the split queue, its parents may become
    mergeable. Returns the queues, the largest left-out priority and the leaves removed."""
    split[v] = 0
    if qs[v] != stamp:
        qs[v] = stamp
        if every or p > tau:
            ns = _push(sk, sv, ns, -p, v)
        else:
            low = max(low, p)
    _geometry(v // N, v % N, n, g)
    removed = 0
    for k in range(2):
        if g[k, 0] < 0:
            continue
        removed += 1
        a = g[k, 0] * N + g[k, 1]
        if qm[a] != stamp and _mergeable(split, a, n, N, g2):
            q = _score(wedge, spacing, a, N, eye, planes, lam, cull)
            if every or q <= tau:
                nm = _push(mk, mv, nm, q, a)
                qm[a] = stamp
    return ns, nm, low, removed


@njit(cache=True)
def _frame(wedge, spacing, n, split, alive, alive_count, qs, qm, mark, stamp,
           eye, planes, lam, tau, budget, leaves, cull, born, stats, until, travel):
    """One ROAM frame from last frame's mesh. Returns (alive_count, leaves, born_count).

    budget < 0: no budget (queues then hold only diamonds that can move: split candidates
    above tau, merge candidates at or below it). stats (float64): [splits, merges, forced,
    largest split priority left (an upper bound), exchanges, stopped by the budget, alive
    full, candidates deferred]. qs/qm/mark are stamps per sample; stamp is this call's number (> 0). When alive
    fills up, returns early with stats[6] = 1 (the mesh is consistent; grow alive, call
    again). Deferred priorities (no budget only): travel is the eye's path length so far and
    until[v] the travel up to which candidate v is known to stay <= tau (float32 rounded
    down); such candidates are not re-scored (the seed's wait-lists, from distance alone,
    so turning the camera needs no re-scoring either)."""
    N = int(np.sqrt(wedge.shape[0]))
    S = N - 1
    every = budget >= 0
    if not every:
        budget = np.iinfo(np.int64).max
    g = np.empty((4, 2), np.int64)
    g2 = np.empty((4, 2), np.int64)
    sk = np.empty(1024, np.float64)  # split queue: keys -p, unsplit diamonds in the mesh
    sv = np.empty(1024, np.int64)
    mk = np.empty(1024, np.float64)  # merge queue: keys p, split diamonds with leaf children
    mv = np.empty(1024, np.int64)
    ns = 0
    nm = 0
    low = 0.0
    for i in range(8):
        stats[i] = 0.0
    centre = (S // 2) * N + S // 2
    head = alive_count  # alive[:head] is sorted (compacted at the end of the last call)
    deferred = 0
    # Queues from last frame's mesh with this frame's priorities.
    # (The children loop is written out here: a call per diamond costs as much again in
    # reference counting of its array arguments.)
    for i in range(alive_count):
        v = alive[i]
        h, sq = _geometry(v // N, v % N, n, g)
        virtual = (not sq) and h == 1
        mergeable = True
        for k in range(2):
            if g[k, 0] < 0:
                continue
            for e in range(2, 4):
                if virtual:
                    continue
                m = ((g[k, 0] + g[e, 0]) // 2) * N + (g[k, 1] + g[e, 1]) // 2
                if split[m]:
                    mergeable = False
                elif qs[m] != stamp:
                    qs[m] = stamp
                    if not every and travel < until[m]:
                        deferred += 1  # the eye has not travelled far enough to matter
                        continue
                    q = _score(wedge, spacing, m, N, eye, planes, lam, cull)
                    if every or q > tau:
                        sk, sv = _reserve(sk, sv, ns, 1)
                        ns = _push(sk, sv, ns, -q, m)
                    else:
                        low = max(low, q)
                        far = travel + _slack(wedge, spacing, m, N, eye, lam, tau)
                        f32 = np.float32(far)
                        if f32 > far:
                            f32 = np.nextafter(f32, np.float32(-np.inf))
                        until[m] = f32
        if mergeable:
            q = _score(wedge, spacing, v, N, eye, planes, lam, cull)
            if every or q <= tau:
                mk, mv = _reserve(mk, mv, nm, 1)
                nm = _push(mk, mv, nm, q, v)
                qm[v] = stamp
    if split[centre] == 0:
        q = _score(wedge, spacing, centre, N, eye, planes, lam, cull)
        sk, sv = _reserve(sk, sv, ns, 1)
        ns = _push(sk, sv, ns, -q, centre)
        qs[centre] = stamp
    splits = merges = forced = exchanges = 0
    blocked = 0
    # Merge phase: diamonds whose own priority meets tau, and any while over the budget.
    while nm > 0 and (mk[0] <= tau or leaves > budget):
        p, v = mk[0], mv[0]
        nm = _pop(mk, mv, nm)
        qm[v] = 0
        if not _mergeable(split, v, n, N, g):
            continue
        sk, sv = _reserve(sk, sv, ns, 1)
        mk, mv = _reserve(mk, mv, nm, 2)
        ns, nm, low, removed = _merge(
            wedge, spacing, n, N, split, qs, qm, stamp, v, p, eye, planes, lam, tau, cull,
            every, sk, sv, ns, mk, mv, nm, low, g, g2)
        leaves -= removed
        merges += 1
    # Split phase: the highest-priority leaf diamond, after its forced chain, while > tau.
    order = np.empty(64 * (n + 2), np.int64)
    stack = np.empty(64 * (n + 2), np.int64)
    born_count = 0
    op = 0
    exchange_cap = 2 * alive_count + 4096
    while ns > 0 and -sk[0] > tau:
        p, v = -sk[0], sv[0]
        if not _candidate(split, v, n, N, g):
            ns = _pop(sk, sv, ns)
            qs[v] = 0
            continue
        if alive_count + 64 * (n + 2) > alive.shape[0]:
            alive_count = _compact(alive, alive_count, split, head)
            head = alive_count
            if alive_count + 64 * (n + 2) > alive.shape[0]:
                stats[6] = 1.0
                break
        # Forced chain: unsplit ancestors first (post-order over the parent DAG).
        op += 1
        token = (stamp << 32) + op
        count = 0
        cost = 0
        top = 1
        stack[0] = v
        while top > 0:
            x = stack[top - 1]
            _geometry(x // N, x % N, n, g)
            pushed = False
            for k in range(2):
                if g[k, 0] < 0:
                    continue
                a = g[k, 0] * N + g[k, 1]
                if split[a] == 0 and mark[a] != token:
                    stack[top] = a
                    top += 1
                    pushed = True
                    break
            if not pushed:
                top -= 1
                mark[x] = token
                order[count] = x
                count += 1
                cost += _triangles_of(x, n, N, g)
        if leaves + cost > budget:
            # Budget: trade the cheapest split diamond for this one (ROAM's
            # max(Qs) > min(Qm) exchange), else stop.
            if nm > 0 and mk[0] < p and exchanges < exchange_cap:
                q, w = mk[0], mv[0]
                nm = _pop(mk, mv, nm)
                qm[w] = 0
                if _mergeable(split, w, n, N, g):
                    sk, sv = _reserve(sk, sv, ns, 1)
                    mk, mv = _reserve(mk, mv, nm, 2)
                    ns, nm, low, removed = _merge(
                        wedge, spacing, n, N, split, qs, qm, stamp, w, q, eye, planes, lam,
                        tau, cull, every, sk, sv, ns, mk, mv, nm, low, g, g2)
                    leaves -= removed
                    merges += 1
                    exchanges += 1
                continue
            blocked = 1
            break
        ns = _pop(sk, sv, ns)
        qs[v] = 0
        for i in range(count):
            x = order[i]
            split[x] = 1
            alive[alive_count] = x
            alive_count += 1
            if born_count < born.shape[0]:
                born[born_count] = x
                born_count += 1
            leaves += _triangles_of(x, n, N, g)
            splits += 1
            if i < count - 1:
                forced += 1
            sk, sv = _reserve(sk, sv, ns, 4)
            ns, low = _push_children(wedge, spacing, n, N, split, qs, stamp, x, eye,
                                     planes, lam, tau, cull, every, sk, sv, ns, low, g)
            if every and qm[x] != stamp:  # newly mergeable (for the budget exchange)
                mk, mv = _reserve(mk, mv, nm, 1)
                nm = _push(mk, mv, nm, _score(wedge, spacing, x, N, eye, planes,
                                              lam, cull), x)
                qm[x] = stamp
    # Largest priority left among leaf diamonds: the frame's screen-error bound (pixels).
    remaining = low
    while ns > 0:
        if _candidate(split, sv[0], n, N, g):
            remaining = max(remaining, -sk[0])
            break
        ns = _pop(sk, sv, ns)
    alive_count = _compact(alive, alive_count, split, head)
    stats[0], stats[1], stats[2] = splits, merges, forced
    if deferred:
        remaining = max(remaining, tau)  # the deferred ones are known to be <= tau only
    stats[3], stats[4], stats[5] = remaining, exchanges, blocked
    stats[7] = deferred
    return alive_count, leaves, born_count


@njit(cache=True)
def _emit(wedge, spacing, n, split, alive, alive_count, planes, cull, out):
    """Leaf triangles (sample ids, counter-clockwise from +y) of the mesh, frustum-culled by
    diamond flags (IN: all, OUT: none, PARTIAL: per triangle). Returns the count (-1: out is
    too small)."""
    N = int(np.sqrt(wedge.shape[0]))
    S = N - 1
    g = np.empty((4, 2), np.int64)
    count = 0
    centre = (S // 2) * N + S // 2
    if split[centre] == 0:
        if out.shape[0] < 2:
            return -1
        out[0, 0], out[0, 1], out[0, 2] = 0, S * N + S, S  # (0,0) (S,S) (0,S)
        out[1, 0], out[1, 1], out[1, 2] = 0, S * N, S * N + S
        return 2
    for i in range(alive_count):
        v = alive[i]
        r, c = v // N, v % N
        x0, x1, z0, z1, y0, y1 = _box(wedge, v, N)
        flag = IN
        if cull:
            flag = _flag(planes, x0 * spacing, y0, z0 * spacing, x1 * spacing, y1, z1 * spacing)
            if flag == OUT:
                continue
        h, sq = _geometry(r, c, n, g)
        virtual = (not sq) and h == 1
        for k in range(2):
            if g[k, 0] < 0:
                continue
            for e in range(2, 4):
                if not virtual:
                    m = ((g[k, 0] + g[e, 0]) // 2) * N + (g[k, 1] + g[e, 1]) // 2
                    if split[m]:
                        continue
                ar, ac, er, ec = g[k, 0], g[k, 1], g[e, 0], g[e, 1]
                if flag == PARTIAL:
                    if not box_visible(planes, min(c, ac, ec) * spacing, y0,
                                       min(r, ar, er) * spacing, max(c, ac, ec) * spacing, y1,
                                       max(r, ar, er) * spacing):
                        continue
                if count == out.shape[0]:
                    return -1
                cross = (ar - r) * (ec - c) - (ac - c) * (er - r)
                out[count, 0] = v
                if cross > 0:
                    out[count, 1], out[count, 2] = ar * N + ac, er * N + ec
                else:
                    out[count, 1], out[count, 2] = er * N + ec, ar * N + ac
                count += 1
    return count


def full_mesh(heightmap: Heightmap) -> np.ndarray:
    """(2 S^2, 3) int64 finest bintree triangles (sample ids, counter-clockwise from +y): the
    4-8 mesh, cells with i + j odd cut along (i, j+1)-(i+1, j)."""
    n = heightmap.size
    i, j = np.meshgrid(np.arange(n - 1), np.arange(n - 1), indexing="ij")
    v00 = (i * n + j).ravel()
    v01, v10, v11 = v00 + 1, v00 + n, v00 + n + 1
    odd = ((i + j) % 2 == 1).ravel()
    a = np.where(odd[:, None], np.stack([v00, v10, v01], 1), np.stack([v00, v11, v01], 1))
    b = np.where(odd[:, None], np.stack([v01, v10, v11], 1), np.stack([v00, v10, v11], 1))
    return np.stack([a, b], axis=1).reshape(-1, 3).astype(np.int64)


@dataclass
class RoamFrame:
    """One ROAM frame.

    triangles  : (T, 3) int64 sample ids (row * N + col) of the drawn leaves, CCW from +y
    leaves     : leaf triangles of the whole bintree mesh (drawn or culled)
    splits, merges, forced : diamond operations this frame (forced: splits of coarser bases)
    bound_px   : the largest priority left among leaf diamonds (pixels): with no geomorph the
                 screen error of every sample in the frustum is at most this
    budget_hit : a split was refused because its forced chain would exceed the budget
    deferred   : split candidates not re-scored (their priority is known to be <= tau)
    lod_ms     : queue rebuild + split/merge + emission wall time
    morph      : (ids (M,) int64, heights (M,) float64) drawn heights of morphing vertices
    """

    triangles: np.ndarray
    leaves: int
    splits: int
    merges: int
    forced: int
    bound_px: float
    budget_hit: bool
    deferred: int
    lod_ms: float
    morph: tuple


class Roam:
    """Frame-coherent ROAM mesh of one heightmap with one pixel knob (and a triangle budget).

    geomorph: frames over which a new vertex rises from its hypotenuse midpoint to its height
    (0: pop at once). defer: skip re-scoring candidates that the eye's travel since they were
    scored cannot have brought above tau (no budget only; the mesh is the same either way).
    """

    def __init__(self, heightmap: Heightmap, geomorph: int = 0, defer: bool = True):
        self.heightmap = heightmap
        self.n = heightmap.exponent
        N = heightmap.size
        self.heights = heightmap.heights.astype(np.float64)
        start = time.perf_counter()
        error = wedgies(self.heights, self.n)
        lo, hi = wedgie_ranges(self.heights, error, self.n)
        # Per diamond, one 16-byte row read by the per-frame priorities: the wedgie box's
        # height range and e (float32 rounded up), so a priority costs one cache line.
        e32 = error.astype(np.float32)
        e32 = np.where(e32 < error, np.nextafter(e32, np.float32(np.inf)), e32)
        self.wedge = np.stack([lo, hi, e32, np.zeros_like(e32)], axis=1)
        del lo, hi, e32, error
        self.build_seconds = time.perf_counter() - start
        self.geomorph = int(geomorph)
        self.defer = bool(defer)
        self.split = np.zeros(N * N, np.uint8)
        S = N - 1
        for v in (0, S, S * N, S * N + S):
            self.split[v] = 1  # the corners: "parents" of the root diamond, always present
        self.alive = np.zeros(min(N * N + 64 * (self.n + 2), 1 << 16), np.int64)
        self.alive_count = 0
        self.leaves = 2
        self.qs = np.zeros(N * N, np.int32)
        self.qm = np.zeros(N * N, np.int32)
        self.mark = np.zeros(N * N, np.int64)
        self.until = np.zeros(N * N, np.float32)  # deferred priorities (see _frame)
        self.travel = 0.0
        self.last_eye = None
        self.knob = None
        self.frame_number = 0  # stamps (may advance twice in one update)
        self.clock = 0  # updates (geomorph time)
        self.out = np.zeros((1 << 16, 3), np.int64)
        self.morph_ids = np.zeros(0, np.int64)
        self.morph_start = np.zeros(0, np.int64)

    def reset(self):
        """Back to the two root triangles (the next frame refines from scratch)."""
        N = self.heightmap.size
        S = N - 1
        self.split[:] = 0
        for v in (0, S, S * N, S * N + S):
            self.split[v] = 1
        self.alive_count = 0
        self.leaves = 2
        self.morph_ids = self.morph_start = np.zeros(0, np.int64)
        self.knob = None

    def update(self, camera, resolution, tau: float, cull: bool = True,
               budget: int | None = None) -> RoamFrame:
        """Split and merge last frame's mesh for this camera; emit the drawn leaves."""
        if not tau > 0:
            raise ValueError("tau must be > 0")
        _, lam = pixel_scale(camera, resolution)
        planes = camera.frustum_planes()
        N = self.heightmap.size
        self.frame_number += 1
        self.clock += 1
        start = time.perf_counter()
        stats = np.zeros(8)
        eye = camera.eye
        if self.last_eye is not None:
            self.travel += float(np.linalg.norm(eye - self.last_eye))
        self.last_eye = eye
        if self.knob != (lam, float(tau)) or not self.defer:  # one lambda and tau only
            self.until[:] = 0.0
            self.travel = 0.0
            self.knob = (lam, float(tau))
        limit = -1 if budget is None else int(budget)
        if budget is not None and budget < 2:
            raise ValueError("budget must be at least 2 triangles")
        born_all = []
        while True:
            born = np.zeros(len(self.alive) if self.geomorph else 0, np.int64)
            self.alive_count, self.leaves, born_count = _frame(
                self.wedge, self.heightmap.spacing, self.n, self.split,
                self.alive, self.alive_count, self.qs, self.qm, self.mark, self.frame_number,
                camera.eye, planes, lam, float(tau), limit, self.leaves, cull, born, stats,
                self.until, self.travel)
            born_all.append(born[:born_count])
            if not stats[6]:
                break
            # The split list filled up: grow it and carry on (same mesh, new stamps).
            grown = np.zeros(min(N * N + 64 * (self.n + 2), 4 * len(self.alive)), np.int64)
            grown[:self.alive_count] = self.alive[:self.alive_count]
            self.alive = grown
            self.frame_number += 1
        while True:
            count = _emit(self.wedge, self.heightmap.spacing, self.n, self.split,
                          self.alive, self.alive_count, planes, cull, self.out)
            if count >= 0:
                break
            self.out = np.zeros((2 * len(self.out), 3), np.int64)
        morph = self._morph(np.concatenate(born_all))
        lod_ms = (time.perf_counter() - start) * 1000.0
        return RoamFrame(self.out[:count].copy(), int(self.leaves), int(stats[0]),
                         int(stats[1]), int(stats[2]), float(stats[3]), bool(stats[5]),
                         int(stats[7]), lod_ms, morph)

    def _morph(self, born) -> tuple:
        """Drawn heights of vertices still rising (ids, heights); empty without geomorph."""
        if not self.geomorph:
            return np.zeros(0, np.int64), np.zeros(0)
        ids = np.r_[self.morph_ids, born]
        starts = np.r_[self.morph_start, np.full(len(born), self.clock)]
        t = (self.clock - starts + 1) / (self.geomorph + 1)
        keep = (t < 1) & (self.split[ids] == 1)
        ids, starts, t = ids[keep], starts[keep], t[keep]
        ids, first = np.unique(ids[::-1], return_index=True)  # re-split vertices restart
        starts, t = starts[::-1][first], t[::-1][first]
        self.morph_ids, self.morph_start = ids, starts
        N = self.heightmap.size
        g = np.empty((4, 2), np.int64)
        mid = np.empty(len(ids))
        for k, v in enumerate(ids.tolist()):  # only this frame's few morphing vertices
            _geometry(v // N, v % N, self.n, g)
            mid[k] = 0.5 * (self.heights[g[2, 0], g[2, 1]] + self.heights[g[3, 0], g[3, 1]])
        r, c = np.divmod(ids, N)
        return ids, (1 - t) * mid + t * self.heights[r, c]

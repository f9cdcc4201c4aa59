"""ROAM's per-diamond operations (roam.py describes the method): frustum flags and
priorities in pixels, the wake-up slack, and the merges (one diamond, or Samec's forced merge
of a diamond with its split descendants) with their queue bookkeeping; roam_frame.py runs a
frame with them."""
from __future__ import annotations

import numpy as np
from numba import njit

from .bintree import _box, _geometry, _half_mergeable, _mergeable
from .roam_heap import _push, _reserve

OUT, PARTIAL, IN = 0, 1, 2


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


@njit(cache=True, inline="always")
def _touch(touched, tcount, v):
    """Record a candidate scored on the safe side of tau (it goes to the wake-up heap)."""
    if tcount[0] < touched.shape[0]:
        touched[tcount[0]] = v
        tcount[0] += 1
    else:
        tcount[1] = 1  # overflow: the caller walks the whole mesh next frame


@njit(cache=True)
def _push_children(wedge, spacing, n, N, split, qs, stamp, x, eye, planes, lam, tau,
                   cull, every, sk, sv, ns, low, g, touched, tcount):
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
                        _touch(touched, tcount, m)
    return ns, low


@njit(cache=True)
def _merge(wedge, spacing, n, N, split, qs, qm, stamp, v, p, eye, planes, lam, tau,
           cull, every, sk, sv, ns, mk, mv, nm, low, g, g2, touched, tcount, changed,
           forced=False):
    """Merge diamond v (priority p): it rejoins the split queue, its parents may become
    mergeable (or, with forced, half-mergeable: forced-merge candidates). Returns the
    queues, the largest left-out priority and the leaves removed."""
    split[v] = 0
    _touch(changed, tcount[2:], v)
    if qs[v] != stamp:
        qs[v] = stamp
        if every or p > tau:
            ns = _push(sk, sv, ns, -p, v)
        else:
            low = max(low, p)
            _touch(touched, tcount, v)
    _geometry(v // N, v % N, n, g)
    removed = 0
    for k in range(2):
        if g[k, 0] < 0:
            continue
        removed += 1
        a = g[k, 0] * N + g[k, 1]
        if qm[a] != stamp and (_mergeable(split, a, n, N, g2)
                               or (forced and _half_mergeable(split, a, n, N, g2))):
            q = _score(wedge, spacing, a, N, eye, planes, lam, cull)
            if every or q <= tau:
                nm = _push(mk, mv, nm, q, a)
                qm[a] = stamp
            else:
                _touch(touched, tcount, a)
    return ns, nm, low, removed


@njit(cache=True)
def _subtree(split, v, n, N, g, mark, token, order, stack):
    """v and its split descendants (over the child DAG), children before parents, into
    order; returns their count. order and stack need room for every split diamond."""
    count = 0
    top = 1
    stack[0] = v
    mark[v] = token
    while top > 0:
        x = stack[top - 1]
        h, sq = _geometry(x // N, x % N, n, g)
        pushed = False
        if sq or h > 1:
            for k in range(2):
                if pushed or g[k, 0] < 0:
                    continue
                for e in range(2, 4):
                    m = ((g[k, 0] + g[e, 0]) // 2) * N + (g[k, 1] + g[e, 1]) // 2
                    if split[m] and mark[m] != token:
                        mark[m] = token
                        stack[top] = m
                        top += 1
                        pushed = True
                        break
        if not pushed:
            top -= 1
            order[count] = x
            count += 1
    return count


@njit(cache=True)
def _stop_descent(split, v, n, N, g, mark, token, order, stack, dying):
    """A forced merge's set stops descending (geomorphing): v's priority rose above tau."""
    if dying[v] == 0:
        return
    start = dying[v]
    for i in range(_subtree(split, v, n, N, g, mark, token, order, stack)):
        if dying[order[i]] == start:
            dying[order[i]] = 0


@njit(cache=True)
def _force_merge(wedge, spacing, n, N, split, qs, qm, stamp, v, p, eye, planes, lam, tau,
                 cull, sk, sv, ns, mk, mv, nm, low, g, g2, touched, tcount, changed, mark,
                 token, order, stack, dying, clock, morph):
    """Samec's forced merge (seed 003, Fig. 22), no budget: merge the split diamond v (its
    priority p <= tau) although some of its children are split, by first merging its split
    descendants, children before parents (post-order over the child DAG: the inverse of the
    forced split's chain). It happens only if every diamond it merges scores <= tau this
    frame, so the mesh stays within tau; else nothing changes and v waits (its blocking
    descendants merge on their own later).

    With geomorphing (morph > 0) the whole set descends together, if every member is within
    tau unculled too: on the first call, if no member is dying already (else v waits for those merges), every member gets dying = clock,
    so Roam._morph draws all of them with one t, a blend of the fine and the coarse surface
    (each within tau), and the merges happen morph frames later. A member scored above tau,
    or a set no longer descending as one (a member split, or rose above tau alone), stops the
    descent of all. order and stack need room for every split diamond (mark: per-sample
    tokens). Returns (sk, sv, ns, mk, mv, nm, low, leaves removed, diamonds merged: 0 when
    refused or still descending, -1 when refused for a member above tau)."""
    count = _subtree(split, v, n, N, g, mark, token, order, stack)
    ok = True
    for i in range(count - 1):
        if _score(wedge, spacing, order[i], N, eye, planes, lam, cull) > tau:
            ok = False
            break
    # A set descends only if no member is <= tau just for being outside the frustum: an
    # incremental frame would not look at it again before a turn shows it.
    for i in range(count if morph > 0 and ok else 0):
        if _score(wedge, spacing, order[i], N, eye, planes, lam, False) > tau:
            ok = False
            break
    if morph > 0:
        start = dying[v]
        same = True
        fresh = True
        for i in range(count):
            same = same and dying[order[i]] == start
            fresh = fresh and dying[order[i]] == 0
        if not ok or (start != 0 and not same):
            for i in range(count):
                if start != 0 and dying[order[i]] == start:
                    dying[order[i]] = 0
            return sk, sv, ns, mk, mv, nm, low, 0, 0 if ok else -1
        if start == 0:
            if not fresh:
                return sk, sv, ns, mk, mv, nm, low, 0, 0  # members still merging alone
            for i in range(count):
                dying[order[i]] = clock
            start = clock
        if clock - start < morph:
            _touch(touched, tcount, v)  # still descending: look again next frame
            return sk, sv, ns, mk, mv, nm, low, 0, 0
        for i in range(count):
            dying[order[i]] = 0
    elif not ok:
        return sk, sv, ns, mk, mv, nm, low, 0, -1
    removed = 0
    for i in range(count):
        x = order[i]
        q = p if x == v else _score(wedge, spacing, x, N, eye, planes, lam, cull)
        sk, sv = _reserve(sk, sv, ns, 1)
        mk, mv = _reserve(mk, mv, nm, 2)
        ns, nm, low, gone = _merge(
            wedge, spacing, n, N, split, qs, qm, stamp, x, q, eye, planes, lam, tau, cull,
            False, sk, sv, ns, mk, mv, nm, low, g, g2, touched, tcount, changed, True)
        removed += gone
    return sk, sv, ns, mk, mv, nm, low, removed, count

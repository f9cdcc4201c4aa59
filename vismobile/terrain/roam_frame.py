"""ROAM's frame in numba (roam.py describes the method): frustum flags and priorities of the
diamonds, the split and merge queues (binary heaps over flat arrays), one frame's merges and
splits within tau or the budget, and the triangles it emits."""
from __future__ import annotations

import numpy as np
from numba import njit

from .bintree import _box, _candidate, _geometry, _half_mergeable, _mergeable, _triangles_of
from .quadtree import box_visible
from .roam_heap import _pop, _push, _reserve
from .roam_ops import (IN, OUT, PARTIAL, _flag, _force_merge, _merge, _push_children, _score,
                       _slack, _stop_descent, _touch)

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
def _frame(wedge, spacing, n, split, alive, alive_count, qs, qm, mark, stamp,
           eye, planes, lam, tau, budget, leaves, cull, born, stats, until, travel,
           walk, hk, hv, hsize, wake_at, touched, tcount, changed, dying, clock, morph,
           parked, pcount, parked_at, samec):
    """One ROAM frame from last frame's mesh. Returns (alive_count, leaves, born_count).

    budget < 0: no budget (queues then hold only diamonds that can move: split candidates
    above tau, merge candidates at or below it). stats (float64): [splits, merges, forced,
    largest split priority left (an upper bound), exchanges, stopped by the budget, alive
    full, candidates deferred, forced merges (Samec), diamonds they merged, forced merges
    refused]. qs/qm/mark are
    stamps per sample; stamp is this call's number (> 0). When alive fills up, returns early
    with stats[6] = 1 (the mesh is consistent; grow alive, call again). Without a budget the
    merge queue also holds half-mergeable diamonds (a triangle with two leaf children) at or
    below tau, merged by Samec's forced merge (roam_ops._force_merge) when every split
    descendant is within tau too (samec True; incremental frames only). Deferred priorities (no budget only): travel
    is the eye's path length so far and
    until[v] the travel up to which candidate v is known to stay <= tau (float32 rounded
    down); such candidates are not re-scored (the seed's wait-lists, from distance alone,
    so turning the camera needs no re-scoring either).

    walk False (incremental, no budget): instead of walking last frame's whole mesh, only the
    candidates due on the wake-up heap (hk, hv, hsize[0]: keys = the travel at which their
    priority may cross tau, valid while wake_at[v] equals the key) are re-scored; every
    candidate scored on the safe side of tau is recorded in touched (tcount[0]) for _rewake,
    every diamond split or merged in changed (tcount[2]; tcount[1] / [3] flag overflows).

    morph > 0 (geomorphing): a diamond due to merge within tau first lowers its vertex to its
    hypotenuse midpoint over morph frames (dying[v] = the clock it started; the drawn heights
    come from Roam._morph) and merges after; a merge forced by the budget does not wait, and a
    dying diamond scored above tau again, or given a split child, stops dying. A diamond
    <= tau only because it is outside the frustum merges at once: an incremental frame
    re-scores it only at its (unculled) wake-up, so a turn could otherwise show it half
    lowered while above tau."""
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
    for i in range(11):
        stats[i] = 0.0
    centre = (S // 2) * N + S // 2
    head = alive_count  # alive[:head] is sorted (compacted at the end of the last call)
    deferred = 0
    # Forced merges only in incremental frames: a walking frame already merges every
    # diamond whose split descendants are all within tau, children first (the merge phase
    # re-queues a parent when its last child merges), so there they only cost refusals
    # (1025^2 circle: ~300 a frame, +30% CPU, the same meshes).
    samec = samec and not walk
    op = 0  # tokens (stamp << 32) + op for the per-sample marks
    fm_order = np.empty(alive.shape[0] + 1, np.int64)  # forced merges' sets
    fm_stack = np.empty(alive.shape[0] + 1, np.int64)
    # Queues from last frame's mesh with this frame's priorities.
    # (The children loop is written out here: a call per diamond costs as much again in
    # reference counting of its array arguments.)
    tcount[0] = 0
    tcount[1] = 0
    tcount[2] = 0  # changed (split or merged) diamonds, for the block emitter
    tcount[3] = 0
    if not walk:
        # Parked candidates (_rewake): still outside the frustum stay parked; the others
        # are scored as if due.
        kept = 0
        for i in range(pcount[0]):
            v = parked[i]
            if parked_at[v] == 0:
                continue
            if not _candidate(split, v, n, N, g):
                parked_at[v] = 0
                continue
            x0, x1, z0, z1, y0, y1 = _box(wedge, v, N)
            if cull and _flag(planes, x0 * spacing, y0, z0 * spacing, x1 * spacing, y1,
                              z1 * spacing) == OUT:
                parked[kept] = v
                kept += 1
                continue
            parked_at[v] = 0
            if qs[v] == stamp:
                continue
            qs[v] = stamp
            q = _score(wedge, spacing, v, N, eye, planes, lam, cull)
            if q > tau:
                sk, sv = _reserve(sk, sv, ns, 1)
                ns = _push(sk, sv, ns, -q, v)
            else:
                low = max(low, q)
                _touch(touched, tcount, v)
        pcount[0] = kept
        while hsize[0] > 0 and hk[0] <= travel:
            key, v = hk[0], hv[0]
            hsize[0] = _pop(hk, hv, hsize[0])
            if wake_at[v] != key:
                continue  # stale: re-pushed since, or consumed
            wake_at[v] = -1.0
            if _candidate(split, v, n, N, g):
                if qs[v] == stamp:
                    continue
                qs[v] = stamp
                q = _score(wedge, spacing, v, N, eye, planes, lam, cull)
                if q > tau:
                    sk, sv = _reserve(sk, sv, ns, 1)
                    ns = _push(sk, sv, ns, -q, v)
                else:
                    low = max(low, q)
                    _touch(touched, tcount, v)
            elif (_half_mergeable(split, v, n, N, g) if samec  # forced-merge candidates
                  else _mergeable(split, v, n, N, g)):
                if qm[v] == stamp:
                    continue
                q = _score(wedge, spacing, v, N, eye, planes, lam, cull)
                if q <= tau:
                    mk, mv = _reserve(mk, mv, nm, 1)
                    nm = _push(mk, mv, nm, q, v)
                    qm[v] = stamp
                else:
                    _touch(touched, tcount, v)
                    if morph > 0 and dying[v] != 0:
                        op += 1
                        _stop_descent(split, v, n, N, g, mark, (stamp << 32) + op, fm_order,
                                      fm_stack, dying)
    for i in range(alive_count if walk else 0):
        v = alive[i]
        h, sq = _geometry(v // N, v % N, n, g)
        virtual = (not sq) and h == 1
        mergeable = True
        half = False  # a triangle with two leaf children: Samec's merge unit
        for k in range(2):
            if g[k, 0] < 0:
                continue
            free = True
            for e in range(2, 4):
                if virtual:
                    continue
                m = ((g[k, 0] + g[e, 0]) // 2) * N + (g[k, 1] + g[e, 1]) // 2
                if split[m]:
                    mergeable = False
                    free = False
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
                        _touch(touched, tcount, m)
                        far = travel + _slack(wedge, spacing, m, N, eye, lam, tau)
                        f32 = np.float32(far)
                        if f32 > far:
                            f32 = np.nextafter(f32, np.float32(-np.inf))
                        until[m] = f32
            half = half or free
        if mergeable or (half and samec and not every):
            q = _score(wedge, spacing, v, N, eye, planes, lam, cull)
            if every or q <= tau:
                mk, mv = _reserve(mk, mv, nm, 1)
                nm = _push(mk, mv, nm, q, v)
                qm[v] = stamp
            else:
                _touch(touched, tcount, v)
                if morph > 0 and dying[v] != 0:
                    op += 1
                    _stop_descent(split, v, n, N, g, mark, (stamp << 32) + op, fm_order,
                                  fm_stack, dying)
    if split[centre] == 0:
        q = _score(wedge, spacing, centre, N, eye, planes, lam, cull)
        sk, sv = _reserve(sk, sv, ns, 1)
        ns = _push(sk, sv, ns, -q, centre)
        qs[centre] = stamp
    splits = merges = forced = exchanges = 0
    forced_merges = forced_merged = refused = 0
    blocked = 0
    # Merge phase: diamonds whose own priority meets tau, and any while over the budget.
    while nm > 0 and (mk[0] <= tau or leaves > budget):
        p, v = mk[0], mv[0]
        nm = _pop(mk, mv, nm)
        qm[v] = 0
        if not _mergeable(split, v, n, N, g):
            if every or not samec or p > tau or not _half_mergeable(split, v, n, N, g):
                continue
            op += 1
            sk, sv, ns, mk, mv, nm, low, removed, count = _force_merge(
                wedge, spacing, n, N, split, qs, qm, stamp, v, p, eye, planes, lam, tau,
                cull, sk, sv, ns, mk, mv, nm, low, g, g2, touched, tcount, changed, mark,
                (stamp << 32) + op, fm_order, fm_stack, dying, clock, morph)
            if count < 0:
                refused += 1
            elif count:
                leaves -= removed
                merges += count
                forced_merges += 1
                forced_merged += count
            continue
        if morph > 0 and p <= tau and _score(wedge, spacing, v, N, eye, planes, lam,
                                             False) > tau:
            dying[v] = 0  # <= tau only because culled: out of view, it merges at once
        elif morph > 0 and p <= tau:
            if dying[v] == 0:
                dying[v] = clock
            if clock - dying[v] < morph:
                _touch(touched, tcount, v)  # still lowering its vertex: look again next frame
                continue
        if morph > 0:
            dying[v] = 0
        sk, sv = _reserve(sk, sv, ns, 1)
        mk, mv = _reserve(mk, mv, nm, 2)
        ns, nm, low, removed = _merge(
            wedge, spacing, n, N, split, qs, qm, stamp, v, p, eye, planes, lam, tau, cull,
            every, sk, sv, ns, mk, mv, nm, low, g, g2, touched, tcount, changed,
            samec and not every)
        leaves -= removed
        merges += 1
    # Split phase: the highest-priority leaf diamond, after its forced chain, while > tau.
    order = np.empty(64 * (n + 2), np.int64)
    stack = np.empty(64 * (n + 2), np.int64)
    born_count = 0
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
                        tau, cull, every, sk, sv, ns, mk, mv, nm, low, g, g2, touched, tcount, changed)
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
            _touch(changed, tcount[2:], x)
            if morph > 0:  # its parents have a split child now: they stop dying
                _geometry(x // N, x % N, n, g)
                for k2 in range(2):
                    if g[k2, 0] >= 0:
                        dying[g[k2, 0] * N + g[k2, 1]] = 0
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
                                     planes, lam, tau, cull, every, sk, sv, ns, low, g,
                                     touched, tcount)
            if not every:
                _touch(touched, tcount, x)  # newly mergeable, above tau: wake it later
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
    if deferred or not walk:
        remaining = max(remaining, tau)  # the deferred ones are known to be <= tau only
    stats[3], stats[4], stats[5] = remaining, exchanges, blocked
    stats[7] = deferred
    stats[8], stats[9], stats[10] = forced_merges, forced_merged, refused
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


@njit(cache=True)
def _rewake(wedge, spacing, n, split, touched, count, eye, lam, tau, travel, hk, hv, hsize,
            wake_at, parked, pcount, parked_at, samec):
    """Push each recorded candidate with the travel at which its priority may first cross
    tau (wedgie box distance d, priority lam e / d changes only as d does, and d by at most
    the eye's travel): a split candidate at travel + d - lam e / tau, a merge candidate at
    travel + lam e / tau - d. Culling can lower a priority to 0 at once (turning): merges of
    diamonds that left the frustum wait for their wake-up, splits never do (the bound is the
    unculled priority). A split candidate whose unculled priority is above tau (it was
    <= tau only because its box was outside the frustum) would be due at once, every frame:
    it is parked instead (parked[:pcount[0]], parked_at[v] = 1), and _frame only tests its
    box against the frustum each frame (no heap traffic, no scoring) until it comes into
    view. hk/hv must have room for count more entries."""
    N = int(np.sqrt(wedge.shape[0]))
    g = np.empty((4, 2), np.int64)
    for i in range(count):
        v = touched[i]
        x0, x1, z0, z1, y0, y1 = _box(wedge, v, N)
        dx = max(x0 * spacing - eye[0], 0.0, eye[0] - x1 * spacing)
        dy = max(y0 - eye[1], 0.0, eye[1] - y1)
        dz = max(z0 * spacing - eye[2], 0.0, eye[2] - z1 * spacing)
        d = np.sqrt(dx * dx + dy * dy + dz * dz)
        reach = lam * wedge[v, 2] / tau
        if _candidate(split, v, n, N, g):
            wake = travel + d - reach
            if wake <= travel:  # <= tau only because culled: parked, checked each frame
                if parked_at[v] == 0 and pcount[0] < parked.shape[0]:
                    parked_at[v] = 1
                    parked[pcount[0]] = v
                    pcount[0] += 1
                if parked_at[v]:
                    wake_at[v] = -1.0
                    continue
        elif (_half_mergeable(split, v, n, N, g) if samec  # forced-merge candidates
              else _mergeable(split, v, n, N, g)):
            if wedge[v, 2] <= 0.0:
                continue
            wake = travel + reach - d
        else:
            continue
        wake_at[v] = wake
        hsize[0] = _push(hk, hv, hsize[0], wake, v)

"""Temporal bounding volumes (Sudarsky and Gotsman 1996, "Output-sensitive visibility
algorithms for dynamic scenes"): a box that holds a moving object over a whole time interval, so
a frame need not pose every object, only those whose interval box may be seen.

For a track at time t the interval is the one in which every channel stays within one of its
key segments: [the latest key at or before t, the earliest key after t] over its channels (for a
looping track in its own time, ending at its duration at most), cut to the SPAN-second window
holding t. Within it each channel runs between two values: translation linearly (inside the
box of its values at the interval's ends), scale linearly (its
magnitude at most the larger key's largest |component|), rotation along the slerp arc (a turn:
lengths kept). With q = pre v for a vertex v of the rest box B, the moved point post (T + R S q)
lies in post(hull(T_a, T_b) + R S pre(B)) when rotation and scale stay fixed over the interval
(steps, equal keys: the exact moved box); when only the rotation turns, in post(hull(T_a, T_b)
+ the box of the circles that the corners of R_a S pre(B) run on about the turn's axis)
(_arc_box: a walker turning about +y keeps its height); else in post(hull(T_a, T_b) +
ball(0, s_max max|q|)).
Boxes are padded outward by SWEEP_PAD relative to their terms' magnitudes (the per-frame matrices
round differently). Contract: for every t in [valid_from, valid_until) the object's exact box
at t (animated.moved_boxes) lies inside its swept box.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from .motion import key_bracket, rotation_scale

SWEEP_PAD = 2.0 ** -30
# Intervals are cut to windows of this many seconds (in each track's own time, staggered by a
# per-track phase so that the sweeps spread over the frames), and translation is bounded over
# the window only: tighter boxes (W2's walkers, 1,000 instances: 198 -> 180 candidates a frame
# at 0.5 s) for one sweep per object every SPAN seconds. With the turn's axis bound
# (_arc_box; W2 + 1,000 walkers, 120 path frames, thread time beside the static vfc, load 7):
# 1 s / 2 s / 4 s windows: sweeps 65.5 / 49.4 / 41.4 a frame, candidates 158 / 170 / 177, the
# update 60.9 / 53.1 / 50.3 us (0.5 s before the axis bound: 97.8 sweeps, 178 candidates).
SPAN = 2.0


@njit(cache=True, nogil=True, inline="always")
def _span(times, a, b, t, step):
    """(lo, hi, from, until) of keys times[a:b] around t: the channel runs between keys lo and
    hi (equal: held) over [from, until); lo = -1 without keys."""
    if a == b:
        return -1, -1, -np.inf, np.inf
    if t < times[a]:
        return a, a, -np.inf, times[a]
    if t >= times[b - 1]:
        return b - 1, b - 1, times[b - 1], np.inf
    lo, hi = key_bracket(times, a, b - 1, t)
    if step:
        return lo, lo, times[lo], times[hi]
    return lo, hi, times[lo], times[hi]


@njit(cache=True, nogil=True)
def _arc_box(rv, r0, r1, sv, s0, q, m, box):
    """The box of R S q over the rotation's slerp from key r0 to key r1 (scale fixed: key s0,
    none when s0 < 0), q the box q (2, 3): writes box (2, 3), returns False (box untouched)
    when the turn's axis is undefined (a turn of ~0). The slerp is R(u) = Rot(a, u angle) R0
    with a the axis of q1' q0^-1 (q1' = q1 on the shortest arc; the nearly-equal lerp keeps to
    the same great circle): each corner p = R0 S c runs on a circle about a, whose coordinate j
    stays within (p . a) a_j +- |p - (p . a) a| sqrt(1 - a_j^2); the object, a convex
    combination of its box's corners, stays in the box of the corners' circles."""
    x0, y0, z0, w0 = rv[r0, 0], rv[r0, 1], rv[r0, 2], rv[r0, 3]
    x1, y1, z1, w1 = rv[r1, 0], rv[r1, 1], rv[r1, 2], rv[r1, 3]
    if x0 * x1 + y0 * y1 + z0 * z1 + w0 * w1 < 0:
        x1, y1, z1, w1 = -x1, -y1, -z1, -w1
    # vector part of q1 q0^-1: w0 v1 - w1 v0 - v1 x v0
    ax = w0 * x1 - w1 * x0 - (y1 * z0 - z1 * y0)
    ay = w0 * y1 - w1 * y0 - (z1 * x0 - x1 * z0)
    az = w0 * z1 - w1 * z0 - (x1 * y0 - y1 * x0)
    length = np.sqrt(ax * ax + ay * ay + az * az)
    if not length > 1e-9:
        return False
    ax, ay, az = ax / length, ay / length, az / length
    sx = sy = sz = 1.0
    if s0 >= 0:
        sx, sy, sz = sv[s0, 0], sv[s0, 1], sv[s0, 2]
    rotation_scale(x0, y0, z0, w0, sx, sy, sz, m)
    spread = np.empty(3)
    spread[0] = np.sqrt(max(1.0 - ax * ax, 0.0))
    spread[1] = np.sqrt(max(1.0 - ay * ay, 0.0))
    spread[2] = np.sqrt(max(1.0 - az * az, 0.0))
    for r in range(3):
        box[0, r], box[1, r] = np.inf, -np.inf
    for corner in range(8):
        cx, cy, cz = q[corner & 1, 0], q[(corner >> 1) & 1, 1], q[(corner >> 2) & 1, 2]
        px = m[0, 0] * cx + m[0, 1] * cy + m[0, 2] * cz
        py = m[1, 0] * cx + m[1, 1] * cy + m[1, 2] * cz
        pz = m[2, 0] * cx + m[2, 1] * cy + m[2, 2] * cz
        along = px * ax + py * ay + pz * az
        ex, ey, ez = px - along * ax, py - along * ay, pz - along * az
        radius = np.sqrt(ex * ex + ey * ey + ez * ez)
        for r, a in ((0, ax), (1, ay), (2, az)):
            centre = along * a
            box[0, r] = min(box[0, r], centre - radius * spread[r])
            box[1, r] = max(box[1, r], centre + radius * spread[r])
    return True


@njit(cache=True, nogil=True)
def swept_boxes(t, rows, loop, duration, step, tt, tv, ts, rt, rv, rs, st, sv, ss, pre, post,
                rest, out, valid_from, valid_until, span=SPAN):
    """For each k in rows: out[k] (2, 3) the box holding track k's object (rest box rest[k])
    over its interval around time t, valid_from[k] / valid_until[k] that interval in global
    time (module docstring). Returns the largest |coordinate| of the boxes written."""
    most = 0.0
    q = np.empty((2, 3))
    box = np.empty((2, 3))
    m = np.empty((3, 3))
    for i in range(len(rows)):
        k = rows[i]
        local, base = t, 0.0
        if loop[k] and duration[k] > 0:
            local = t - np.floor(t / duration[k]) * duration[k]
            base = t - local
        t0, t1, t2, t3 = _span(tt, ts[k], ts[k + 1], local, step[k])
        r0, r1, r2, r3 = _span(rt, rs[k], rs[k + 1], local, step[k])
        s0, s1, s2, s3 = _span(st, ss[k], ss[k + 1], local, step[k])
        start = max(t2, max(r2, s2))
        until = min(t3, min(r3, s3))
        if loop[k] and duration[k] > 0:
            start, until = max(start, 0.0), min(until, duration[k])
        if span > 0:  # windows staggered per track: sweeps spread over the frames
            phase = (k * 0.6180339887498949) % 1.0 * span
            window = np.floor((local - phase) / span) * span + phase
            start, until = max(start, window), min(until, window + span)
        valid_from[k] = start + base
        valid_until[k] = until + base
        # pre applied to the rest box, and the largest |q| over it
        reach = 0.0
        for r in range(3):
            lo, hi, mag = pre[k, r, 3], pre[k, r, 3], abs(pre[k, r, 3])
            for c in range(3):
                a, b = pre[k, r, c] * rest[k, 0, c], pre[k, r, c] * rest[k, 1, c]
                lo += min(a, b)
                hi += max(a, b)
            q[0, r], q[1, r] = lo, hi
            reach += max(lo * lo, hi * hi)
        reach = np.sqrt(reach)
        # scale: fixed, and its largest magnitude
        fixed = True
        smax = 1.0
        if s0 >= 0:
            smax = 0.0
            for c in range(3):
                smax = max(smax, abs(sv[s0, c]), abs(sv[s1, c]))
                fixed = fixed and sv[s0, c] == sv[s1, c]
        if r0 >= 0:
            same = True
            flip = True
            for c in range(4):
                same = same and rv[r0, c] == rv[r1, c]
                flip = flip and rv[r0, c] == -rv[r1, c]
            fixed = fixed and (same or flip)
        turning = False
        if not fixed and r0 >= 0 and r0 != r1:  # only the rotation may change
            turning = True
            for c in range(3):
                turning = turning and (s0 < 0 or sv[s0, c] == sv[s1, c])
        if turning:
            turning = _arc_box(rv, r0, r1, sv, s0, q, m, box)
        if fixed:
            x, y, z, w = 0.0, 0.0, 0.0, 1.0
            if r0 >= 0:
                x, y, z, w = rv[r0, 0], rv[r0, 1], rv[r0, 2], rv[r0, 3]
            sx = sy = sz = 1.0
            if s0 >= 0:
                sx, sy, sz = sv[s0, 0], sv[s0, 1], sv[s0, 2]
            rotation_scale(x, y, z, w, sx, sy, sz, m)
            for r in range(3):
                lo = hi = 0.0
                for c in range(3):
                    a, b = m[r, c] * q[0, c], m[r, c] * q[1, c]
                    lo += min(a, b)
                    hi += max(a, b)
                box[0, r], box[1, r] = lo, hi
        elif not turning:
            for r in range(3):
                box[0, r], box[1, r] = -smax * reach, smax * reach
        if t0 >= 0:  # plus the translation's hull over [start, until] (linear in between)
            ua = ub = 0.0
            if t1 != t0:
                gap = tt[t1] - tt[t0]
                ua = min(max((start - tt[t0]) / gap, 0.0), 1.0)
                ub = min(max((until - tt[t0]) / gap, 0.0), 1.0)
            for r in range(3):
                a = tv[t0, r] + ua * (tv[t1, r] - tv[t0, r])
                b = tv[t0, r] + ub * (tv[t1, r] - tv[t0, r])
                box[0, r] += min(a, b)
                box[1, r] += max(a, b)
        for r in range(3):  # post, an affine map: the moved box, padded
            lo, hi, mag = post[k, r, 3], post[k, r, 3], abs(post[k, r, 3])
            for c in range(3):
                a, b = post[k, r, c] * box[0, c], post[k, r, c] * box[1, c]
                lo += min(a, b)
                hi += max(a, b)
                mag += max(abs(a), abs(b))
            mag += smax * reach
            out[k, 0, r] = lo - SWEEP_PAD * mag
            out[k, 1, r] = hi + SWEEP_PAD * mag
            most = max(most, abs(out[k, 0, r]), abs(out[k, 1, r]))
    return most


@njit(cache=True, nogil=True)
def expired(t, valid_from, valid_until, out):
    """Writes to out the tracks whose interval does not hold t; returns their count."""
    count = 0
    for k in range(len(valid_from)):
        if not (valid_from[k] <= t < valid_until[k]):
            out[count] = k
            count += 1
    return count


# A track's baked intervals at most (more: it is swept at run time instead).
TABLE_LIMIT = 4096


@njit(cache=True, nogil=True, inline="always")
def _key_range(times, a, b, low, high):
    """(low, high) widened by the keys times[a:b]."""
    if a < b:
        low, high = min(low, times[a]), max(high, times[b - 1])
    return low, high


@njit(cache=True, nogil=True)
def _bake_track(k, loop, duration, step, tt, tv, ts, rt, rv, rs, st, sv, ss, pre, post, rest,
                span, row, box, valid_from, valid_until, lo_out, hi_out, box_out, at, limit):
    """Track k's intervals in its own time, in order, written from index `at` of lo_out,
    hi_out (I,) and box_out (I, 2, 3) (when they are long enough: a counting pass passes
    empty ones); returns how many (limit + 1 when more than limit). A looping track steps
    through [0, duration); another through [first key, last key), with one interval before and
    one after (every channel held: its box the same whatever the window). Each is what
    swept_boxes gives for a time in it (the same call)."""
    row[0] = k
    count = 0
    low, high = np.inf, -np.inf
    low, high = _key_range(tt, ts[k], ts[k + 1], low, high)
    low, high = _key_range(rt, rs[k], rs[k + 1], low, high)
    low, high = _key_range(st, ss[k], ss[k + 1], low, high)
    wraps = loop[k] and duration[k] > 0
    if not wraps and low > high:  # no keys: the rest pose, always
        swept_boxes(0.0, row, loop, duration, step, tt, tv, ts, rt, rv, rs, st, sv, ss, pre,
                    post, rest, box, valid_from, valid_until, span)
        if at < len(lo_out):
            lo_out[at], hi_out[at], box_out[at] = -np.inf, np.inf, box[k]
        return 1
    if wraps:
        t, end = 0.0, duration[k]
    else:
        t, end = low, high
        swept_boxes(np.nextafter(low, -np.inf), row, loop, duration, step, tt, tv, ts, rt, rv, rs, st, sv, ss,
                    pre, post, rest, box, valid_from, valid_until, span)
        if at < len(lo_out):
            lo_out[at], hi_out[at], box_out[at] = -np.inf, low, box[k]
        count = 1
    while t < end:
        swept_boxes(t, row, loop, duration, step, tt, tv, ts, rt, rv, rs, st, sv, ss, pre,
                    post, rest, box, valid_from, valid_until, span)
        start, until = valid_from[k], valid_until[k]
        if not (start <= t < until):  # rounding at a window's edge: skip one ulp
            t = np.nextafter(t, np.inf)
            continue
        if count >= limit:
            return limit + 1
        if at + count < len(lo_out):
            lo_out[at + count], hi_out[at + count] = start, until
            box_out[at + count] = box[k]
        count += 1
        t = until
    if not wraps:
        swept_boxes(high, row, loop, duration, step, tt, tv, ts, rt, rv, rs, st, sv, ss, pre,
                    post, rest, box, valid_from, valid_until, span)
        if count >= limit:
            return limit + 1
        if at + count < len(lo_out):
            lo_out[at + count], hi_out[at + count] = high, np.inf
            box_out[at + count] = box[k]
        count += 1
    return count


@njit(cache=True, nogil=True)
def bake_intervals(loop, duration, step, tt, tv, ts, rt, rv, rs, st, sv, ss, pre, post, rest,
                   span, limit):
    """Every track's swept boxes over its whole time, baked once: (start (M + 1,) int64,
    lo (I,), hi (I,) float64 each interval in the track's own time, boxes (I, 2, 3)); track k's
    intervals are start[k]:start[k + 1], in order, each holding what swept_boxes writes for a
    time in it. A track with more than `limit` intervals has none (lookup falls back to
    sweeping it)."""
    m = len(loop)
    row = np.zeros(1, dtype=np.int64)
    box = np.empty((m, 2, 3))
    valid_from, valid_until = np.empty(m), np.empty(m)
    none = np.empty(0)
    counts = np.empty(m, dtype=np.int64)
    for k in range(m):
        n = _bake_track(k, loop, duration, step, tt, tv, ts, rt, rv, rs, st, sv, ss, pre, post,
                        rest, span, row, box, valid_from, valid_until, none, none,
                        np.empty((0, 2, 3)), 0, limit)
        counts[k] = n if n <= limit else 0
    start = np.zeros(m + 1, dtype=np.int64)
    for k in range(m):
        start[k + 1] = start[k] + counts[k]
    lo, hi = np.empty(start[m]), np.empty(start[m])
    boxes = np.empty((start[m], 2, 3))
    for k in range(m):
        if counts[k]:
            _bake_track(k, loop, duration, step, tt, tv, ts, rt, rv, rs, st, sv, ss, pre, post,
                        rest, span, row, box, valid_from, valid_until, lo, hi, boxes, start[k],
                        limit)
    return start, lo, hi, boxes


@njit(cache=True, nogil=True)
def baked_boxes(t, rows, loop, duration, start, lo, hi, boxes, out, valid_from, valid_until,
                missed):
    """swept_boxes for rows (K,) from the baked intervals (bake_intervals): out[k] and the
    interval in global time for each k found; the rows without a baked interval holding t are
    written to missed (sweep them); returns their count."""
    n = 0
    for i in range(len(rows)):
        k = rows[i]
        local, base = t, 0.0
        if loop[k] and duration[k] > 0:
            local = t - np.floor(t / duration[k]) * duration[k]
            base = t - local
        a, b = start[k], start[k + 1]
        if a == b or local < lo[a]:
            missed[n] = k
            n += 1
            continue
        while b - a > 1:  # the last interval starting at or before local
            mid = (a + b) // 2
            if lo[mid] <= local:
                a = mid
            else:
                b = mid
        if not local < hi[a]:
            missed[n] = k
            n += 1
            continue
        valid_from[k], valid_until[k] = lo[a] + base, hi[a] + base
        for j in range(3):
            out[k, 0, j], out[k, 1, j] = boxes[a, 0, j], boxes[a, 1, j]
    return n

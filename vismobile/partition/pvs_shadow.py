"""Occluder shadows from sample points, fused (Wonka, Wimmer and Schmalstieg 2000: occluder
shrinking for 2.5D cities), the kernels of the outdoor PVS (pvs_street.py).

From one sample point s, a front wall a -> b of a column (pvs_columns.py) whose footprint was
shrunk by r hides every point q seen from s (x-z) between the directions of b and a, at least
the wall's line away, lying below the line from s over the wall's top: the line s -> q crosses
the wall below its top (the column is taller than s) and above its base. In x-z polar
coordinates around s, per direction bin that the wedge wholly covers, the wall becomes one step
(start, slope): a point of the bin at distance d >= start below sy + slope d is hidden, with
the wall's line taken at its farthest over the bin (the least slope, the latest start). The
steps of all walls fuse into a staircase per bin (a point under any one step is hidden). A
triangle is hidden from s when, over every bin its x-z shadow spans, its highest corner is
below sy + slope dmin for a step starting within dmin (its least x-z distance from s; a rising
step's height only grows farther out, a falling one's is taken at the triangle's farthest
corner). A column no taller than s (a fly-over cell's, pvs_fly.py) hides through its exit
walls instead: a line from s leaving the footprint below the top passed through it. A view
cell's hidden set is what every sample hides.

Conservative, with the constants pvs_street.py derives (shrinking by the samples' spacing,
the push-back `slack` x the distance + `extra` for the depth buffer, ANGLE_SLACK around the
angles for atan2's rounding); the argument is in pvs_street.py's docstring.
"""
from __future__ import annotations

import numpy as np
from numba import njit


def erode(footprint, r):
    """(H, 2) the convex counter-clockwise footprint with every edge moved in by r, or None when
    it would vanish or an edge would turn over."""
    a = np.asarray(footprint, dtype=np.float64)
    b = np.roll(a, -1, axis=0)
    edge = b - a
    length = np.hypot(edge[:, 0], edge[:, 1])
    inward = np.column_stack([-edge[:, 1], edge[:, 0]]) / length[:, None]
    offset = np.einsum("ij,ij->i", inward, a) + r  # inward . x = offset on the moved line
    out = np.empty_like(a)
    for k in range(len(a)):
        j = k - 1  # vertex k joins the moved edges k - 1 and k
        m = np.array([inward[j], inward[k]])
        det = np.linalg.det(m)
        if abs(det) < 1e-12:
            return None
        out[k] = np.linalg.solve(m, [offset[j], offset[k]])
    moved = np.roll(out, -1, axis=0) - out
    if (np.einsum("ij,ij->i", moved, edge) <= 0).any():
        return None
    return out


BINS = 2048  # directions around a sample point (0.18 degrees each)
PAIRS = 8  # (start, slope) steps kept per direction
ANGLE_SLACK = 1e-9  # radians: atan2's and the bins' rounding (about 1e-15) many times over


@njit(cache=True, inline="always")
def _insert(starts, slopes, count, b, st, sl):
    """Add the step (st, sl) to direction b's staircase (starts ascending, slopes ascending,
    none dominating another); when full, the step starting farthest goes (less shadow)."""
    k = count[b]
    for i in range(k):
        if starts[b, i] <= st and slopes[b, i] >= sl:
            return  # dominated
    j = 0
    for i in range(k):  # drop the steps the new one dominates
        if not (starts[b, i] >= st and slopes[b, i] <= sl):
            starts[b, j] = starts[b, i]
            slopes[b, j] = slopes[b, i]
            j += 1
    k = j
    if k == starts.shape[1]:
        if starts[b, k - 1] <= st:
            return
        k -= 1
    i = k
    while i > 0 and starts[b, i - 1] > st:
        starts[b, i] = starts[b, i - 1]
        slopes[b, i] = slopes[b, i - 1]
        i -= 1
    starts[b, i] = st
    slopes[b, i] = sl
    count[b] = k + 1


@njit(cache=True)
def sample_steps(sx, sy, sz, polys, starts, tops, use, slack, extra, steps, slopes, count,
                 cosines, sines):
    """The fused shadows of the shrunk columns' walls from the sample (sx, sy, sz), per
    direction bin b (angle atan2(dz, dx) in [-pi + b 2 pi / BINS, + 2 pi / BINS)): steps
    (start, slope): a point in the bin at distance d >= start (x-z) below sy + slope d is hidden.
    Only bins wholly inside a wall's wedge take it; start is taken where the wall's line is
    farthest over the bin, pushed back by slack and extra.

    A column taller than the sample hides through its front walls (the sample outside their
    line): a line below the wall's top where it crosses it, slope (top - sy) / the farthest
    crossing. A column no taller than the sample hides through its exit walls (the sample on
    their inner side, whether above the roof or beside the column): a descending line that
    leaves the footprint below the top passed through the prism (it entered through the roof
    or a front wall, nearer still), slope (top - sy) / the nearest crossing (<= 0: the least
    shadow over the bin).

    polys : (V, 2) shrunk footprints' corners (x, z), counter-clockwise, column k's at
            starts[k]..starts[k + 1]; tops (N,) their tops (lowered by the bake's slack),
            used where use[k]; cosines, sines (BINS + 1,) of the bins' edge angles
    """
    count[:] = 0
    width = 2.0 * np.pi / BINS
    for k in range(len(tops)):
        if not use[k]:
            continue
        h = tops[k]
        tall = h > sy
        first, last = starts[k], starts[k + 1]
        for e in range(first, last):
            ax, az = polys[e, 0], polys[e, 1]
            f = e + 1 if e + 1 < last else first
            bx, bz = polys[f, 0], polys[f, 1]
            ex, ez = bx - ax, bz - az
            length = np.sqrt(ex * ex + ez * ez)
            nx, nz = -ez / length, ex / length  # inward normal (left of a -> b)
            d = nx * (ax - sx) + nz * (az - sz)  # > 0: a front wall, its inside beyond it
            if tall:
                if not d > 0.0:
                    continue
                # seen from outside, a -> b turns clockwise: the wedge runs from b to a
                lo = np.arctan2(bz - sz, bx - sx)
                hi = np.arctan2(az - sz, ax - sx)
            else:
                if not d < 0.0:
                    continue
                # an exit wall: seen from its inner side a -> b turns counter-clockwise
                nx, nz, d = -nx, -nz, -d  # the outward normal, the distance to the line
                lo = np.arctan2(az - sz, ax - sx)
                hi = np.arctan2(bz - sz, bx - sx)
            if hi < lo:
                hi += 2.0 * np.pi
            if hi - lo >= np.pi:
                continue
            b0 = int(np.ceil((lo + ANGLE_SLACK + np.pi) / width))
            b1 = int(np.floor((hi - ANGLE_SLACK + np.pi) / width))
            for b in range(b0, b1):  # bins [b, b + 1] wholly inside [ta, tb]
                m = b % BINS
                c0 = nx * cosines[m] + nz * sines[m]
                c1 = nx * cosines[m + 1] + nz * sines[m + 1]
                c = min(c0, c1)
                if not c > 0.0:
                    continue
                far = d / c  # the wall's line at its farthest over the bin
                at = far if tall else d / max(c0, c1)  # the least shadow's crossing
                _insert(steps, slopes, count, b % BINS, far * (1.0 + slack) + extra,
                        (h - sy) / at)


@njit(cache=True, inline="always")
def _edge_distance(ax, az, bx, bz):
    """Distance from the origin to the segment a-b (x-z)."""
    ex, ez = bx - ax, bz - az
    ll = ex * ex + ez * ez
    u = 0.0 if ll == 0.0 else min(max(-(ax * ex + az * ez) / ll, 0.0), 1.0)
    qx, qz = ax + u * ex, az + u * ez
    return np.sqrt(qx * qx + qz * qz)


@njit(cache=True, inline="always")
def _wrap(r):
    """An angle difference into [-pi, pi]."""
    if r > np.pi:
        return r - 2.0 * np.pi
    if r < -np.pi:
        return r + 2.0 * np.pi
    return r


@njit(cache=True, inline="always")
def _polygon_hidden(xs, zs, n, top, sy, steps, slopes, count):
    """The convex x-z polygon (xs, zs)[:n] (relative to the sample, either winding), up to
    height top, is hidden by the steps: the sample is outside it, and over every direction bin
    its shadow spans (widened by ANGLE_SLACK) some step starting within dmin, its least x-z
    distance from the sample, is above top all over it: sy + slope dmin > top for a rising
    step, sy + slope dmax > top for a falling one (dmax: its farthest corner)."""
    width = 2.0 * np.pi / BINS
    positive = True
    negative = True
    dmin = np.inf
    dmax = 0.0
    for i in range(n):
        j = (i + 1) % n
        c = xs[i] * zs[j] - zs[i] * xs[j]
        positive = positive and c >= 0.0
        negative = negative and c <= 0.0
        dmin = min(dmin, _edge_distance(xs[i], zs[i], xs[j], zs[j]))
        dmax = max(dmax, np.sqrt(xs[i] * xs[i] + zs[i] * zs[i]))
    if positive or negative or not dmin > 0.0:  # the sample inside or on it
        return False
    a0 = np.arctan2(zs[0], xs[0])
    lo, hi = 0.0, 0.0
    for i in range(1, n):
        r = _wrap(np.arctan2(zs[i], xs[i]) - a0)
        lo, hi = min(lo, r), max(hi, r)
    b0 = int(np.floor((a0 + lo - ANGLE_SLACK + np.pi) / width))
    b1 = int(np.floor((a0 + hi + ANGLE_SLACK + np.pi) / width))
    for bb in range(b0, b1 + 1):
        b = bb % BINS
        best = -np.inf
        for i in range(count[b]):
            if steps[b, i] <= dmin:
                s = slopes[b, i]
                best = max(best, sy + s * (dmin if s >= 0.0 else dmax))
        if not (best > top):
            return False
    return True


@njit(cache=True)
def hidden_from_sample(sx, sy, sz, corners, groups, order, boxes, alive, margin, steps, slopes,
                       count):
    """alive (T,) bool: clear the triangles (corners (T, 3, 3)) the sample's shadow steps do
    not hide (_polygon_hidden of the x-z triangle up to its highest corner plus margin). The
    triangles come in groups (order[groups[g]:groups[g + 1]]) within x-z boxes (G, 5) (x0,
    z0, x1, z1, top): a group whose box is hidden keeps its triangles without testing them."""
    xs = np.empty(4)
    zs = np.empty(4)
    for g in range(len(groups) - 1):
        first, last = groups[g], groups[g + 1]
        some = False
        for k in range(first, last):
            if alive[order[k]]:
                some = True
                break
        if not some:
            continue
        if last - first > 1:
            xs[0], zs[0] = boxes[g, 0] - sx, boxes[g, 1] - sz
            xs[1], zs[1] = boxes[g, 2] - sx, boxes[g, 1] - sz
            xs[2], zs[2] = boxes[g, 2] - sx, boxes[g, 3] - sz
            xs[3], zs[3] = boxes[g, 0] - sx, boxes[g, 3] - sz
            if _polygon_hidden(xs, zs, 4, boxes[g, 4] + margin, sy, steps, slopes, count):
                continue
        for k in range(first, last):
            t = order[k]
            if not alive[t]:
                continue
            top = max(corners[t, 0, 1], max(corners[t, 1, 1], corners[t, 2, 1])) + margin
            for i in range(3):
                xs[i], zs[i] = corners[t, i, 0] - sx, corners[t, i, 2] - sz
            if not _polygon_hidden(xs, zs, 3, top, sy, steps, slopes, count):
                alive[t] = False


@njit(cache=True)
def cell_hidden(samples, polys, starts, tops, use, slack, extra, corners, groups, order, boxes,
                margin, hidden):
    """hidden (T,) bool, in place: True where it was and every sample's shadows hide it
    (triangle groups as hidden_from_sample's)."""
    steps = np.empty((BINS, PAIRS))
    slopes = np.empty((BINS, PAIRS))
    count = np.zeros(BINS, dtype=np.int64)
    edges = -np.pi + np.arange(BINS + 1) * (2.0 * np.pi / BINS)
    cosines, sines = np.cos(edges), np.sin(edges)
    for s in range(len(samples)):
        if not hidden.any():
            return
        sample_steps(samples[s, 0], samples[s, 1], samples[s, 2], polys, starts, tops, use,
                     slack, extra, steps, slopes, count, cosines, sines)
        hidden_from_sample(samples[s, 0], samples[s, 1], samples[s, 2], corners, groups, order,
                           boxes, hidden, margin, steps, slopes, count)


def triangle_groups(world, tile) -> tuple:
    """(groups (G + 1,) int64 offsets, order (T,) int64, boxes (G, 5) float64 x0, z0, x1, z1,
    top): the triangles grouped by object and by the tile x tile x-z square of their centroid,
    for hidden_from_sample."""
    cells = np.floor(world.centroids[:, [0, 2]] / tile).astype(np.int64)
    keys = np.column_stack([world.object_ids.astype(np.int64), cells])
    _, label = np.unique(keys, axis=0, return_inverse=True)
    label = label.reshape(-1)
    order = np.argsort(label, kind="stable").astype(np.int64)
    count = np.bincount(label)
    groups = np.concatenate([[0], np.cumsum(count)]).astype(np.int64)
    b = world.bounds
    boxes = np.empty((len(count), 5))
    low = np.full((len(count), 2), np.inf)
    high = np.full((len(count), 3), -np.inf)
    np.minimum.at(low, label, b[:, 0][:, [0, 2]])
    np.maximum.at(high, label, b[:, 1])
    boxes[:, 0], boxes[:, 1] = low[:, 0], low[:, 1]
    boxes[:, 2], boxes[:, 3], boxes[:, 4] = high[:, 0], high[:, 2], high[:, 1]
    return groups, order, boxes

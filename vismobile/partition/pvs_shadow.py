"""Occluder shadows from sample points, fused (Wonka, Wimmer and Schmalstieg 2000: occluder
shrinking for 2.5D cities), the kernels of the outdoor PVS (pvs_street.py).

From one sample point s, a column (pvs_columns.py) whose footprint was shrunk by r and is taller
than s hides every point q seen from s (x-z) inside the footprint's silhouette (the wedge of
directions its corners span), beyond its front walls, lying below the line from s over the
walls' top: the line s -> q enters the footprint through a front wall, below its top (the
column is taller than s) and above its base. In x-z polar coordinates around s, per direction
bin the silhouette wholly covers, the column becomes one step (start, slope): a point of the
bin at distance d >= start below sy + slope d is hidden, with the front walls taken at their
farthest over the bin (the least slope, the latest start); a bin holding a corner between two
front walls takes it too. A bin that the silhouette sides of two columns each cover in part,
the parts overlapping, takes the step that holds for both (the later start, the lesser slope).
The steps of all columns fuse into a staircase per bin (a point under any one step is hidden).
A triangle is hidden from s when, over every bin its x-z shadow spans, its highest corner is
below sy + slope dmin for a step starting within dmin, dmin being the least x-z distance from s
of the triangle's part in that bin (a rising step's height only grows farther out, a falling
one's is taken at the part's farthest point). A column no taller than s (a fly-over cell's,
pvs_fly.py) hides through its exit walls instead: a line from s leaving the footprint below the
top passed through it. A view cell's hidden set is what every sample hides.

Conservative, with the constants pvs_street.py derives (shrinking by the samples' spacing,
the push-back `slack` x the distance + `extra` for the depth buffer, ANGLE_SLACK around the
angles for atan2's rounding, WEDGE_SLACK and DISTANCE_SLACK around a triangle's part in a bin
for the clip's); the argument is in pvs_street.py's docstring.
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
PIECES = 4  # columns' partial covers kept per bin and side (sample_steps)
ANGLE_SLACK = 1e-9  # radians: atan2's and the bins' rounding (about 1e-15) many times over
WEDGE_SLACK = 1e-12  # radians: a bin's wedge widened for the clip's rounding (about 1e-16)
DISTANCE_SLACK = 1e-9  # relative: the clipped part's distances moved out (rounding ~1e-15)


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


@njit(cache=True, inline="always")
def _chain_far(front, n, ca, sa, cb, sb):
    """Over the directions from (ca, sa) to (cb, sb) inside a column's silhouette, the farthest
    x-z distance at which a ray from the sample enters the footprint: the greatest over its
    front walls (rows (nx, nz, d) of front[:n]: inward normal, distance to the line) of
    d / n.u at either end (n.u > 0 for every front wall along a ray that meets a convex
    footprint; inf when rounding says otherwise: no step)."""
    far = 0.0
    for i in range(n):
        c = min(front[i, 0] * ca + front[i, 1] * sa, front[i, 0] * cb + front[i, 1] * sb)
        if not c > 0.0:
            return np.inf
        far = max(far, front[i, 2] / c)
    return far


@njit(cache=True, inline="always")
def _piece(pieces, held, side, b, frac, start, slope):
    """Keep a column's partial cover of bin b (side 0: from frac to the bin's upper edge, 1:
    from its lower edge to frac; start, slope as a step's), PIECES per side and bin, the
    nearest starts kept."""
    k = held[side, b]
    if k == pieces.shape[2]:
        worst = 0
        for i in range(1, k):
            if pieces[side, b, i, 1] > pieces[side, b, worst, 1]:
                worst = i
        if pieces[side, b, worst, 1] <= start:
            return
        k = worst
    else:
        held[side, b] = k + 1
    pieces[side, b, k, 0] = frac
    pieces[side, b, k, 1] = start
    pieces[side, b, k, 2] = slope


@njit(cache=True)
def sample_steps(sx, sy, sz, polys, starts, tops, use, slack, extra, steps, slopes, count,
                 cosines, sines, front, pieces, held):
    """The fused shadows of the shrunk columns' walls from the sample (sx, sy, sz), per
    direction bin b (angle atan2(dz, dx) in [-pi + b 2 pi / BINS, + 2 pi / BINS)): steps
    (start, slope): a point in the bin at distance d >= start (x-z) below sy + slope d is hidden.
    start is taken where the walls are farthest over the bin, pushed back by slack and extra.

    A column taller than the sample hides through its front walls (the sample outside their
    line): a ray in a direction inside the column's silhouette (the wedge its footprint spans,
    ANGLE_SLACK in from each side) enters the footprint through a front wall, at most `far`
    away (_chain_far), so a line below sy + (top - sy) / far x d crosses that wall below its
    top: every bin wholly inside the silhouette takes the step (far (1 + slack) + extra,
    (top - sy) / far), a bin with a wall's corner in it included. The two bins the
    silhouette's sides cut are partly covered: each keeps the part (_piece), and after all
    columns a bin whose upper part one column covers and lower part another, the two parts
    overlapping, takes the step (the later start, the lesser slope) that holds on both.

    A column no taller than the sample hides through its exit walls (the sample on their
    inner side, whether above the roof or beside the column): a descending line that leaves
    the footprint below the top passed through the prism (it entered through the roof or a
    front wall, nearer still), slope (top - sy) / the nearest crossing (<= 0: the least shadow
    over the bin); only bins wholly inside one exit wall's wedge take it.

    polys : (V, 2) shrunk footprints' corners (x, z), counter-clockwise, column k's at
            starts[k]..starts[k + 1]; tops (N,) their tops (lowered by the bake's slack),
            used where use[k]; cosines, sines (BINS + 1,) of the bins' edge angles
    front : (H, 3) scratch, H >= a footprint's corners; pieces (2, BINS, PIECES, 3) and
            held (2, BINS) scratch (_piece)
    """
    count[:] = 0
    held[:] = 0
    width = 2.0 * np.pi / BINS
    for k in range(len(tops)):
        if not use[k]:
            continue
        h = tops[k]
        tall = h > sy
        first, last = starts[k], starts[k + 1]
        n = 0
        ref, lo_all, hi_all = 0.0, 0.0, 0.0
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
                if hi < lo:
                    hi += 2.0 * np.pi
                if n == 0:
                    ref, lo_all, hi_all = lo, lo, hi
                else:  # the front walls' wedges join into the silhouette (< pi wide)
                    r = _wrap(lo - ref)
                    lo_all = min(lo_all, ref + r)
                    hi_all = max(hi_all, ref + r + (hi - lo))
                front[n, 0], front[n, 1], front[n, 2] = nx, nz, d
                n += 1
                continue
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
                if not min(c0, c1) > 0.0:
                    continue
                _insert(steps, slopes, count, m, d / min(c0, c1) * (1.0 + slack) + extra,
                        (h - sy) / (d / max(c0, c1)))
        if n == 0 or hi_all - lo_all >= np.pi:
            continue
        lo_all += ANGLE_SLACK
        hi_all -= ANGLE_SLACK
        bs = int(np.floor((lo_all + np.pi) / width))  # the bins the silhouette's sides cut
        be = int(np.floor((hi_all + np.pi) / width))
        if not bs < be:
            continue  # within one bin
        rise = h - sy
        for b in range(bs + 1, be):  # bins wholly inside the silhouette
            m = b % BINS
            far = _chain_far(front, n, cosines[m], sines[m], cosines[m + 1], sines[m + 1])
            if far < np.inf:
                _insert(steps, slopes, count, m, far * (1.0 + slack) + extra, rise / far)
        m = bs % BINS  # covered from lo_all up to the bin's upper edge
        far = _chain_far(front, n, np.cos(lo_all), np.sin(lo_all), cosines[m + 1], sines[m + 1])
        if far < np.inf:
            _piece(pieces, held, 0, m, (lo_all + np.pi) / width - bs, far * (1.0 + slack) + extra,
                   rise / far)
        m = be % BINS  # covered from the bin's lower edge up to hi_all
        far = _chain_far(front, n, cosines[m], sines[m], np.cos(hi_all), np.sin(hi_all))
        if far < np.inf:
            _piece(pieces, held, 1, m, (hi_all + np.pi) / width - be, far * (1.0 + slack) + extra,
                   rise / far)
    for m in range(BINS):  # bins covered by two columns' parts together
        for i in range(held[0, m]):
            for j in range(held[1, m]):
                if pieces[0, m, i, 0] <= pieces[1, m, j, 0]:
                    _insert(steps, slopes, count, m, max(pieces[0, m, i, 1], pieces[1, m, j, 1]),
                            min(pieces[0, m, i, 2], pieces[1, m, j, 2]))


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
def _clip(xs, zs, n, nx, nz, ox, oz, out):
    """Sutherland-Hodgman: the convex polygon (xs, zs)[:n] clipped to the half-plane
    nx x + nz z >= 0, written to (ox, oz)[out:]; returns the new corner count."""
    m = out
    for i in range(n):
        j = i + 1 if i + 1 < n else 0
        a = nx * xs[i] + nz * zs[i]
        b = nx * xs[j] + nz * zs[j]
        if a >= 0.0:
            ox[m], oz[m] = xs[i], zs[i]
            m += 1
        if (a >= 0.0) != (b >= 0.0):
            t = a / (a - b)
            ox[m], oz[m] = xs[i] + t * (xs[j] - xs[i]), zs[i] + t * (zs[j] - zs[i])
            m += 1
    return m - out


@njit(cache=True, inline="always")
def _wedge_reach(xs, zs, n, c0, s0, c1, s1, cx, cz):
    """(dmin, dmax) x-z distances from the origin of the convex polygon (xs, zs)[:n] clipped to
    the wedge from direction (c0, s0) counter-clockwise to (c1, s1) (less than pi wide), or
    (inf, 0) when nothing is left; cx, cz (>= 2 n + 4) scratch. The clip's rounding is a few
    ulps of the coordinates, which the callers' relative margin covers."""
    h = len(cx) // 2  # the first clip's corners in cx[:h], the second's in cx[h:]
    m = _clip(xs, zs, n, -s0, c0, cx, cz, 0)  # left of the first direction
    if m == 0:
        return np.inf, 0.0
    k = h + _clip(cx, cz, m, s1, -c1, cx, cz, h)  # right of the second
    dmin, dmax = np.inf, 0.0
    for i in range(h, k):
        j = i + 1 if i + 1 < k else h
        dmin = min(dmin, _edge_distance(cx[i], cz[i], cx[j], cz[j]))
        dmax = max(dmax, np.sqrt(cx[i] * cx[i] + cz[i] * cz[i]))
    return dmin, dmax


@njit(cache=True, inline="always")
def _best(b, dmin, dmax, sy, steps, slopes, count):
    """The highest y a step of bin b hides all over [dmin, dmax] (-inf: none): sy + slope
    dmin for a rising step starting within dmin, sy + slope dmax for a falling one."""
    best = -np.inf
    for i in range(count[b]):
        if steps[b, i] <= dmin:
            s = slopes[b, i]
            best = max(best, sy + s * (dmin if s >= 0.0 else dmax))
    return best


@njit(cache=True, inline="always")
def _polygon_hidden(xs, zs, n, top, sy, steps, slopes, count, wedges, cx, cz):
    """The convex x-z polygon (xs, zs)[:n] (relative to the sample, either winding), up to
    height top, is hidden by the steps: the sample is outside it, and over every direction bin
    its shadow spans (widened by ANGLE_SLACK) some step starting within dmin, the least x-z
    distance from the sample of the polygon's part in that bin, is above top all over it:
    sy + slope dmin > top for a rising step, sy + slope dmax > top for a falling one (dmax:
    the part's farthest point). The part is the polygon clipped to the bin's wedge widened by
    WEDGE_SLACK (wedges (BINS, 4): its edge directions' cos, sin), its distances moved out by
    the relative DISTANCE_SLACK (dmin down, dmax up): the clip's rounding, many times over.
    The polygon's least and greatest distance over all bins are tried first (no clip)."""
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
        if _best(b, dmin, dmax, sy, steps, slopes, count) > top:
            continue
        near, far = _wedge_reach(xs, zs, n, wedges[b, 0], wedges[b, 1], wedges[b, 2],
                                 wedges[b, 3], cx, cz)
        if near == np.inf:
            continue  # the polygon misses the widened bin
        near *= 1.0 - DISTANCE_SLACK
        far *= 1.0 + DISTANCE_SLACK
        if not (_best(b, max(near, dmin), min(far, dmax), sy, steps, slopes, count) > top):
            return False
    return True


@njit(cache=True)
def hidden_from_sample(sx, sy, sz, corners, groups, order, boxes, alive, margin, steps, slopes,
                       count, wedges):
    """alive (T,) bool: clear the triangles (corners (T, 3, 3)) the sample's shadow steps do
    not hide (_polygon_hidden of the x-z triangle up to its highest corner plus margin). The
    triangles come in groups (order[groups[g]:groups[g + 1]]) within x-z boxes (G, 5) (x0,
    z0, x1, z1, top): a group whose box is hidden keeps its triangles without testing them."""
    xs = np.empty(4)
    zs = np.empty(4)
    cx = np.empty(16)
    cz = np.empty(16)
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
            if _polygon_hidden(xs, zs, 4, boxes[g, 4] + margin, sy, steps, slopes, count,
                               wedges, cx, cz):
                continue
        for k in range(first, last):
            t = order[k]
            if not alive[t]:
                continue
            top = max(corners[t, 0, 1], max(corners[t, 1, 1], corners[t, 2, 1])) + margin
            for i in range(3):
                xs[i], zs[i] = corners[t, i, 0] - sx, corners[t, i, 2] - sz
            if not _polygon_hidden(xs, zs, 3, top, sy, steps, slopes, count, wedges, cx, cz):
                alive[t] = False


@njit(cache=True)
def cell_hidden(samples, polys, starts, tops, use, slack, extra, corners, groups, order, boxes,
                margin, hidden):
    """hidden (T,) bool, in place: True where it was and every sample's shadows hide it
    (triangle groups as hidden_from_sample's)."""
    steps = np.empty((BINS, PAIRS))
    slopes = np.empty((BINS, PAIRS))
    count = np.zeros(BINS, dtype=np.int64)
    size = 3
    for k in range(len(starts) - 1):
        size = max(size, starts[k + 1] - starts[k])
    front = np.empty((size, 3))
    pieces = np.empty((2, BINS, PIECES, 3))
    held = np.zeros((2, BINS), dtype=np.int64)
    edges = -np.pi + np.arange(BINS + 1) * (2.0 * np.pi / BINS)
    cosines, sines = np.cos(edges), np.sin(edges)
    wedges = np.empty((BINS, 4))  # each bin's edge directions, widened by WEDGE_SLACK
    wedges[:, 0], wedges[:, 1] = np.cos(edges[:-1] - WEDGE_SLACK), np.sin(edges[:-1] - WEDGE_SLACK)
    wedges[:, 2], wedges[:, 3] = np.cos(edges[1:] + WEDGE_SLACK), np.sin(edges[1:] + WEDGE_SLACK)
    for s in range(len(samples)):
        if not hidden.any():
            return
        sample_steps(samples[s, 0], samples[s, 1], samples[s, 2], polys, starts, tops, use,
                     slack, extra, steps, slopes, count, cosines, sines, front, pieces, held)
        hidden_from_sample(samples[s, 0], samples[s, 1], samples[s, 2], corners, groups, order,
                           boxes, hidden, margin, steps, slopes, count, wedges)


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

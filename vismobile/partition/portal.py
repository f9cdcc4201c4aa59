"""Portal octree: irregular-grid cells, each with its own octree (depth 1..3), joined by portals
(Luebke & Georges 1995, "Portals and Mirrors") found from the geometry.

A portal is the part of a shared cell face a sight line from free space may cross. Each face is
cut into sample cells: a uniform grid refined with the coordinates of the axis-parallel edges on
the face, so wall ends, slabs and doorways fall on sample boundaries. A sample cell is blocked
only when all of it lies in the walls lying in the face, or in solid space: no triangle crosses
it and, along u or along v, the nearest triangle cut on both sides is seen from behind and
belongs to a closed, consistently wound, outward-facing part (solids.py: such a cell is inside
that part, a hollow wall, a slab or a closed object, and every line from outside crosses its
surface). Nothing else is assumed of winding: the inside of a room whose one-sided walls face
out, or of any open surface, is free space. Every other sample cell is open, however thin the
opening. The open cells of a face
are stored as a few rectangles covering them (convex polygons). The runtime
(culling/portals.py) leaves the portals to eyes in free space and culls without them elsewhere.
"""
from __future__ import annotations

import numpy as np

from . import grid
from .layout import make_partition
from .portal_edges import auto_edges, wall_edges
from .octree import check_depth, chain_levels, subdivide
from .solids import outward_solid_faces

# Samples along the longer side of a shared face when classifying its coverage.
FACE_SAMPLES = 64
# Cells of a portal grid: portals are found face by face between cell pairs.
MAX_PORTAL_CELLS = 4096
# Triangles within this fraction of the world's size of a face plane lie in it (walls).
THICKNESS = 1e-7
# Coordinates within this fraction of the world's size coincide (rounding noise).
COINCIDE = 1e-9
# Rectangles per face before one box per open region is stored instead.
MAX_RECTS = 8


def _components(open_mask):
    """(nu, nv) int64 4-connected component labels of open samples (-1 where closed)."""
    nu, nv = open_mask.shape
    big = nu * nv
    label = np.where(open_mask, np.arange(big).reshape(nu, nv), big)
    while True:
        new = label.copy()
        new[1:] = np.minimum(new[1:], np.where(open_mask[1:], label[:-1], big))
        new[:-1] = np.minimum(new[:-1], np.where(open_mask[:-1], label[1:], big))
        new[:, 1:] = np.minimum(new[:, 1:], np.where(open_mask[:, 1:], label[:, :-1], big))
        new[:, :-1] = np.minimum(new[:, :-1], np.where(open_mask[:, :-1], label[:, 1:], big))
        new = np.where(open_mask, new, big)
        flat = new.ravel()
        jumped = np.where(open_mask.ravel(), np.append(flat, big)[np.minimum(flat, big)], big)
        new = np.minimum(new, jumped.reshape(nu, nv))
        if np.array_equal(new, label):
            return np.where(open_mask, label, -1)
        label = new


def _snapped_heights(corners, axis, plane, thickness):
    """(n, 3) float64 corner heights above the plane, 0 within thickness of it."""
    h = corners[:, :, axis] - plane
    return np.where(np.abs(h) <= thickness, 0.0, h)


def plane_footprints(corners, axis, plane, thickness):
    """What each triangle leaves on the plane x[axis] = plane, in the (axis + 1, axis + 2) coords.

    Corners within thickness of the plane count as on it.
    corners   : (n, 3, 3) float64
    returns   : cu, cv (n, 3) float64 corner coordinates on the plane; flat (n,) bool (all
                corners within thickness of the plane: the triangle lies in it); crossing (n,)
                bool (corners strictly on both sides); seg (n, 2, 2) float64 [[u0, v0], [u1, v1]]
                the exact segment where a crossing triangle cuts the plane (zeros elsewhere);
                box (n, 2, 2) float64 [[u0, v0], [u1, v1]] bounds of the footprint (triangle or
                segment)
    """
    u_axis, v_axis = (axis + 1) % 3, (axis + 2) % 3
    h = _snapped_heights(corners, axis, plane, thickness)
    cu, cv = corners[:, :, u_axis], corners[:, :, v_axis]
    flat = (h == 0).all(axis=1)
    crossing = ~flat & (h.min(axis=1) < 0) & (h.max(axis=1) > 0)
    # Where each edge (0,1), (1,2), (2,0) meets h = 0; the cut is the longest pair of them.
    hb, ub, vb = (np.roll(x, -1, axis=1) for x in (h, cu, cv))
    meets = (np.minimum(h, hb) <= 0) & (np.maximum(h, hb) >= 0) & (h != hb)
    w = np.where(meets, h / np.where(h != hb, h - hb, 1.0), 0.0)
    pu, pv = cu + w * (ub - cu), cv + w * (vb - cv)
    pair_a, pair_b = np.array([0, 1, 2]), np.array([1, 2, 0])
    gap = (pu[:, pair_a] - pu[:, pair_b]) ** 2 + (pv[:, pair_a] - pv[:, pair_b]) ** 2
    gap = np.where(meets[:, pair_a] & meets[:, pair_b], gap, -1.0)
    best = np.argmax(gap, axis=1)
    rows = np.arange(len(h))
    a, b = pair_a[best], pair_b[best]
    seg = np.stack([np.stack([pu[rows, a], pv[rows, a]], axis=1),
                    np.stack([pu[rows, b], pv[rows, b]], axis=1)], axis=1)
    seg = np.where(crossing[:, None, None], seg, 0.0)
    box = np.where(flat[:, None, None],
                   np.stack([np.stack([cu.min(axis=1), cv.min(axis=1)], axis=1),
                             np.stack([cu.max(axis=1), cv.max(axis=1)], axis=1)], axis=1),
                   np.stack([seg.min(axis=1), seg.max(axis=1)], axis=1))
    return cu, cv, flat, crossing, seg, box


def plane_segments(corners, normals, axis, plane, thickness):
    """Where triangles meet the plane x[axis] = plane without lying in it, in its (u, v) =
    (axis + 1, axis + 2) coords: the cut of each crossing triangle and the edge of each triangle
    touching the plane along an edge (two corners within thickness, the third off it).

    corners : (n, 3, 3) float64;  normals : (n, 3) float64 unit
    returns : seg (m, 2, 2) float64 [[u0, v0], [u1, v1]], side (m, 2) float64 the triangle's
              normal in (u, v) (the side its front faces), m <= n
    """
    u_axis, v_axis = (axis + 1) % 3, (axis + 2) % 3
    cu, cv, flat, crossing, seg, _ = plane_footprints(corners, axis, plane, thickness)
    on = _snapped_heights(corners, axis, plane, thickness) == 0
    touch = ~flat & ~crossing & (on.sum(axis=1) == 2)
    off = np.argmin(on, axis=1)  # the corner off the plane; the edge is the other two
    rows = np.arange(len(corners))
    a, b = (off + 1) % 3, (off + 2) % 3
    edge = np.stack([np.stack([cu[rows, a], cv[rows, a]], axis=1),
                     np.stack([cu[rows, b], cv[rows, b]], axis=1)], axis=1)
    pick = crossing | touch
    seg = np.where(touch[:, None, None], edge, seg)[pick]
    return seg, np.asarray(normals, dtype=np.float64)[pick][:, [u_axis, v_axis]]


def wall_outline(cu, cv, quantum):
    """Edges bounding the union of in-plane triangles: every edge not shared with a triangle
    lying on its other side (a superset of the union's boundary).

    cu, cv  : (n, 3) float64 corner coordinates of the in-plane triangles
    quantum : float, endpoints this close are the same point
    returns : (e, 2, 2) float64 [[u0, v0], [u1, v1]]
    """
    if not len(cu):
        return np.zeros((0, 2, 2))
    ia, ib, ic = np.array([0, 1, 2]), np.array([1, 2, 0]), np.array([2, 0, 1])
    p = np.stack([cu, cv], axis=2)                           # (n, 3, 2)
    pa, pb, pc = p[:, ia].reshape(-1, 2), p[:, ib].reshape(-1, 2), p[:, ic].reshape(-1, 2)
    qa, qb = np.round(pa / quantum).astype(np.int64), np.round(pb / quantum).astype(np.int64)
    swap = (qa[:, 0] > qb[:, 0]) | ((qa[:, 0] == qb[:, 0]) & (qa[:, 1] > qb[:, 1]))
    key = np.where(swap[:, None], np.hstack([qb, qa]), np.hstack([qa, qb]))
    d, e = pb - pa, pc - pa
    side = np.sign(d[:, 0] * e[:, 1] - d[:, 1] * e[:, 0]) * np.where(swap, -1.0, 1.0)
    _, inverse = np.unique(key, axis=0, return_inverse=True)
    inverse = inverse.ravel()
    pos = np.bincount(inverse, weights=side > 0)[inverse] > 0
    neg = np.bincount(inverse, weights=side < 0)[inverse] > 0
    degenerate = (qa == qb).all(axis=1)
    keep = ~(pos & neg) & ~degenerate
    return np.stack([pa[keep], pb[keep]], axis=1)


def _breaks(lo, hi, s, lines, eps):
    """(n + 1,) float64 sample boundaries from lo to hi: every coordinate of `lines` inside
    (lo, hi), and uniform boundaries about s apart except those within s/4 of such a line."""
    count = max(1, int(np.ceil((hi - lo) / s - 1e-9)))
    uniform = lo + (hi - lo) * np.arange(count + 1) / count
    lines = np.unique(lines[(lines > lo + eps) & (lines < hi - eps)])
    if len(lines):
        lines = lines[np.concatenate([[True], np.diff(lines) > eps])]
        if len(lines) > 4 * count:  # keep the sample count bounded; any boundaries are sound
            lines = lines[np.linspace(0, len(lines) - 1, 4 * count).astype(np.int64)]
        inner = uniform[1:-1]
        at = np.clip(np.searchsorted(lines, inner), 1, len(lines) - 1) if len(lines) > 1 \
            else np.zeros(len(inner), dtype=np.int64)
        gap = np.minimum(np.abs(inner - lines[at]), np.abs(inner - lines[np.maximum(at - 1, 0)]))
        uniform = np.concatenate([[lo], inner[gap >= s / 4], [hi]])
    return np.unique(np.concatenate([uniform, lines]))


def _aligned_lines(segs, eps):
    """Sample boundaries the axis-parallel segments ask for: (u (k,), v (l,) float64).

    A segment parallel to v gives its u (so no sample straddles it) and its two v ends (so a
    band along u is spanned by one piece of a wall split into several, not by halves of two).
    """
    d = np.abs(segs[:, 1] - segs[:, 0])
    along_v = (d[:, 0] <= eps) & (d[:, 1] > eps)
    along_u = (d[:, 1] <= eps) & (d[:, 0] > eps)
    return (np.concatenate([segs[along_v, :, 0].mean(axis=1), segs[along_u, :, 0].ravel()]),
            np.concatenate([segs[along_u, :, 1].mean(axis=1), segs[along_v, :, 1].ravel()]))


def _interval_pairs(lo, hi, bounds):
    """(item (P,) int64, k (P,) int64): the intervals bounds[k]..bounds[k + 1] that each item's
    [lo, hi] may meet (a superset; callers test the overlap they need)."""
    n = len(bounds) - 1
    k0 = np.clip(np.searchsorted(bounds, lo, side="right") - 1, 0, n - 1)
    k1 = np.clip(np.searchsorted(bounds, hi, side="left") - 1, 0, n - 1)
    span = np.where((hi < bounds[0]) | (lo > bounds[-1]), 0, np.maximum(k1 - k0 + 1, 0))
    item = np.repeat(np.arange(len(lo)), span)
    local = np.arange(int(span.sum())) - np.repeat(np.cumsum(span) - span, span)
    return item, k0[item] + local


def _cell_pairs(lo, hi, bu, bv):
    """Enumerate the sample cells whose closed box meets each item's box [lo, hi] (k, 2):
    (item (P,) int64, i (P,) int64, j (P,) int64)."""
    nu, nv = len(bu) - 1, len(bv) - 1
    i0 = np.clip(np.searchsorted(bu, lo[:, 0], side="right") - 1, 0, nu - 1)
    i1 = np.clip(np.searchsorted(bu, hi[:, 0], side="left") - 1, -1, nu - 1)
    j0 = np.clip(np.searchsorted(bv, lo[:, 1], side="right") - 1, 0, nv - 1)
    j1 = np.clip(np.searchsorted(bv, hi[:, 1], side="left") - 1, -1, nv - 1)
    out = (hi[:, 0] < bu[0]) | (lo[:, 0] > bu[-1]) | (hi[:, 1] < bv[0]) | (lo[:, 1] > bv[-1])
    span_i = np.where(out, 0, np.maximum(i1 - i0 + 1, 0))
    span_j = np.where(out, 0, np.maximum(j1 - j0 + 1, 0))
    total = span_i * span_j
    item = np.repeat(np.arange(len(lo)), total)
    local = np.arange(int(total.sum())) - np.repeat(np.cumsum(total) - total, total)
    sj = np.maximum(span_j[item], 1)
    return item, i0[item] + local // sj, j0[item] + local % sj


def cells_crossed(segs, bu, bv, eps):
    """(nu, nv) bool sample cells whose open interior a segment passes through.

    Errs toward not crossed by eps: a segment along a border, or within eps inside it, does not
    cross (coordinates within eps coincide).
    segs : (m, 2, 2) float64;  bu (nu + 1,), bv (nv + 1,) float64 sample boundaries
    """
    nu, nv = len(bu) - 1, len(bv) - 1
    crossed = np.zeros(nu * nv, dtype=bool)
    if not len(segs):
        return crossed.reshape(nu, nv)
    item, i, j = _cell_pairs(segs.min(axis=1), segs.max(axis=1), bu, bv)
    p0, d = segs[item, 0], segs[item, 1] - segs[item, 0]
    t0, t1 = np.zeros(len(item)), np.ones(len(item))
    for k, (lo, hi) in enumerate(((bu[i], bu[i + 1]), (bv[j], bv[j + 1]))):
        moving = d[:, k] != 0
        safe = np.where(moving, d[:, k], 1.0)
        ta, tb = (lo - p0[:, k]) / safe, (hi - p0[:, k]) / safe
        t0 = np.where(moving, np.maximum(t0, np.minimum(ta, tb)), t0)
        t1 = np.where(moving, np.minimum(t1, np.maximum(ta, tb)), t1)
    mid = p0 + ((t0 + t1) / 2)[:, None] * d
    hit = ((t0 <= t1) & (mid[:, 0] > bu[i] + eps) & (mid[:, 0] < bu[i + 1] - eps)
           & (mid[:, 1] > bv[j] + eps) & (mid[:, 1] < bv[j + 1] - eps))
    crossed[(i * nv + j)[hit]] = True
    return crossed.reshape(nu, nv)


def centres_covered(cu, cv, bu, bv):
    """(nu, nv) bool: the sample cell's centre lies in (or on) one of the triangles (cu, cv).

    Exact up to rounding (edge functions, boundary inclusive)."""
    nu, nv = len(bu) - 1, len(bv) - 1
    covered = np.zeros(nu * nv, dtype=bool)
    if not len(cu):
        return covered.reshape(nu, nv)
    mu, mv = (bu[:-1] + bu[1:]) / 2, (bv[:-1] + bv[1:]) / 2
    lo = np.stack([cu.min(axis=1), cv.min(axis=1)], axis=1)
    hi = np.stack([cu.max(axis=1), cv.max(axis=1)], axis=1)
    tri, i, j = _cell_pairs(lo, hi, bu, bv)
    x, y = mu[i], mv[j]
    u, v = cu[tri], cv[tri]
    d = [(u[:, b] - u[:, a]) * (y - v[:, a]) - (v[:, b] - v[:, a]) * (x - u[:, a])
         for a, b in ((0, 1), (1, 2), (2, 0))]
    inside = (((d[0] >= 0) & (d[1] >= 0) & (d[2] >= 0))
              | ((d[0] <= 0) & (d[1] <= 0) & (d[2] <= 0)))
    covered[(i * nv + j)[inside]] = True
    return covered.reshape(nu, nv)


def _suffix_min(band, key, value, q_band, q_key):
    """For each query: min of `value` over items of the same band with key >= q_key (inf if
    none). Bands are small ints; one sort, one reversed running minimum."""
    if not len(band):
        return np.full(len(q_band), np.inf)
    span = float(np.abs(value).max()) * 4.0 + 1.0
    n = len(band)
    order = np.lexsort((np.concatenate([np.ones(n), np.zeros(len(q_band))]),
                        np.concatenate([key, q_key]), np.concatenate([band, q_band])))
    lifted = np.concatenate([value + band * span, np.full(len(q_band), np.inf)])[order]
    running = np.minimum.accumulate(lifted[::-1])[::-1]
    where = np.empty(len(order), dtype=np.int64)
    where[order] = np.arange(len(order))
    got = running[where[n:]] - q_band * span
    return np.where(got < span / 2, got, np.inf)


def back_along(seg, side, ba, bb, eps):
    """(na, nb) bool: from every point of each sample cell, the nearest segment along +a is seen
    from behind (side . a > 0), or the cell is crossed by a segment (callers exclude those).

    Errs toward False: a front-facing or edge-on segment within eps of the first full-width one
    counts as nearer.
    seg  : (m, 2, 2) float64 in (a, b) coords;  side : (m, 2) float64 normals in (a, b)
    ba   : (na + 1,), bb : (nb + 1,) float64 sample boundaries along a and b
    """
    na, nb = len(ba) - 1, len(bb) - 1
    if not len(seg):
        return np.zeros((na, nb), dtype=bool)
    bmin, bmax = seg[:, :, 1].min(axis=1), seg[:, :, 1].max(axis=1)
    s, j = _interval_pairs(bmin, bmax, bb)  # (segment, band) pairs
    keep = (bmin[s] < bb[j + 1]) & (bmax[s] > bb[j])
    s, j = s[keep], j[keep]
    (a0, b0), (a1, b1) = seg[s, 0].T, seg[s, 1].T
    db = b1 - b0
    safe = np.where(db != 0, db, 1.0)
    ta = np.clip((bb[j] - b0) / safe, 0.0, 1.0)
    tb = np.clip((bb[j + 1] - b0) / safe, 0.0, 1.0)
    ta, tb = np.where(db != 0, ta, 0.0), np.where(db != 0, tb, 1.0)
    pa, pb = a0 + ta * (a1 - a0), a0 + tb * (a1 - a0)
    amin, amax = np.minimum(pa, pb), np.maximum(pa, pb)
    spans = (bmin[s] <= bb[j] + eps) & (bmax[s] >= bb[j + 1] - eps)
    back = side[s, 0] > 1e-9
    # queries: every cell, by its far boundary along a
    qi, qj = np.meshgrid(np.arange(na), np.arange(nb), indexing="ij")
    qi, qj = qi.ravel(), qj.ravel()
    far = ba[qi + 1] - eps
    full = _suffix_min(j[spans], amin[spans], amax[spans], qj, far)
    bad = _suffix_min(j[~back], amax[~back], amin[~back], qj, far)
    return (np.isfinite(full) & (bad > full + eps)).reshape(na, nb)


def _solid(seg, side, bu, bv, eps):
    """(nu, nv) bool sample cells between back faces on both sides along u, or along v.

    Errs as back_along (toward False); callers exclude the cells a segment crosses."""
    flip = np.array([-1.0, 1.0])
    swap = [1, 0]

    def both(s, n, ba, bb):
        plus = back_along(s, n, ba, bb, eps)
        minus = back_along(s * flip, n * flip, -ba[::-1], bb, eps)[::-1]
        return plus & minus

    along_u = both(seg, side, bu, bv)
    along_v = both(seg[:, :, swap], side[:, swap], bv, bu).T
    return along_u | along_v


def face_blocked(flat_uv, outline, seg, side, lo_uv, hi_uv, samples, eps):
    """Sample boundaries and blocked sample cells of one face.

    A sample cell is blocked when its whole area lies in the walls (its centre in an in-plane
    triangle and no outline edge through it) or in solid space (no segment through it and
    back faces on both sides along u or v). Errs toward open.
    flat_uv : (cu, cv) (n, 3) float64 in-plane triangles;  outline : (e, 2, 2) (wall_outline)
    seg, side : plane_segments;  lo_uv, hi_uv : (2,) float64 the face
    returns : bu (nu + 1,), bv (nv + 1,) float64, blocked (nu, nv) bool
    """
    size = hi_uv - lo_uv
    s = max(float(size.max()) / samples, 1e-300)
    lines_u, lines_v = _aligned_lines(np.concatenate([seg, outline]), eps)
    bu = _breaks(lo_uv[0], hi_uv[0], s, lines_u, eps)
    bv = _breaks(lo_uv[1], hi_uv[1], s, lines_v, eps)
    walls = centres_covered(*flat_uv, bu, bv) & ~cells_crossed(outline, bu, bv, eps)
    free = ~walls
    if free.any() and len(seg):
        solid = ~cells_crossed(seg, bu, bv, eps) & _solid(seg, side, bu, bv, eps)
        return bu, bv, walls | (solid & ~_touching_walls(solid, walls))
    return bu, bv, walls


def _touching_walls(solid, walls):
    """(nu, nv) bool: solid sample cells whose 4-connected solid region borders a wall cell.

    Such a region is not closed in the face: where a wall in the face meets it, no crossing
    surface separates it from what lies beyond the wall's edge (a floor slab between two
    storeys' walls, open at the atrium), and with back faces culled a sight line can run
    inside it and leave through a back face. These regions stay open (errs toward open)."""
    labels = _components(solid)
    near = np.zeros_like(walls)
    near[1:] |= walls[:-1]
    near[:-1] |= walls[1:]
    near[:, 1:] |= walls[:, :-1]
    near[:, :-1] |= walls[:, 1:]
    hit = np.unique(labels[near & solid])
    return solid & np.isin(labels, hit)


def open_rectangles(open_mask, bu, bv, max_rects=MAX_RECTS):
    """(Q, 2, 2) float64 rectangles [[u0, v0], [u1, v1]] covering every open sample cell: runs
    of open cells along v merged across rows of equal runs; if that gives more than max_rects,
    one bounding box per 4-connected open region."""
    nu, nv = open_mask.shape
    pad = np.zeros((nu, nv + 2), dtype=bool)
    pad[:, 1:-1] = open_mask
    step = np.diff(pad.astype(np.int8), axis=1)
    ri, j0 = np.nonzero(step == 1)
    _, j1 = np.nonzero(step == -1)  # same row order, so runs pair up
    if not len(ri):
        return np.zeros((0, 2, 2))
    order = np.lexsort((ri, j1, j0))
    ri, j0, j1 = ri[order], j0[order], j1[order]
    new = np.ones(len(ri), dtype=bool)
    new[1:] = (j0[1:] != j0[:-1]) | (j1[1:] != j1[:-1]) | (ri[1:] != ri[:-1] + 1)
    first = np.flatnonzero(new)
    last = np.append(first[1:], len(ri)) - 1
    i0, i1, g0, g1 = ri[first], ri[last] + 1, j0[first], j1[first]
    if len(first) > max_rects:
        labels = _components(open_mask)
        found = np.unique(labels[labels >= 0])
        li, lj = np.nonzero(labels >= 0)
        lab = np.searchsorted(found, labels[li, lj])
        i0 = np.full(len(found), nu)
        i1 = np.full(len(found), -1)
        g0, g1 = i0.copy(), i1.copy()
        np.minimum.at(i0, lab, li)
        np.maximum.at(i1, lab, li + 1)
        np.minimum.at(g0, lab, lj)
        np.maximum.at(g1, lab, lj + 1)
    return np.stack([np.stack([bu[i0], bv[g0]], axis=1), np.stack([bu[i1], bv[g1]], axis=1)],
                    axis=1)


def _touching(world, axis, plane, thickness):
    """(n,) int64 ids of triangles whose AABB reaches within thickness of x[axis] = plane."""
    tb = world.bounds
    return np.flatnonzero((tb[:, 0, axis] <= plane + thickness) & (tb[:, 1, axis] >= plane - thickness))


class PlaneGeometry:
    """What the triangles near one grid plane leave on it, computed once for all its faces:
    in-plane triangles (flat_uv), their outline, and the oriented segments (plane_segments)."""

    def __init__(self, world, corners, axis, plane, thickness, eps, solid=None):
        near = _touching(world, axis, plane, thickness)
        c = corners[near]
        cu, cv, flat, _, _, _ = plane_footprints(c, axis, plane, thickness)
        self.flat_uv = (cu[flat], cv[flat])
        self.outline = wall_outline(cu[flat], cv[flat], eps)
        # Only a closed outward solid's faces may close space behind them (solids.py): the
        # others get no side (edge-on), which back_along never takes for a back face.
        solid = outward_solid_faces(world) if solid is None else solid
        normals = np.where(solid[near, None], world.normals[near], 0.0)
        self.seg, self.side = plane_segments(c, normals, axis, plane, thickness)
        self.eps = eps

    def openings(self, lo_uv, hi_uv, samples=FACE_SAMPLES):
        """(Q, 2, 2) float64 open rectangles of the face [lo_uv, hi_uv] (face_openings)."""
        lo_uv, hi_uv = np.asarray(lo_uv, dtype=np.float64), np.asarray(hi_uv, dtype=np.float64)
        seg_lo, seg_hi = self.seg.min(axis=1), self.seg.max(axis=1)
        # segments in the face's row or column bands (rays run beyond the face)
        near = (((seg_hi[:, 1] >= lo_uv[1]) & (seg_lo[:, 1] <= hi_uv[1]))
                | ((seg_hi[:, 0] >= lo_uv[0]) & (seg_lo[:, 0] <= hi_uv[0])))
        cu, cv = self.flat_uv
        inside = ((cu.max(axis=1) >= lo_uv[0]) & (cu.min(axis=1) <= hi_uv[0])
                  & (cv.max(axis=1) >= lo_uv[1]) & (cv.min(axis=1) <= hi_uv[1]))
        o_lo, o_hi = self.outline.min(axis=1), self.outline.max(axis=1)
        o_in = ((o_hi >= lo_uv) & (o_lo <= hi_uv)).all(axis=1)
        bu, bv, blocked = face_blocked((cu[inside], cv[inside]), self.outline[o_in],
                                       self.seg[near], self.side[near], lo_uv, hi_uv, samples,
                                       self.eps)
        return open_rectangles(~blocked, bu, bv)


def face_openings(world, axis, plane, lo_uv, hi_uv, thickness, samples=FACE_SAMPLES, eps=None):
    """Open rectangles of one shared face: (Q, 2, 2) float64 [[u0, v0], [u1, v1]] in the face's
    (axis + 1, axis + 2) coordinates.

    Errs large: the rectangles cover every point of the face that is neither in a wall lying in
    the face nor in solid space (face_blocked), however thin the opening; triangles within
    `thickness` of the plane lie in it, points within eps coincide.
    """
    eps = COINCIDE * float(np.ptp(world.extent, axis=0).max()) if eps is None else eps
    geometry = PlaneGeometry(world, world.corners, axis, plane, thickness, eps)
    return geometry.openings(lo_uv, hi_uv, samples)


def find_portals(world, edges, thickness, samples=FACE_SAMPLES, eps=None):
    """Portals between face-adjacent cells of the grid `edges` (face_openings of every face).

    The plane's geometry is computed once per interior grid plane; its faces (a loop over cell
    faces, tens to a few hundred) each classify only the segments reaching their rows.
    returns : portal_cells (P, 2) int32 (low cell, high cell along the face axis),
              portal_start (P + 1,) int64, portal_vertices (4P, 3) float64 rectangles wound
              so their right-hand normal points from portal_cells[:, 0] to portal_cells[:, 1]
    """
    eps = COINCIDE * float(np.ptp(world.extent, axis=0).max()) if eps is None else eps
    corners = world.corners
    solid = outward_solid_faces(world)
    shape = [len(e) - 1 for e in edges]
    cells, polys = [], []
    for axis in range(3):
        u_axis, v_axis = (axis + 1) % 3, (axis + 2) % 3
        for b in range(1, shape[axis]):
            plane = edges[axis][b]
            geometry = PlaneGeometry(world, corners, axis, plane, thickness, eps, solid)
            for iu in range(shape[u_axis]):
                for iv in range(shape[v_axis]):
                    lo_uv = np.array([edges[u_axis][iu], edges[v_axis][iv]], dtype=np.float64)
                    hi_uv = np.array([edges[u_axis][iu + 1], edges[v_axis][iv + 1]],
                                     dtype=np.float64)
                    rects = geometry.openings(lo_uv, hi_uv, samples)
                    if not len(rects):
                        continue
                    idx = [0, 0, 0]
                    idx[u_axis], idx[v_axis], idx[axis] = iu, iv, b - 1
                    low = np.ravel_multi_index(idx, shape)
                    idx[axis] = b
                    high = np.ravel_multi_index(idx, shape)
                    quads = np.zeros((len(rects), 4, 3))
                    quads[:, :, axis] = plane
                    quads[:, :, u_axis] = rects[:, [0, 1, 1, 0], 0]
                    quads[:, :, v_axis] = rects[:, [0, 0, 1, 1], 1]
                    cells.extend([(low, high)] * len(rects))
                    polys.append(quads.reshape(-1, 3))
    count = len(cells)
    portal_cells = np.array(cells, dtype=np.int32).reshape(count, 2)
    vertices = np.concatenate(polys) if polys else np.zeros((0, 3))
    return portal_cells, np.arange(0, 4 * count + 1, 4, dtype=np.int64), vertices


def build(world, depth=2, slabs=None, auto=False, cells=None, thickness=None,
          samples=FACE_SAMPLES, walls=False, progress=None):
    """Portal octree: root -> every grid cell (level 1, empty ones too) -> each cell's octree.

    depth     : octree depth inside each cell, 1..3
    slabs     : explicit cells as in grid.build; otherwise automatic, about `cells` cells
                (default sqrt(T) / 2, 8..256) snapped to wall planes
    thickness : distance from a face plane within which a triangle lies in it (default
                THICKNESS x the world's size)
    walls     : True puts a boundary on every large wall plane instead (portal_edges.wall_edges:
                both faces of each hollow wall and slab, at most MAX_PORTAL_CELLS cells); not
                with slabs or cells
    returns   : Partition with extras octant (N,) int8 (-1 above the cell octrees), cell_node (C,) int32, cell_bounds (C, 2, 3) float64,
                portal_cells, portal_start, portal_vertices (find_portals), cell_portal_start
                (C + 1,) int64 and cell_portals (2P,) int32 (CSR cell -> portal ids), grid_x/y/z
    """
    depth = check_depth(depth, 1, 3, "portal octree depth")
    if not isinstance(walls, (bool, np.bool_)):
        raise ValueError(f"portal walls must be true or false, got {walls!r}")
    if walls and (slabs is not None or cells is not None or auto):
        raise ValueError("portal walls=true places the cells itself: give no slabs, cells or auto")
    if cells is not None:
        grid.check_cells(cells, MAX_PORTAL_CELLS, "portal")
    if slabs is not None:
        counts = [len(e) - 1 for e in grid.resolve_edges(world, slabs, auto, cells)]
        grid.check_cells(int(np.prod(counts)), MAX_PORTAL_CELLS, "portal")
    if walls:
        edges = wall_edges(world, MAX_PORTAL_CELLS)
    elif slabs is None:
        target = int(np.clip(round(np.sqrt(world.triangle_count) / 2), 8, 256)) if cells is None else int(cells)
        edges = auto_edges(world, target)
    else:
        edges = grid.resolve_edges(world, slabs, auto, cells)
    size = float(np.ptp(world.extent, axis=0).max())
    thickness = THICKNESS * size if thickness is None else float(thickness)
    # Triangles within `thickness` of a cell face lie in it (find_portals closes the face
    # there): both cells hold them, whatever side rounding put them on.
    cell, tri = grid.cell_pairs(world, edges, slack=thickness)
    boxes = grid.cell_boxes(edges)
    count = len(boxes)
    levels, (last_node, last_tri) = subdivide(world, boxes, cell, tri, depth)
    root = world.extent[None].astype(np.float64)
    parent, region, starts = chain_levels([root, boxes] + [b for b, _, _ in levels],
                                          [np.array([-1]), np.zeros(count, dtype=np.int64)]
                                          + [p for _, p, _ in levels])
    octant = np.concatenate([np.full(count + 1, -1)] + [o for _, _, o in levels]).astype(np.int8)
    if progress is not None:
        progress(1, 2)
    portal_cells, portal_start, portal_vertices = find_portals(world, edges, thickness, samples)
    if progress is not None:
        progress(2, 2)
    ends = np.concatenate([portal_cells[:, 0], portal_cells[:, 1]]).astype(np.int64)
    ids = np.tile(np.arange(len(portal_cells)), 2)
    order = np.lexsort((ids, ends))
    cell_portal_start = np.concatenate([[0], np.cumsum(np.bincount(ends, minlength=count))])
    params = {"depth": depth, "auto": slabs is None and not walls, "slabs": [len(e) - 1 for e in edges],
              "thickness": thickness, "samples": int(samples)}
    if walls:  # only when asked: a default partition's params (and .vmp) stay as they were
        params["walls"] = True
    result, flat = make_partition(
        "portal", params, world, parent, last_node + starts[-1], last_tri, region,
        node_extras={"octant": octant},
        extras={"portal_cells": portal_cells, "portal_start": portal_start,
                "portal_vertices": portal_vertices,
                "cell_portal_start": cell_portal_start.astype(np.int64),
                "cell_portals": ids[order].astype(np.int32),
                **{f"grid_{grid.AXES[a]}": np.asarray(edges[a], dtype=np.float64) for a in range(3)}})
    result.extras["cell_node"] = flat["new_of_old"][1:count + 1].astype(np.int32)
    result.extras["cell_bounds"] = result.node_bounds[result.extras["cell_node"]].copy()
    return result

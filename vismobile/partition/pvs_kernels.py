"""Compiled kernels of the conservative PVS bake (pvs.py): separating planes between convex
point sets, polygon clipping, and the walk over portal crossings from one source cell.

A sight line from an eye in the source cell S to a point in a cell m crosses, in order, the
portals of a sequence of cells (cells are convex boxes: a line enters each at most once). For
any two convex sets X before Y along the line and any plane with X on its negative side and Y
on its positive side (a separating plane), the line beyond Y stays on the positive side
(Teller and Sequin 1991; Quake's vis). flow_from_cell keeps, per portal crossing, a box of the
points where such lines may cross it, and clips the next portals by the separators of (S, that
box). Every plane kept is a true separator, so the test never removes a line that exists: it
errs toward visible.
"""
from __future__ import annotations

import numpy as np
from numba import njit

# Box vertex k has x from bit 0, y from bit 1, z from bit 2.
BOX_EDGES = np.array([[0, 1], [2, 3], [4, 5], [6, 7], [0, 2], [1, 3], [4, 6], [5, 7],
                      [0, 4], [1, 5], [2, 6], [3, 7]], dtype=np.int64)
MAX_VERTS = 48      # vertices of a clipped portal polygon (more: kept unclipped)
MAX_PLANES = 192    # separating planes kept per sequence step (more are dropped: looser)
# A crossing box that grows grows this much further (a share of the cells' extent, within the
# portal's face): the walk's fixed point is reached in fewer, larger steps (the axis planes
# let boxes in thin cells creep by a crack's width per round; W1 overflowed the budget).
STEP = 2.0 ** -10
NO_SLAB = np.array([-1.0, 0.0, 0.0])  # flow_in_slab: every line


@njit(cache=True, inline="always")
def _side_at(planes, k, points, i):
    """planes[k]'s side of points[i] (by index: no row views in the walk's loops)."""
    return (planes[k, 0] * points[i, 0] + planes[k, 1] * points[i, 1]
            + planes[k, 2] * points[i, 2] + planes[k, 3])


@njit(cache=True, inline="always")
def _side_corner(planes, k, corners, t, i):
    """planes[k]'s side of corners[t, i] (by index (corners (T, V, 3): a triangle's or a
    portal's)."""
    return (planes[k, 0] * corners[t, i, 0] + planes[k, 1] * corners[t, i, 1]
            + planes[k, 2] * corners[t, i, 2] + planes[k, 3])


@njit(cache=True)
def box_vertices(lo, hi, out):
    """out (8, 3) float64 <- the corners of the box [lo, hi] (vertex k: bit 0 x, 1 y, 2 z)."""
    for k in range(8):
        out[k, 0] = hi[0] if k & 1 else lo[0]
        out[k, 1] = hi[1] if k & 2 else lo[1]
        out[k, 2] = hi[2] if k & 4 else lo[2]


@njit(cache=True, inline="always")
def _try(e, i, j, v, k, a, na, b, nb, out, count, a0, a1, a2, b0, b1):
    """Plane through e[i], e[j], v[k] kept when it separates a[:na] (negative) from b[:nb]
    (positive), moved to the middle of the gap; returns the new count. Points by index, not
    row views: no view per call in the separators' loops (the bake's hottest call).
    a0, a1, a2 / b0, b1: indices into a / b (-1: none) probed first: when the probes' sides
    already overlap (some a beyond some b either way), neither test can hold and the plane is
    dropped before the full loops; the sides are the same numbers the loops compute, so the
    planes kept are exactly those without probes."""
    e0, e1, e2 = e[j, 0] - e[i, 0], e[j, 1] - e[i, 1], e[j, 2] - e[i, 2]
    w0, w1, w2 = v[k, 0] - e[i, 0], v[k, 1] - e[i, 1], v[k, 2] - e[i, 2]
    n0, n1, n2 = e1 * w2 - e2 * w1, e2 * w0 - e0 * w2, e0 * w1 - e1 * w0
    length = np.sqrt(n0 * n0 + n1 * n1 + n2 * n2)
    scale = np.sqrt((e0 * e0 + e1 * e1 + e2 * e2) * (w0 * w0 + w1 * w1 + w2 * w2))
    if length <= 1e-9 * scale or length == 0.0:
        return count
    n0, n1, n2 = n0 / length, n1 / length, n2 / length
    d = -(n0 * e[i, 0] + n1 * e[i, 1] + n2 * e[i, 2])
    amin, amax, bmin, bmax = np.inf, -np.inf, np.inf, -np.inf
    for q in (a0, a1, a2):
        if q >= 0:
            f = n0 * a[q, 0] + n1 * a[q, 1] + n2 * a[q, 2] + d
            amin, amax = min(amin, f), max(amax, f)
    for q in (b0, b1):
        if q >= 0:
            f = n0 * b[q, 0] + n1 * b[q, 1] + n2 * b[q, 2] + d
            bmin, bmax = min(bmin, f), max(bmax, f)
    if amax > bmin and amin < bmax:
        return count
    for i in range(na):
        f = n0 * a[i, 0] + n1 * a[i, 1] + n2 * a[i, 2] + d
        amin, amax = min(amin, f), max(amax, f)
    for i in range(nb):
        f = n0 * b[i, 0] + n1 * b[i, 1] + n2 * b[i, 2] + d
        bmin, bmax = min(bmin, f), max(bmax, f)
    if amax <= bmin:
        out[count, 0], out[count, 1], out[count, 2] = n0, n1, n2
        out[count, 3] = d - 0.5 * (amax + bmin)
        return count + 1
    if bmax <= amin:
        out[count, 0], out[count, 1], out[count, 2] = -n0, -n1, -n2
        out[count, 3] = -d + 0.5 * (amin + bmax)
        return count + 1
    return count


@njit(cache=True)
def separators(a, na, a_box, b, nb, out, count, b_box=False):
    """Append to out[count:] the planes through an edge of one set and a vertex of the other
    that separate a[:na] (negative side) from b[:nb] (positive side); returns the new count.

    a_box : a holds the 8 corners of a box (its 12 edges), else a convex polygon in order.
    b likewise (b_box). Stops at len(out) (fewer planes: looser, still sound).
    """
    limit = len(out)
    ea = 12 if a_box else na
    for k in range(ea):
        if a_box:
            i, j = BOX_EDGES[k, 0], BOX_EDGES[k, 1]
            p0, p1 = _beside(i, j)  # on both sides of a plane through the edge unless it
        else:                        # supports the box
            i, j = k, (k + 1) % na
            p0, p1 = (j + 1) % na, (i + na - 1) % na
        for r in range(nb):
            if count >= limit:
                return count
            count = _try(a, i, j, b, r, a, na, b, nb, out, count, p0, p1, -1, r,
                         _far(r, nb, b_box))
    eb = 12 if b_box else nb
    for k in range(eb):
        if b_box:
            i, j = BOX_EDGES[k, 0], BOX_EDGES[k, 1]
            p0, p1 = _beside(i, j)
        else:
            i, j = k, (k + 1) % nb
            p0, p1 = (j + 1) % nb, (i + nb - 1) % nb
        for r in range(na):
            if count >= limit:
                return count
            if a_box:
                count = _try(b, i, j, a, r, a, na, b, nb, out, count, r ^ 1, r ^ 2, r ^ 4,
                             p0, p1)
            else:
                count = _try(b, i, j, a, r, a, na, b, nb, out, count, r, (r + 1) % na,
                             (r + na - 1) % na, p0, p1)
    return count


@njit(cache=True, inline="always")
def _beside(i, j):
    """The two corners of a box next to corner i off the edge i-j (box_vertices' order)."""
    along = i ^ j
    if along == 1:
        return i ^ 2, i ^ 4
    if along == 2:
        return i ^ 1, i ^ 4
    return i ^ 1, i ^ 2


@njit(cache=True, inline="always")
def _far(r, n, box):
    """A vertex far from vertex r of a box (its opposite corner) or convex polygon of n."""
    return r ^ 7 if box else (r + n // 2) % n


@njit(cache=True)
def axis_planes(s_lo, s_hi, e_lo, e_hi, out, count):
    """Append to out[count:] the axis planes that bound a line beyond the box [e_lo, e_hi] after
    the box [s_lo, s_hi]: along an axis where the source lies wholly at or above the entry
    (s_lo >= e_hi), every line from the source through the entry has that coordinate
    non-increasing, so beyond the entry it stays at most e_hi (positive side: e_hi - x >= 0);
    likewise at least e_lo where the source lies wholly at or below it. Each plane touches
    the entry and has the source on its other side: a separator as in `separators`, the
    tightest one across that axis (separators' planes sit mid-gap). Returns the new count."""
    for a in range(3):
        if count >= len(out):
            return count
        if s_lo[a] >= e_hi[a]:
            out[count, 0], out[count, 1], out[count, 2] = 0.0, 0.0, 0.0
            out[count, a] = -1.0
            out[count, 3] = e_hi[a]
            count += 1
        elif s_hi[a] <= e_lo[a]:
            out[count, 0], out[count, 1], out[count, 2] = 0.0, 0.0, 0.0
            out[count, a] = 1.0
            out[count, 3] = -e_lo[a]
            count += 1
    return count


@njit(cache=True)
def clip_polygon(poly, n, planes, np_, tol, scratch):
    """Clip poly[:n] (convex, in order) in place to every plane's side >= -tol; returns the new
    vertex count (0: nothing left). A polygon that would outgrow MAX_VERTS is left as it was
    before that plane (larger: sound)."""
    for k in range(np_):
        m = 0
        inside_all = True
        for i in range(n):
            if _side_at(planes, k, poly, i) < -tol:
                inside_all = False
                break
        if inside_all:
            continue
        for i in range(n):
            j = (i + 1) % n
            fp, fq = _side_at(planes, k, poly, i) + tol, _side_at(planes, k, poly, j) + tol
            if fp >= 0.0:
                if m >= MAX_VERTS:
                    m = -1
                    break
                scratch[m, 0], scratch[m, 1], scratch[m, 2] = poly[i, 0], poly[i, 1], poly[i, 2]
                m += 1
            if (fp >= 0.0) != (fq >= 0.0):
                if m >= MAX_VERTS:
                    m = -1
                    break
                t = fp / (fp - fq)
                for c in range(3):
                    scratch[m, c] = poly[i, c] + t * (poly[j, c] - poly[i, c])
                m += 1
        if m < 0:
            continue
        if m < 3:
            return 0
        for i in range(m):
            poly[i, 0], poly[i, 1], poly[i, 2] = scratch[i, 0], scratch[i, 1], scratch[i, 2]
        n = m
    return n


@njit(cache=True)
def _behind_cell(t, corners, lo, hi, src, tol):
    """True when triangle t's plane has the cell box [lo, hi] on its back side (within tol) and
    every source point strictly in front (beyond tol): a line from the source can then reach t
    from inside the cell only through t's front half-space (it crosses the plane once), never
    from the cell's side, so another cell on the line, in front of t, marks it if anything."""
    x0, y0, z0 = corners[t, 0, 0], corners[t, 0, 1], corners[t, 0, 2]
    a0, a1, a2 = corners[t, 1, 0] - x0, corners[t, 1, 1] - y0, corners[t, 1, 2] - z0
    b0, b1, b2 = corners[t, 2, 0] - x0, corners[t, 2, 1] - y0, corners[t, 2, 2] - z0
    n0, n1, n2 = a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0
    length = np.sqrt(n0 * n0 + n1 * n1 + n2 * n2)
    if length == 0.0:
        return False
    n0, n1, n2 = n0 / length, n1 / length, n2 / length
    d = -(n0 * x0 + n1 * y0 + n2 * z0)
    # the cell's farthest corner toward the normal
    top = d + (n0 * (hi[0] if n0 > 0 else lo[0]) + n1 * (hi[1] if n1 > 0 else lo[1])
               + n2 * (hi[2] if n2 > 0 else lo[2]))
    if top > tol:
        return False
    for i in range(len(src)):
        if n0 * src[i, 0] + n1 * src[i, 1] + n2 * src[i, 2] + d <= tol:
            return False
    return True


@njit(cache=True)
def _mark(cell, cell_ref_start, cell_ref_end, tri_refs, corners, planes, np_, tol, visible,
          lo, hi, src):
    """Mark the cell's triangles not wholly on the negative side of one of the planes, nor
    facing out of the cell with every source point in front of them (_behind_cell); True when
    every triangle of the cell is marked now or left to other cells (so for every crossing)."""
    every = True
    for r in range(cell_ref_start[cell], cell_ref_end[cell]):
        t = tri_refs[r]
        if visible[t]:
            continue
        seen = True
        for k in range(np_):
            best = -np.inf
            for i in range(3):
                best = max(best, _side_corner(planes, k, corners, t, i))
            if best < -tol:
                seen = False
                break
        if not seen:
            every = False
        elif not _behind_cell(t, corners, lo, hi, src, tol):
            visible[t] = True
        # else: left to the cells in front for this source, whatever the crossing
    return every


@njit(cache=True)
def _flat_rectangle(lo, hi, out):
    """out <- the box [lo, hi] as a rectangle (4 corners in order) when it is flat along an
    axis (a crossing box lies in its portal's plane: fewer candidate planes), else its 8
    corners; returns the vertex count."""
    axis = -1
    for a in range(3):
        if hi[a] <= lo[a]:
            axis = a
            break
    if axis < 0:
        box_vertices(lo, hi, out)
        return 8
    u, v = (axis + 1) % 3, (axis + 2) % 3
    for i in range(4):
        out[i, axis] = lo[axis]
    out[0, u], out[0, v] = lo[u], lo[v]
    out[1, u], out[1, v] = hi[u], lo[v]
    out[2, u], out[2, v] = hi[u], hi[v]
    out[3, u], out[3, v] = lo[u], hi[v]
    return 4


@njit(cache=True)
def _grown_quad(portal_quads, p, grow, cand):
    """cand[:4] <- portal p's quad grown by `grow` along its in-plane axes."""
    for i in range(4):
        for a in range(3):
            cand[i, a] = portal_quads[p, i, a]
    for a in range(3):
        qlo = min(cand[0, a], cand[1, a], cand[2, a], cand[3, a])
        qhi = max(cand[0, a], cand[1, a], cand[2, a], cand[3, a])
        if qhi > qlo:
            for i in range(4):
                cand[i, a] = qlo - grow if cand[i, a] == qlo else qhi + grow


@njit(cache=True)
def _crack_candidate(portal_quads, p, src, grow, slope, planes, np_, tol, lo_i, hi_i, cand):
    """cand[:4] <- a box holding every point where a line from the source box src (8 corners)
    may pass crack portal p (pvs_cracks.py: the segment portal_quads[p, 0]-[p, 1]) from one
    of its cells into the other: within the crack's width w (grow + slope x the farthest
    source-to-segment distance) of the part of the segment whose w-box reaches every plane's
    side >= -tol, and on the cells' common face or line [lo_i, hi_i] (within tol). Returns 4,
    or 0 when no such point is left."""
    far = 0.0
    for i in range(8):  # the farthest pair of two convex sets is a pair of their vertices
        for e in range(2):
            d0 = src[i, 0] - portal_quads[p, e, 0]
            d1 = src[i, 1] - portal_quads[p, e, 1]
            d2 = src[i, 2] - portal_quads[p, e, 2]
            far = max(far, d0 * d0 + d1 * d1 + d2 * d2)
    w = grow + slope * np.sqrt(far)
    t0, t1 = 0.0, 1.0
    for k in range(np_):
        slack = tol + w * (abs(planes[k, 0]) + abs(planes[k, 1]) + abs(planes[k, 2]))
        f0 = _side_corner(planes, k, portal_quads, p, 0) + slack
        f1 = _side_corner(planes, k, portal_quads, p, 1) + slack
        if f0 < 0.0 and f1 < 0.0:
            return 0
        if f0 < 0.0:
            t0 = max(t0, f0 / (f0 - f1))
        elif f1 < 0.0:
            t1 = min(t1, f0 / (f0 - f1))
        if t0 > t1:
            return 0
    for a in range(3):
        q0, q1 = portal_quads[p, 0, a], portal_quads[p, 1, a]
        a0 = q0 + t0 * (q1 - q0)
        a1 = q0 + t1 * (q1 - q0)
        lo = max(min(a0, a1) - w, lo_i[a] - tol)
        hi = min(max(a0, a1) + w, hi_i[a] + tol)
        if lo > hi:
            return 0
        if hi_i[a] - lo_i[a] <= tol:  # the common face's axis: flat (fewer, tighter planes)
            lo = hi = 0.5 * (lo_i[a] + hi_i[a])
        cand[0, a], cand[1, a], cand[2, a], cand[3, a] = lo, hi, lo, hi
    return 4


@njit(cache=True, inline="always")
def common_face(cell_bounds, portal_cells, p, common):
    """common (2, 3) <- the box shared by portal p's two cells (their common face or line)."""
    a, b = portal_cells[p, 0], portal_cells[p, 1]
    for k in range(3):
        common[0, k] = max(cell_bounds[a, 0, k], cell_bounds[b, 0, k])
        common[1, k] = min(cell_bounds[a, 1, k], cell_bounds[b, 1, k])


@njit(cache=True, inline="always")
def exit_candidate(portal_quads, p, is_crack, cell_bounds, portal_cells, src, grow, slope,
                   planes, count, tol, common, scratch, cand):
    """cand[:n] <- the part of portal p a line from src may cross through planes[:count]: a
    crack's crossing box (_crack_candidate, cut to the two cells' common face or line), else
    the grown quad clipped. Returns n (0: none)."""
    if is_crack:
        common_face(cell_bounds, portal_cells, p, common)
        return _crack_candidate(portal_quads, p, src, grow, slope, planes, count, tol,
                                common[0], common[1], cand)
    _grown_quad(portal_quads, p, grow, cand)
    return clip_polygon(cand, 4, planes, count, tol, scratch)


@njit(cache=True, inline="always")
def grow_box(box, d, cand, n):
    """Grow box[d] (2, 3) to hold cand[:n]; returns whether it grew."""
    grew = False
    for a in range(3):
        lo, hi = np.inf, -np.inf
        for i in range(n):
            lo, hi = min(lo, cand[i, a]), max(hi, cand[i, a])
        if lo < box[d, 0, a]:
            box[d, 0, a] = lo
            grew = True
        if hi > box[d, 1, a]:
            box[d, 1, a] = hi
            grew = True
    return grew


@njit(cache=True, inline="always")
def grow_box_step(box, d, cand, n, step, face, pad):
    """grow_box, but a bound that moves (once the box holds a point) moves `step` beyond
    cand[:n], kept within face (2, 3) grown by pad; returns whether it grew. Larger: sound."""
    grew = False
    first = box[d, 0, 0] > box[d, 1, 0]  # empty before
    for a in range(3):
        lo, hi = np.inf, -np.inf
        for i in range(n):
            lo, hi = min(lo, cand[i, a]), max(hi, cand[i, a])
        extra = 0.0 if first else step
        if lo < box[d, 0, a]:
            box[d, 0, a] = min(lo, max(lo - extra, face[0, a] - pad))
            grew = True
        if hi > box[d, 1, a]:
            box[d, 1, a] = max(hi, min(hi + extra, face[1, a] + pad))
            grew = True
    return grew


@njit(cache=True)
def slab_planes(slab, out, count):
    """Append to out[count:] the two planes of the slab (axis, lo, hi) = slab[0], slab[1],
    slab[2] (positive side: lo <= x[axis] <= hi); none when slab[0] < 0. Returns the count."""
    if slab[0] < 0.0:
        return count
    a = int(slab[0])
    for k in range(2):
        out[count + k, 0], out[count + k, 1], out[count + k, 2] = 0.0, 0.0, 0.0
    out[count, a], out[count, 3] = 1.0, -slab[1]
    out[count + 1, a], out[count + 1, 3] = -1.0, slab[2]
    return count + 2


@njit(cache=True)
def flow_from_cell(source, src_lo, src_hi, cell_bounds, portal_cells, portal_quads,
                   cell_portal_start, cell_portals, cell_ref_start, cell_ref_end, tri_refs,
                   corners, grow, tol, budget, visible, cell_seen, crack, slope, blocked,
                   crossed):
    """flow_in_slab without a slab: every line from the source (the docstring there)."""
    return flow_in_slab(source, src_lo, src_hi, cell_bounds, portal_cells, portal_quads,
                        cell_portal_start, cell_portals, cell_ref_start, cell_ref_end,
                        tri_refs, corners, grow, tol, budget, visible, cell_seen, crack, slope,
                        blocked, crossed, NO_SLAB)


@njit(cache=True)
def flow_in_slab(source, src_lo, src_hi, cell_bounds, portal_cells, portal_quads,
                 cell_portal_start, cell_portals, cell_ref_start, cell_ref_end, tri_refs,
                 corners, grow, tol, budget, visible, cell_seen, crack, slope, blocked,
                 crossed, slab):
    """Each portal crossing (portal, direction) keeps one box holding every
    point where a line from the source may cross it (the union over all sequences), so the walk
    is a fixed point instead of an enumeration. The eyes are the box [src_lo, src_hi] (grown
    by `grow`) inside the source cell (the whole cell, or a part of it). The exit portals of
    the cell a crossing enters are clipped by the separators of (source box, crossing box),
    the surviving parts grow those exits' boxes, and a crossing whose box grew is walked
    again. The entered cell's triangles are marked against the same planes, and against the
    axis planes (axis_planes): along an axis where the source lies wholly on one side of the
    crossing box, a line beyond it stays on that box's far side (a line entering the thin
    strip along the world's side through a crack within w of it stays within w of it). A box
    that grows again grows STEP of the cells' extent further (within its face), so the fixed
    point comes in fewer rounds.

    Sound: a line from the source crossing portals p1, p2, ... crosses each at a point of its
    box (induction: its exit point lies beyond its entry point and the source, so on the
    positive side of every separator of the two, and survives the clip). Errs toward visible.
    Crack portals (crack[p], pvs_cracks.py: unshared edges, where the rasteriser may leave a
    pixel open) are crossed by every line passing within their width (grow + slope x the
    distance from the source): their crossing box is the clipped segment grown by that width,
    cut to the two cells' common face or line, and a line may pass any number of them.
    Portals with blocked[p] (a shut door's, pvs.py's door sets) are never crossed; crossed[p]
    is set for every portal some line from the source may cross.
    With a slab (axis, lo, hi) (slab[0] >= 0; pvs_planes.py), only the lines lying within it
    are walked: its two planes bound every crossing and every mark, so the walk stays in the
    slab (the lines within a device's rounding of a cell face's plane).
    Returns the crossings walked, or -1 past `budget` (the caller keeps every connected cell).
    """
    states = 2 * len(portal_cells)
    box = np.empty((states, 2, 3))
    for d in range(states):
        for a in range(3):
            box[d, 0, a] = np.inf
            box[d, 1, a] = -np.inf
    queued = np.zeros(states, dtype=np.bool_)
    queue = np.empty(max(states, 1), dtype=np.int64)
    done = np.zeros(len(cell_bounds), dtype=np.bool_)
    head, size = 0, 0
    src = np.empty((8, 3))
    box_vertices(src_lo - grow, src_hi + grow, src)
    entry = np.empty((8, 3))
    planes = np.empty((MAX_PLANES, 4))
    scratch = np.empty((MAX_VERTS, 3))
    cand = np.empty((MAX_VERTS, 3))
    common = np.empty((2, 3))
    step = 0.0
    for a in range(3):
        step = max(step, STEP * (cell_bounds[:, 1, a].max() - cell_bounds[:, 0, a].min()))
    for r in range(cell_ref_start[source], cell_ref_end[source]):
        visible[tri_refs[r]] = True
    cell_seen[source] = True
    walks = 0
    current = -1  # the crossing being walked; -1: the source itself
    while True:
        if current < 0:
            cell, count, came = source, slab_planes(slab, planes, 0), -1
        else:
            p = current // 2
            cell = portal_cells[p, 1] if current % 2 == 0 else portal_cells[p, 0]
            came = p
            ne = _flat_rectangle(box[current, 0], box[current, 1], entry)
            count = axis_planes(src_lo - grow, src_hi + grow, box[current, 0], box[current, 1],
                                planes, slab_planes(slab, planes, 0))
            count = separators(src, 8, True, entry, ne, planes, count, ne == 8)
            if not done[cell]:  # a cell wholly marked needs no more marking
                done[cell] = _mark(cell, cell_ref_start, cell_ref_end, tri_refs, corners,
                                   planes, count, tol, visible, cell_bounds[cell, 0],
                                   cell_bounds[cell, 1], src)
            cell_seen[cell] = True
        for q in range(cell_portal_start[cell], cell_portal_start[cell + 1]):
            p = cell_portals[q]
            if p == came or blocked[p]:
                continue
            forward = portal_cells[p, 0] == cell
            m = portal_cells[p, 1] if forward else portal_cells[p, 0]
            if m == source:
                continue
            n = exit_candidate(portal_quads, p, crack[p], cell_bounds, portal_cells, src, grow,
                               slope, planes, count, tol, common, scratch, cand)
            if n == 0:
                continue
            d = 2 * p + (0 if forward else 1)
            common_face(cell_bounds, portal_cells, p, common)
            grew = grow_box_step(box, d, cand, n, step, common, grow)
            crossed[p] = True
            if grew and not queued[d]:
                queued[d] = True
                queue[(head + size) % states] = d
                size += 1
        if size == 0:
            return walks
        current = queue[head]
        head = (head + 1) % states
        size -= 1
        queued[current] = False
        walks += 1
        if walks > budget:
            return -1

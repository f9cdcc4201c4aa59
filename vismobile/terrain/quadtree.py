"""Per-frame quadtree refinement shared by the tile and Röttger methods (numba kernels).

Nodes are squares of a (2^n+1)^2 heightmap: node (l, bi, bj) spans s = cells >> l cells from
(bi*s, bj*s); level l has 4^l nodes stored at offsets[l] + bi * 2^l + bj of flat per-node
arrays. Frame state is a stamp per node: subdivided in frame F when stamp == F, so nothing is
cleared between frames. After refinement, balancing makes every subdivided node's four edge
neighbours exist, so neighbouring leaves differ by at most one level.

Each kernel also runs over a paged tree (quadtree_paged.py's page table, the *_paged names):
one body, specialised by numba on the table's type, so the in-memory kernels (table None) keep
their own code: the storage index, the may-split test and the split are overloads that fold to
the flat arithmetic when there is no table.
"""
from __future__ import annotations

import numpy as np
from numba import njit, types
from numba.extending import overload

from .quadtree_paged import may_split, node_index, table_locals, want

ROETTGER, BOUND = 0, 1  # refinement criteria


def level_offsets(levels: int) -> np.ndarray:
    """(levels + 2,) int64 start of each level's nodes in flat arrays (4^l nodes per level)."""
    return np.r_[0, np.cumsum(4 ** np.arange(levels + 1))].astype(np.int64)


@njit(cache=True, inline="always")
def box_visible(planes, x0, y0, z0, x1, y1, z1):
    """False only if the box is entirely outside one plane (errs visible)."""
    for p in range(planes.shape[0]):
        px = x1 if planes[p, 0] >= 0 else x0
        py = y1 if planes[p, 1] >= 0 else y0
        pz = z1 if planes[p, 2] >= 0 else z0
        if planes[p, 0] * px + planes[p, 1] * py + planes[p, 2] * pz + planes[p, 3] < 0:
            return False
    return True


def _flat(table):
    return table is None or isinstance(table, types.NoneType)


def _view(table):
    """(pg, slots): the page table's locals (quadtree_paged.table_locals), or (None, None)."""


def _index(offsets, pg, slots, l, bi, bj):
    """Storage index of node (l, bi, bj) (quadtree_paged.node_index: -1 when not resident)."""


def _may_split(pg, slots, table, l, bi, bj):
    """quadtree_paged.may_split; always True in memory."""


def _split(offsets, pg, slots, table, stamp, frame, lists, counts, list_offsets, l, bi, bj,
           node, index):
    """Subdivide node (l, bi, bj) (its id node within the level, its storage index) unless it
    is already, or has no storage, or is a page level node of a page not resident (then
    wanted). Returns 1 when it was subdivided now."""


@overload(_view)
def _view_impl(table):
    def flat(table):
        return None, None

    def paged(table):
        return table_locals(table)
    return flat if _flat(table) else paged


@overload(_index)
def _index_impl(offsets, pg, slots, l, bi, bj):
    def flat(offsets, pg, slots, l, bi, bj):
        return offsets[l] + bi * (1 << l) + bj

    def paged(offsets, pg, slots, l, bi, bj):
        return node_index(offsets, pg, slots, l, bi, bj)
    return flat if _flat(pg) else paged


@overload(_may_split)
def _may_split_impl(pg, slots, table, l, bi, bj):
    def flat(pg, slots, table, l, bi, bj):
        return True

    def paged(pg, slots, table, l, bi, bj):
        return may_split(pg, slots, table, l, bi, bj)
    return flat if _flat(pg) else paged


@overload(_split)
def _split_impl(offsets, pg, slots, table, stamp, frame, lists, counts, list_offsets, l, bi, bj,
                node, index):
    def paged(offsets, pg, slots, table, stamp, frame, lists, counts, list_offsets, l, bi, bj,
              node, index):
        if index < 0:
            lg = pg[0]
            want(table, lg, (bi >> (l - lg)) * (1 << lg) + (bj >> (l - lg)))
            return 0
        if stamp[index] == frame or not may_split(pg, slots, table, l, bi, bj):
            return 0
        stamp[index] = frame
        lists[list_offsets[l] + counts[l]] = node
        counts[l] += 1
        return 1

    def flat(offsets, pg, slots, table, stamp, frame, lists, counts, list_offsets, l, bi,
                   bj, node, index):
        if stamp[index] == frame:
            return 0
        stamp[index] = frame
        lists[list_offsets[l] + counts[l]] = node
        counts[l] += 1
        return 1
    return flat if _flat(pg) else paged


@njit(cache=True)
def refine(cells, spacing, centre_heights, error, hmin, hmax, offsets, levels, stamp, frame,
           eye, planes, mode, a, b, cull, lists, counts):
    """Top-down refinement, then balancing.

    mode ROETTGER: refine while l1(eye, centre) < d * a (Röttger's minimum resolution, a = C)
      or dist(eye, box) < d * a * b * error (b = c, error = d2, with d * d2 a strict bound of
      the block's vertical error: the roughness branch measured to the nearest point of the
      block's box instead of the L1 distance to its centre, so the bound holds everywhere);
      mode BOUND: refine while a * error > b * dist(eye, box) (a = lambda, b = tau).
    Nodes outside the frustum are not refined when cull. lists gets level l's subdivided nodes
    at lists[offsets[l]:offsets[l] + counts[l]]. Returns the nodes whose criterion ran.
    """
    return _refine(cells, spacing, centre_heights, error, hmin, hmax, offsets, levels, stamp,
                   frame, eye, planes, mode, a, b, cull, lists, counts, None, offsets)


@njit(cache=True)
def refine_paged(cells, spacing, centre_heights, error, hmin, hmax, offsets, levels, stamp,
                 frame, eye, planes, mode, a, b, cull, lists, counts, table, list_offsets):
    """refine over a paged tree: lists at list_offsets; a page level node whose page is not
    resident is not subdivided (the page wanted)."""
    return _refine(cells, spacing, centre_heights, error, hmin, hmax, offsets, levels, stamp,
                   frame, eye, planes, mode, a, b, cull, lists, counts, table, list_offsets)


@njit(cache=True)
def _refine(cells, spacing, centre_heights, error, hmin, hmax, offsets, levels, stamp, frame,
            eye, planes, mode, a, b, cull, lists, counts, table, list_offsets):
    pg, slots = _view(table)
    for l in range(levels + 1):
        counts[l] = 0
    stack = np.empty((4 * (levels + 2), 3), np.int64)
    stack[0, 0], stack[0, 1], stack[0, 2] = 0, 0, 0
    top = 1
    tested = 0
    while top > 0:
        top -= 1
        l, bi, bj = stack[top, 0], stack[top, 1], stack[top, 2]
        if l == levels:
            continue
        m = 1 << l
        index = _index(offsets, pg, slots, l, bi, bj)
        if index < 0:
            continue
        s = cells >> l
        x0, z0 = bj * s * spacing, bi * s * spacing
        x1, z1 = x0 + s * spacing, z0 + s * spacing
        tested += 1
        if cull and not box_visible(planes, x0, hmin[index], z0, x1, hmax[index], z1):
            continue
        dx = max(x0 - eye[0], 0.0, eye[0] - x1)
        dy = max(hmin[index] - eye[1], 0.0, eye[1] - hmax[index])
        dz = max(z0 - eye[2], 0.0, eye[2] - z1)
        dist = np.sqrt(dx * dx + dy * dy + dz * dz)
        if mode == ROETTGER:
            cx, cz = 0.5 * (x0 + x1), 0.5 * (z0 + z1)
            l1 = abs(eye[0] - cx) + abs(eye[1] - centre_heights[index]) + abs(eye[2] - cz)
            d = s * spacing
            split = l1 < d * a or dist < d * a * b * error[index]
        else:
            split = a * error[index] > b * dist
        if split and _may_split(pg, slots, table, l, bi, bj):
            stamp[index] = frame
            lists[list_offsets[l] + counts[l]] = bi * m + bj
            counts[l] += 1
            for k in range(4):
                stack[top, 0] = l + 1
                stack[top, 1] = 2 * bi + (k >> 1)
                stack[top, 2] = 2 * bj + (k & 1)
                top += 1
    _balance(offsets, levels, stamp, frame, lists, counts, table, list_offsets)
    return tested


@njit(cache=True)
def balance(offsets, levels, stamp, frame, lists, counts):
    """Fine to coarse: a subdivided node's edge neighbours must exist (their parents
    subdivided). Splitting at level l-1 only adds leaves at level l, so one pass."""
    _balance(offsets, levels, stamp, frame, lists, counts, None, offsets)


@njit(cache=True)
def balance_paged(offsets, levels, stamp, frame, lists, counts, table, list_offsets):
    """balance over a paged tree."""
    _balance(offsets, levels, stamp, frame, lists, counts, table, list_offsets)


@njit(cache=True)
def _balance(offsets, levels, stamp, frame, lists, counts, table, list_offsets):
    pg, slots = _view(table)
    for l in range(levels - 1, 0, -1):
        m = 1 << l
        pm = m >> 1
        k = 0
        while k < counts[l]:
            node = lists[list_offsets[l] + k]
            bi, bj = node // m, node % m
            k += 1
            for q in range(5):
                ni, nj = bi, bj
                if q == 1:
                    ni += 1
                elif q == 2:
                    ni -= 1
                elif q == 3:
                    nj += 1
                elif q == 4:
                    nj -= 1
                if ni < 0 or nj < 0 or ni >= m or nj >= m:
                    continue
                index = _index(offsets, pg, slots, l - 1, ni >> 1, nj >> 1)
                if index >= 0 and stamp[index] == frame:
                    continue
                _split(offsets, pg, slots, table, stamp, frame, lists, counts, list_offsets,
                       l - 1, ni >> 1, nj >> 1, (ni >> 1) * pm + (nj >> 1), index)


@njit(cache=True, inline="always")
def side_neighbour(bi, bj, bit):
    """Node (bi, bj)'s same-level neighbour across side bit (coarser_sides' bits 0..3)."""
    if bit == 0:
        return bi - 1, bj
    if bit == 1:
        return bi, bj + 1
    if bit == 2:
        return bi + 1, bj
    return bi, bj - 1


@njit(cache=True, inline="always")
def coarser_sides(stamp, offsets, frame, l, bi, bj, pg, slots):
    """Bits of the sides whose same-level neighbour does not exist (a coarser leaf is there):
    1 row-0 side, 2 last-column side, 4 last-row side, 8 column-0 side; never the border.
    pg, slots: _view(table)."""
    m = 1 << l
    sides = 0
    if l == 0:
        return 0
    for bit in range(4):
        ni, nj = side_neighbour(bi, bj, bit)
        if ni < 0 or nj < 0 or ni >= m or nj >= m:
            continue
        index = _index(offsets, pg, slots, l - 1, ni >> 1, nj >> 1)
        if index < 0 or stamp[index] != frame:
            sides |= 1 << bit
    return sides


@njit(cache=True)
def leaves(cells, spacing, hmin, hmax, offsets, levels, stamp, frame, planes, cull, out):
    """Visible leaves as rows (level, bi, bj, sides) of out, in depth-first order; returns
    (count, leaves in the tree), count -1 when out has too few rows (4^levels always suffice)."""
    return _leaves(cells, spacing, hmin, hmax, offsets, levels, stamp, frame, planes, cull, out,
                   None)


@njit(cache=True)
def leaves_paged(cells, spacing, hmin, hmax, offsets, levels, stamp, frame, planes, cull, out,
                 table):
    """leaves over a paged tree."""
    return _leaves(cells, spacing, hmin, hmax, offsets, levels, stamp, frame, planes, cull, out,
                   table)


@njit(cache=True)
def _leaves(cells, spacing, hmin, hmax, offsets, levels, stamp, frame, planes, cull, out, table):
    pg, slots = _view(table)
    stack = np.empty((4 * (levels + 2), 3), np.int64)
    stack[0, 0], stack[0, 1], stack[0, 2] = 0, 0, 0
    top = 1
    count = 0
    total = 0
    while top > 0:
        top -= 1
        l, bi, bj = stack[top, 0], stack[top, 1], stack[top, 2]
        index = _index(offsets, pg, slots, l, bi, bj)
        if l < levels and stamp[index] == frame:
            for k in range(4):
                stack[top, 0] = l + 1
                stack[top, 1] = 2 * bi + (k >> 1)
                stack[top, 2] = 2 * bj + (k & 1)
                top += 1
            continue
        total += 1
        s = cells >> l
        x0, z0 = bj * s * spacing, bi * s * spacing
        if cull and not box_visible(planes, x0, hmin[index], z0, x0 + s * spacing, hmax[index],
                                    z0 + s * spacing):
            continue
        if count == out.shape[0]:
            return -1, total
        out[count, 0], out[count, 1], out[count, 2] = l, bi, bj
        out[count, 3] = coarser_sides(stamp, offsets, frame, l, bi, bj, pg, slots)
        count += 1
    return count, total


@njit(cache=True)
def unreduce_finest(cells, spacing, levels, offsets, stamp, frame, lists, counts, skip_error,
                    hmin, hmax, eye, planes, lam, tau, cull):
    """Leaves of the finest level cannot refine, yet drop the odd vertices of a side beside a
    coarser leaf (Röttger's skipped midpoints, the tiles' reduced sides). For each visible
    finest leaf whose error with such a side, skip_error (per node, the finest level's
    entries read), is over tau from its box (lam * E > tau * dist), subdivide every coarser
    neighbour so the side keeps its vertices. Children of newly subdivided nodes are checked in
    the same loop. Returns the nodes subdivided (balance again afterwards)."""
    return _unreduce_finest(cells, spacing, levels, offsets, stamp, frame, lists, counts,
                            skip_error, hmin, hmax, eye, planes, lam, tau, cull, None, offsets)


@njit(cache=True)
def unreduce_finest_paged(cells, spacing, levels, offsets, stamp, frame, lists, counts,
                          skip_error, hmin, hmax, eye, planes, lam, tau, cull, table,
                          list_offsets):
    """unreduce_finest over a paged tree (a neighbour of a page not resident: the page
    wanted)."""
    return _unreduce_finest(cells, spacing, levels, offsets, stamp, frame, lists, counts,
                            skip_error, hmin, hmax, eye, planes, lam, tau, cull, table,
                            list_offsets)


@njit(cache=True)
def _unreduce_finest(cells, spacing, levels, offsets, stamp, frame, lists, counts, skip_error,
                     hmin, hmax, eye, planes, lam, tau, cull, table, list_offsets):
    pg, slots = _view(table)
    L = levels
    m = 1 << L
    pm = m >> 1
    s = cells >> L
    added = 0
    k = 0
    while k < counts[L - 1]:
        node = lists[list_offsets[L - 1] + k]
        k += 1
        pi, pj = node // pm, node % pm
        for q in range(4):
            bi, bj = 2 * pi + (q >> 1), 2 * pj + (q & 1)
            index = _index(offsets, pg, slots, L, bi, bj)
            x0, z0 = bj * s * spacing, bi * s * spacing
            x1, z1 = x0 + s * spacing, z0 + s * spacing
            if cull and not box_visible(planes, x0, hmin[index], z0, x1, hmax[index], z1):
                continue
            dx = max(x0 - eye[0], 0.0, eye[0] - x1)
            dy = max(hmin[index] - eye[1], 0.0, eye[1] - hmax[index])
            dz = max(z0 - eye[2], 0.0, eye[2] - z1)
            if not lam * skip_error[index] > tau * np.sqrt(dx * dx + dy * dy + dz * dz):
                continue
            sides = coarser_sides(stamp, offsets, frame, L, bi, bj, pg, slots)
            for bit in range(4):
                if not sides & (1 << bit):
                    continue
                ni, nj = side_neighbour(bi, bj, bit)
                added += _split(offsets, pg, slots, table, stamp, frame, lists, counts,
                                list_offsets, L - 1, ni >> 1, nj >> 1, (ni >> 1) * pm + (nj >> 1),
                                _index(offsets, pg, slots, L - 1, ni >> 1, nj >> 1))
    return added

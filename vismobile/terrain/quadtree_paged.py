"""quadtree.py's kernels over a paged tree (terrain/paged_roettger.py).

Nodes at levels <= the page level are stored flat (quadtree's offsets[l] + bi * 2^l + bj); a
node below it lives in the slot of its page (the page level's node above it) when that page is
resident, else it has no storage (node_index -1). A page level node whose page is not resident
is never subdivided: the kernels add the page to the table's wanted list instead, and the
caller reads those pages and runs the frame again. Per-level lists of subdivided nodes start at
list_offsets (room for the held pages only). The unpaged kernels stay in quadtree.py, apart:
the indirection made them 2.5-3.6x slower. Helpers taking many arrays cost a call each even
when marked inline (balance_paged ran 10x balance's time through _split, leaves_paged 2.2x
leaves' through present): the common paths here are written out.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from .quadtree import ROETTGER, box_visible

# page_table layout: [page level, nodes per page, first slot node, wanted count, slot of each
# page (4^page level, -1 when not resident), wanted pages (as many)]
PAGE_LEVEL, PER_PAGE, BASE, WANTED, SLOTS = 0, 1, 2, 3, 4


@njit(cache=True, inline="always")
def node_index(offsets, pg, slots, l, bi, bj):
    """Storage index of node (l, bi, bj), or -1 when its page is not resident. pg: the table's
    (page level, nodes per page, first slot node) and slots its slot per page, read once per
    kernel into locals (read through the table at every node, which the kernels also write,
    refine ran 3x slower than quadtree's)."""
    lg, per_page, base = pg
    if l <= lg:
        return offsets[l] + bi * (1 << l) + bj
    k = l - lg
    slot = slots[(bi >> k) * (1 << lg) + (bj >> k)]
    if slot < 0:
        return -1
    mk = 1 << k
    local = ((1 << (2 * k)) - 4) // 3 + (bi & (mk - 1)) * mk + (bj & (mk - 1))
    return base + slot * per_page + local


@njit(cache=True, inline="always")
def _locals(table):
    return (table[PAGE_LEVEL], table[PER_PAGE], table[BASE]), table[SLOTS:]


@njit(cache=True, inline="always")
def may_split(pg, slots, table, l, bi, bj):
    """False (and the page wanted) for a page level node of a paged tree whose page is not
    resident: its children have no storage."""
    if pg[1] == 0 or l != pg[0]:
        return True
    page = bi * (1 << l) + bj
    if slots[page] >= 0:
        return True
    pages = 1 << (2 * l)
    n = table[WANTED]
    if n < pages:
        table[SLOTS + pages + n] = page
        table[WANTED] = n + 1
    return False


@njit(cache=True)
def refine_paged(cells, spacing, centre_heights, error, hmin, hmax, offsets, levels, stamp,
                 frame, eye, planes, mode, a, b, cull, lists, counts, table, list_offsets):
    """Top-down refinement, then balancing.

    mode ROETTGER: refine while l1(eye, centre) < d * a (Röttger's minimum resolution, a = C)
      or dist(eye, box) < d * a * b * error (b = c, error = d2, with d * d2 a strict bound of
      the block's vertical error: the roughness branch measured to the nearest point of the
      block's box instead of the L1 distance to its centre, so the bound holds everywhere);
      mode BOUND: refine while a * error > b * dist(eye, box) (a = lambda, b = tau).
    Nodes outside the frustum are not refined when cull. lists gets level l's subdivided nodes
    at lists[list_offsets[l]:list_offsets[l] + counts[l]]. Returns the nodes whose criterion
    ran.
    """
    pg, slots = _locals(table)
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
        index = node_index(offsets, pg, slots, l, bi, bj)
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
        if split and may_split(pg, slots, table, l, bi, bj):
            stamp[index] = frame
            lists[list_offsets[l] + counts[l]] = bi * m + bj
            counts[l] += 1
            for k in range(4):
                stack[top, 0] = l + 1
                stack[top, 1] = 2 * bi + (k >> 1)
                stack[top, 2] = 2 * bj + (k & 1)
                top += 1
    balance_paged(offsets, levels, stamp, frame, lists, counts, table, list_offsets)
    return tested


@njit(cache=True)
def balance_paged(offsets, levels, stamp, frame, lists, counts, table, list_offsets):
    """Fine to coarse: a subdivided node's edge neighbours must exist (their parents
    subdivided). Splitting at level l-1 only adds leaves at level l, so one pass."""
    pg, slots = _locals(table)
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
                parent = (ni >> 1) * pm + (nj >> 1)
                index = node_index(offsets, pg, slots, l - 1, ni >> 1, nj >> 1)
                if index >= 0 and stamp[index] == frame:
                    continue  # the common case, without _split's call
                _split(offsets, pg, slots, table, stamp, frame, lists, counts, list_offsets,
                       l - 1, ni >> 1, nj >> 1, parent)


@njit(cache=True, inline="always")
def _split(offsets, pg, slots, table, stamp, frame, lists, counts, list_offsets, l, bi, bj, node):
    """Subdivide node (l, bi, bj) (its id node within the level) unless it is already, or has
    no storage, or is a page level node of a page not resident (then wanted). Returns 1 when
    it was subdivided now."""
    index = node_index(offsets, pg, slots, l, bi, bj)
    if index < 0:
        lg = pg[0]
        page = (bi >> (l - lg)) * (1 << lg) + (bj >> (l - lg))
        pages = 1 << (2 * lg)
        if table[WANTED] < pages:
            table[SLOTS + pages + table[WANTED]] = page
            table[WANTED] += 1
        return 0
    if stamp[index] == frame or not may_split(pg, slots, table, l, bi, bj):
        return 0
    stamp[index] = frame
    lists[list_offsets[l] + counts[l]] = node
    counts[l] += 1
    return 1


@njit(cache=True, inline="always")
def present(stamp, offsets, frame, l, bi, bj, pg, slots):
    """Node (l, bi, bj) exists this frame: the root, or its parent is subdivided."""
    if l == 0:
        return True
    index = node_index(offsets, pg, slots, l - 1, bi >> 1, bj >> 1)
    return index >= 0 and stamp[index] == frame


@njit(cache=True, inline="always")
def coarser_sides(stamp, offsets, frame, l, bi, bj, pg, slots):
    """Bits of the sides whose same-level neighbour does not exist (a coarser leaf is there):
    1 row-0 side, 2 last-column side, 4 last-row side, 8 column-0 side; never the border.
    (present's test written out: a call per side cost leaves 2.2x quadtree's time.)"""
    m = 1 << l
    sides = 0
    if l == 0:
        return 0
    for bit in range(4):
        ni, nj = bi, bj
        if bit == 0:
            ni -= 1
        elif bit == 1:
            nj += 1
        elif bit == 2:
            ni += 1
        else:
            nj -= 1
        if ni < 0 or nj < 0 or ni >= m or nj >= m:
            continue
        index = node_index(offsets, pg, slots, l - 1, ni >> 1, nj >> 1)
        if index < 0 or stamp[index] != frame:
            sides |= 1 << bit
    return sides


@njit(cache=True)
def leaves_paged(cells, spacing, hmin, hmax, offsets, levels, stamp, frame, planes, cull, out,
                 table):
    """Visible leaves as rows (level, bi, bj, sides) of out, in depth-first order; returns
    (count, leaves in the tree), count -1 when out has too few rows (4^levels always suffice)."""
    pg, slots = _locals(table)
    stack = np.empty((4 * (levels + 2), 3), np.int64)
    stack[0, 0], stack[0, 1], stack[0, 2] = 0, 0, 0
    top = 1
    count = 0
    total = 0
    while top > 0:
        top -= 1
        l, bi, bj = stack[top, 0], stack[top, 1], stack[top, 2]
        index = node_index(offsets, pg, slots, l, bi, bj)
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
def unreduce_finest_paged(cells, spacing, levels, offsets, stamp, frame, lists, counts,
                          skip_error, hmin, hmax, eye, planes, lam, tau, cull, table,
                          list_offsets):
    """Leaves of the finest level cannot refine, yet drop the odd vertices of a side beside a
    coarser leaf (Röttger's skipped midpoints, the tiles' reduced sides). For each visible
    finest leaf whose error with such a side, skip_error (per node, the finest level's
    entries read), is over tau from its box (lam * E > tau * dist), subdivide every coarser
    neighbour so the side keeps its vertices. Children of newly subdivided nodes are checked in
    the same loop. Returns the nodes subdivided (balance again afterwards)."""
    pg, slots = _locals(table)
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
            index = node_index(offsets, pg, slots, L, bi, bj)
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
                ni, nj = bi, bj
                if bit == 0:
                    ni -= 1
                elif bit == 1:
                    nj += 1
                elif bit == 2:
                    ni += 1
                else:
                    nj -= 1
                parent = (ni >> 1) * pm + (nj >> 1)
                added += _split(offsets, pg, slots, table, stamp, frame, lists, counts,
                                list_offsets, L - 1, ni >> 1, nj >> 1, parent)
    return added

"""Compiled per-frame kernels (numba, cached on disk): the frustum walk over the flat tree, run
counting, and the back-face bound the per-triangle tests in facing.py use (the distinct gather
is in gather.py).

Each frame used to cost hundreds of small numpy calls (one batch per tree level, masks over the
whole world); these loops do the same arithmetic once per touched node or reference, so a
frame's cost follows what is in the frustum, not the size of the world. Scratch arrays are
allocated once per tree (Tree.scratch) and reused.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from .prefetch import prefetch


def node_records(node_bounds, first_child, child_count, nonempty) -> tuple:
    """(box, links): one (N, 8) record per node for frustum_walk, float32 when every bound is
    a float32 (octree cells are rounded to float32: the same numbers), else float64; links is
    the same memory read as integers. A visited node's box and links share a cache line (its
    siblings the next ones), instead of six arrays' lines."""
    flat = np.asarray(node_bounds, dtype=np.float64).reshape(-1, 6)
    narrow = np.array_equal(flat.astype(np.float32).astype(np.float64), flat)
    box = np.empty((len(flat), 8), dtype=np.float32 if narrow else np.float64)
    links = box.view(np.int32 if narrow else np.int64)
    box[:, :6] = flat
    links[:, 6] = first_child
    links[:, 7] = np.where(nonempty, child_count, -1)
    return box, links


def inner_records(box, links) -> np.ndarray:
    """(M, 16) per node below M (every node with children; breadth-first order puts them
    first), box's dtype, for frustum_walk:
    0:3, 3:6  its cover: the least hi and the greatest lo, per axis, of the non-empty nodes
              strictly below it (+inf / -inf when none). For a plane (n, d), d + sum over axes
              of n_i * (the least hi_i when n_i > 0, else the greatest lo_i) is at most the
              distance of the p-vertex of every such node: when it is >= 0, none of them lies
              behind that plane;
    6, 7      (as integers) its children's octant codes, 3 bits each, and 1 when its children
              are all non-empty leaves whose boxes are octants of its own: child k's lo_i is
              split_lo_i when bit i of its code is set, else the node's lo_i; its hi_i the
              node's hi_i when set, else split_hi_i (checked exactly against their records);
    8:11, 11:14 split_lo, split_hi.
    Exact: every number is one of the boxes' own.
    """
    inner = np.flatnonzero(links[:, 7] > 0)
    records = np.zeros((int(inner[-1]) + 1 if len(inner) else 0, 16), dtype=box.dtype)
    records[:, :3] = np.inf
    records[:, 3:6] = -np.inf
    if len(records):
        _cover_up(box, links, records)
        _octants(box, links, records, records.view(links.dtype))
    return records


@njit(cache=True, nogil=True)
def _cover_up(box, links, cover):
    """Fill columns 0:6 bottom-up; children follow their parent (the layout is breadth-first)."""
    for node in range(len(cover) - 1, -1, -1):
        n = links[node, 7]
        if n <= 0:
            continue
        first = links[node, 6]
        for c in range(first, first + n):
            if links[c, 7] < 0:  # references nothing: the walk skips it
                continue
            below = c < len(cover)
            for i in range(3):
                least = min(cover[node, i], box[c, 3 + i])
                most = max(cover[node, 3 + i], box[c, i])
                if below:
                    least = min(least, cover[c, i])
                    most = max(most, cover[c, 3 + i])
                cover[node, i] = least
                cover[node, 3 + i] = most


@njit(cache=True, nogil=True)
def _octants(box, links, records, ints):
    """Columns 6:14 of inner_records: the octant codes and split of each node whose children
    are non-empty leaves with octant boxes (ints: records read as integers)."""
    for node in range(len(records)):
        n = links[node, 7]
        if n <= 0 or n > 8:
            continue
        first = links[node, 6]
        codes = 0
        ok = True
        for k in range(n):
            c = first + k
            if links[c, 7] != 0:  # not a non-empty leaf
                ok = False
                break
            code = 0
            for i in range(3):
                if box[c, i] != box[node, i]:  # the upper half on axis i
                    code |= 1 << i
                    records[node, 8 + i] = box[c, i]
                else:
                    records[node, 11 + i] = box[c, 3 + i]
            codes |= code << (3 * k)
        if not ok:
            continue
        for k in range(n):  # every child's box must come out of the rule exactly
            c = first + k
            code = (codes >> (3 * k)) & 7
            for i in range(3):
                upper = (code >> i) & 1
                lo = records[node, 8 + i] if upper else box[node, i]
                hi = box[node, 3 + i] if upper else records[node, 11 + i]
                if lo != box[c, i] or hi != box[c, 3 + i]:
                    ok = False
        if ok:
            ints[node, 6] = codes
            ints[node, 7] = 1


@njit(cache=True, nogil=True, inline="always")
def _lowest_bit(mask):
    """Index of the lowest set bit of mask > 0 (a plane mask: at most 62 bits)."""
    p = 0
    while not (mask >> p) & 1:
        p += 1
    return p


@njit(cache=True, nogil=True, inline="always")
def _box_planes(lx, ly, lz, ux, uy, uz, planes, mask, tol):
    """(outside, straddled planes, planes tested) of the box lo, hi against the planes of mask
    (p-vertex / n-vertex with tol toward keeping); stops at the first plane it is behind."""
    cx = 0.5 * (lx + ux)
    cy = 0.5 * (ly + uy)
    cz = 0.5 * (lz + uz)
    hx = 0.5 * (ux - lx)
    hy = 0.5 * (uy - ly)
    hz = 0.5 * (uz - lz)
    straddle = np.int64(0)
    tests = 0
    rest = mask
    while rest:  # the planes of the mask, lowest first
        p = _lowest_bit(rest)
        bit = np.int64(1) << p
        rest ^= bit
        tests += 1
        nx, ny, nz = planes[p, 0], planes[p, 1], planes[p, 2]
        mid = cx * nx + cy * ny + cz * nz + planes[p, 3]
        reach = hx * abs(nx) + hy * abs(ny) + hz * abs(nz)
        if mid + reach < -tol:
            return True, straddle, tests
        if mid - reach < tol:
            straddle |= bit
    return False, straddle, tests


@njit(cache=True, nogil=True)
def frustum_walk(box, links, size, whole_below, inner, inner_links, covering, roots, root_sets,
                 plane_sets, tol, out, stack_node, stack_set, stack_mask, allow=None):
    """Hierarchical p/n-vertex frustum test with plane masks, depth first from `roots`.

    Errs toward keeping by tol: a box is rejected only when its p-vertex is more than tol
    behind a plane; it is accepted whole when its n-vertex is at least tol inside every plane
    its parent straddled, or when it straddles a plane and size[node] <= whole_below (a
    superset: its subtree's part outside the frustum is sent too; whole_below < 0: never), or
    (covering) when it straddles planes but no node below it would be rejected by them: its
    cover (inner_records) is >= tol for each. Then its subtree's leaves are the walk's
    accepted leaves below it, every one: the same triangles, from fewer nodes.
    A node whose children are octant leaves (inner_records) tests them from its own record:
    the same boxes, so the same decisions, without reading theirs.
    box, links  : (N, 8) views of one record per node (node_records): box[n, :6] its corners
                  lo, hi (float32 or float64, widened to float64 here), links[n, 6] its first
                  child, links[n, 7] its child count or -1 when it references nothing
    size        : (N,) int, what accepting the node whole costs (pairs read)
    inner, inner_links : inner_records(box, links) and the same read as integers
    covering    : bool, accept covered nodes whole
    roots : (K,) int64;  root_sets : (K,) int64 into plane_sets
    plane_sets  : (S, P, 4) float64 inward planes (n, d), P <= 62
    out         : (>= accepted,) int64 receives accepted nodes; stacks : (>= K + N,) scratch
    allow       : None, or (N,) bool: a node not allowed is skipped like one referencing
                  nothing (the pvs stage: subtrees holding no triangle of the eye's set,
                  culling/pvs_frame.py); None compiles without the test
    returns (accepted, visited, plane tests, culled, inner nodes accepted while straddling by
    whole_below, inner nodes accepted by their cover); plane tests count the cover's too
    """
    planes_per_set = plane_sets.shape[1]
    full = (np.int64(1) << planes_per_set) - 1
    top = 0
    for k in range(len(roots) - 1, -1, -1):
        stack_node[top] = roots[k]
        stack_set[top] = root_sets[k]
        stack_mask[top] = full
        top += 1
    count = visited = tests = culled = straddling = covered = 0
    while top > 0:
        top -= 1
        node, s, mask = stack_node[top], stack_set[top], stack_mask[top]
        n = links[node, 7]
        if n < 0:  # references nothing
            continue
        if allow is not None:
            if not allow[node]:
                continue
        visited += 1
        lx, ly, lz = np.float64(box[node, 0]), np.float64(box[node, 1]), np.float64(box[node, 2])
        ux, uy, uz = np.float64(box[node, 3]), np.float64(box[node, 4]), np.float64(box[node, 5])
        outside, straddle, done = _box_planes(lx, ly, lz, ux, uy, uz, plane_sets[s], mask, tol)
        tests += done
        if outside:
            culled += 1
            continue
        if straddle == 0 or n == 0:
            out[count] = node
            count += 1
            continue
        if size[node] <= whole_below:
            straddling += 1
            out[count] = node
            count += 1
            continue
        if covering:
            whole = True
            rest = straddle
            while rest:
                p = _lowest_bit(rest)
                rest ^= np.int64(1) << p
                tests += 1
                nx, ny, nz = plane_sets[s, p, 0], plane_sets[s, p, 1], plane_sets[s, p, 2]
                least = plane_sets[s, p, 3]
                least += nx * (np.float64(inner[node, 0]) if nx > 0 else np.float64(inner[node, 3]))
                least += ny * (np.float64(inner[node, 1]) if ny > 0 else np.float64(inner[node, 4]))
                least += nz * (np.float64(inner[node, 2]) if nz > 0 else np.float64(inner[node, 5]))
                if not least >= tol:  # tol of margin for rounding: errs toward walking
                    whole = False
                    break
            if whole:
                covered += 1
                out[count] = node
                count += 1
                continue
        first = links[node, 6]
        if inner_links[node, 7] == 1:  # octant leaves: their boxes from this record, in order
            codes = inner_links[node, 6]
            for c in range(n):
                if allow is not None:
                    if not allow[first + c]:
                        continue
                code = (codes >> (3 * c)) & 7
                clx = np.float64(inner[node, 8]) if code & 1 else lx
                cly = np.float64(inner[node, 9]) if code & 2 else ly
                clz = np.float64(inner[node, 10]) if code & 4 else lz
                cux = ux if code & 1 else np.float64(inner[node, 11])
                cuy = uy if code & 2 else np.float64(inner[node, 12])
                cuz = uz if code & 4 else np.float64(inner[node, 13])
                visited += 1
                outside, _, done = _box_planes(clx, cly, clz, cux, cuy, cuz, plane_sets[s],
                                               straddle, tol)
                tests += done
                if outside:
                    culled += 1
                else:
                    out[count] = first + c
                    count += 1
            continue
        for c in range(n):  # the children's records, read soon
            prefetch(box, first + c)
        for c in range(n - 1, -1, -1):  # first child on top: depth-first in stored order
            stack_node[top] = first + c
            stack_set[top] = s
            stack_mask[top] = straddle
            top += 1
    return count, visited, tests, culled, straddling, covered


@njit(cache=True, nogil=True)
def run_count(ids):
    """Maximal runs of consecutive values in ids (draw batches of a sorted id list)."""
    runs = 0
    for k in range(len(ids)):
        if k == 0 or ids[k] != ids[k - 1] + 1:
            runs += 1
    return runs


@njit(cache=True, nogil=True, inline="always")
def backface_threshold(delta, lw, ea, eb, rounding):
    """How far below zero det must be for a triangle to face away certainly: triangle_backface's
    bound for corners and eye moved by up to delta per coordinate, plus `rounding` (gamma8
    |c|.|w|), raised by 2^-50 for its own evaluation. Errs large (toward keeping).
    lw : |e - v0|;  ea, eb : |v1 - v0|, |v2 - v0|. The one copy of the bound the compiled
    back-face kernels (facing.py) use; numpy's is certainly_backfacing."""
    moved = np.sqrt(3.0) * delta * (2.0 * lw * (ea + eb) + 2.0 * ea * eb) \
        + 36.0 * delta * delta * (lw + ea + eb) + 48.0 * delta * delta * delta
    return (moved + rounding) * (1.0 + 2.0 ** -50)

"""The tiled depth buffer's node walks (numba, cached on disk): tree boxes tested against the
buffer from the root, hidden subtrees never entered (cull_nodes), and the same fused with the
frustum test (frustum_cull_nodes), which may stop expanding after a budget of nodes (the rest
is refined by cull_nodes once later rounds have filled the buffer). Box tests as in buffer.py;
errs toward keeping.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from ..kernels import _box_planes
from .buffer import _behind, _centre_rect, _local_border, _rect
from .raster import _box_to_camera

# With a screen, node boxes whose rectangle spans up to this many pixels (width + height, buffer
# pixels) are tested at the centres (cull_nodes): on w2x7 wider ones cost more than they cull.
CENTRE_SPAN = 24.0
# frustum_cull_nodes' budget that never stops a walk.
NO_BUDGET = 1 << 62
# The node walks take a subtree of at most this many triangle references as one node
# (walk_child_counts): its triangles are tested one by one after, cheaper than its boxes.
WHOLE_REFS = 16


def walk_child_counts(child_count, ref_start, ref_end, whole=WHOLE_REFS) -> np.ndarray:
    """(N,) int64 child counts for the node walks (cull_nodes, frustum_cull_nodes) and the
    candidates' walks: an inner node whose subtree holds at most `whole` triangle references
    (ref_end - ref_start) counts as a leaf, so a walk keeps it whole instead of testing its
    boxes (on tiled W2 at octree 7, a visible leaf names 0.3 distinct triangles: a room's
    wall is referenced by dozens of leaves). Built once per tree. Errs toward keeping: a
    node kept whole sends every triangle of its subtree to the triangle tests that follow,
    which are the conservative ones."""
    counts = np.asarray(child_count, dtype=np.int64)
    if whole <= 0:
        return counts
    refs = np.asarray(ref_end, dtype=np.int64) - np.asarray(ref_start, dtype=np.int64)
    return np.where(refs <= whole, 0, counts)


@njit(cache=True, nogil=True)
def _touches(x0, x1, y0, y1, tile_any, cols, tw, th):
    for ty_ in range(y0 // th, y1 // th + 1):
        for tx_ in range(x0 // tw, x1 // tw + 1):
            if tile_any[ty_ * cols + tx_]:
                return True
    return False


@njit(cache=True, nogil=True, inline="always")
def _box_hidden(cam, near, tx, ty, width, height, move, shift, sample_move, tile_shift, sw, sh,
                depth, tile_max, cols, tw, th, margin, recede, r):
    """The node walks' box test of the 8 camera-space corners cam: True when testable and off
    screen or behind the buffer (_rect into r, _behind), or, with a screen (sw > 0) and a span
    of at most CENTRE_SPAN pixels, when no centre lies under it (_centre_rect narrows r first).
    Contract: errs toward False (kept), as _rect, _centre_rect and _behind do."""
    _rect(cam, 8, near, tx, ty, width, height, move, shift, r)
    if r[5] == 0:
        return False
    if r[6] == 2:
        _local_border(r, shift, tx, ty, width, height, tile_shift, cols, tw, th)
    if sw > 0 and r[6] != 0 and r[1] - r[0] + r[3] - r[2] <= CENTRE_SPAN and not _centre_rect(
            cam, 8, tx, ty, width, height, sample_move, move, shift, tile_shift, cols, tw, th,
            sw, sh, r):
        return True
    return r[6] == 0 or (r[6] == 1 and _behind(int(r[0]), int(r[1]), int(r[2]), int(r[3]),
                                               r[4], depth, width, tile_max,
                                               (height + th - 1) // th, cols, tw, th, margin,
                                               recede))


@njit(cache=True, nogil=True)
def cull_nodes(lo, hi, first_child, child_count, nonempty, parent, roots, draw_mark, up_mark,
               frame, eye, rot, near, tx, ty, width, height, move, shift, margin, recede, depth,
               tile_max, tile_any, tile_shift, tw, th, out, stack, below, nearest_far, from_root,
               sw, sh, sample_move):
    """Occlusion walk over the subtrees of `roots` (the frame's draw nodes), entered from the
    tree's root so that hidden regions go at a coarse level: an ancestor of draw nodes that is
    hidden by the buffer (module docstring) drops every draw node under it; a draw node (or a
    node under one) that is hidden is dropped, a visible inner one whose rectangle meets a
    covered tile (or that is not testable) is replaced by its non-empty children, others are
    kept in out. Errs toward keeping; the result lies within the roots' subtrees.
    lo, hi : (N, 3) box corners;  parent : (N,) int64 (-1 at the root)
    draw_mark, up_mark : (N,) int64 scratch stamped with frame (draw nodes, their ancestors)
    out, stack : (>= N + len(roots),) int64 scratch;  below : same size, uint8 scratch
    nearest_far: a leaf whose nearest corner is not beyond this (the smallest covered depth
                 bound D plus margin D^2 + recede) is kept without its rectangle
    from_root  : enter through the ancestors (else start at the roots themselves)
    sw, sh, sample_move, tile_shift : with a screen (sw > 0) a box whose rectangle spans at
                 most 24 pixels (width + height) is tested over the pixels under its centres
                 only (hidden_triangles; larger ones: the test costs more than it removes)
    returns (kept count, nodes visited, nodes culled)"""
    cols = (width + tw - 1) // tw
    cam = np.empty((8, 3))
    r = np.empty(12)
    for k in range(len(roots)):
        draw_mark[roots[k]] = frame
    top = 0
    for k in range(len(roots)):
        p = parent[roots[k]]
        while p >= 0 and up_mark[p] != frame:
            up_mark[p] = frame
            p = parent[p]
        if parent[roots[k]] < 0 or not from_root:  # entered directly
            stack[top] = roots[k]
            below[top] = 1
            top += 1
    if from_root and len(roots) and up_mark[0] == frame:
        stack[top] = 0
        below[top] = 0
        top += 1
    count = visited = culled = 0
    while top > 0:
        top -= 1
        node, under = stack[top], below[top]
        if not under:
            if draw_mark[node] == frame:
                under = 1
            elif up_mark[node] != frame:
                continue  # outside every draw node's subtree
        if not nonempty[node]:
            continue
        visited += 1
        zmin = _box_to_camera(lo, hi, node, eye, rot, cam)
        n = child_count[node]
        # n == 0 above the draw nodes: an ancestor walked as a leaf (walk_child_counts), kept
        # whole like the fused walk keeps it (never dropped for having no children to enter)
        if n == 0 and zmin <= nearest_far:
            out[count] = node  # nearer than every covered pixel's bound: cannot be hidden
            count += 1
            continue
        if _box_hidden(cam, near, tx, ty, width, height, move, shift, sample_move, tile_shift,
                       sw, sh, depth, tile_max, cols, tw, th, margin, recede, r):
            culled += 1
            continue
        x0, x1, y0, y1 = int(r[0]), int(r[1]), int(r[2]), int(r[3])
        testable = r[5] > 0
        if n > 0 and (not under or not testable
                      or _touches(x0, x1, y0, y1, tile_any, cols, tw, th)):
            first = first_child[node]
            for c in range(n - 1, -1, -1):
                stack[top] = first + c
                below[top] = under
                top += 1
            continue
        out[count] = node
        count += 1
    return count, visited, culled


@njit(cache=True, nogil=True)
def frustum_cull_nodes(lo, hi, first_child, child_count, nonempty, roots, planes, tol, eye, rot,
                       near, tx, ty, width, height, move, shift, margin, recede, depth,
                       tile_max, tile_any, tile_shift, tw, th, out, stack_node, stack_mask,
                       nearest_far, sw, sh, sample_move, budget):
    """One walk from `roots` that rejects a node outside the frustum or hidden by the buffer, so
    neither kind of subtree is entered: the frustum test of kernels.frustum_walk (p/n-vertex
    with plane masks; errs toward keeping by tol: rejects only a box more than tol behind a
    plane) first, then cull_nodes' occlusion test (module docstring; errs toward keeping) on the
    boxes it leaves. A visible inner node is replaced by its non-empty children when it
    straddles a plane, is not testable or its rectangle meets a covered tile; others are kept
    in out. A leaf whose nearest corner is not beyond nearest_far is kept without a rectangle.
    Once more than `budget` nodes were visited, a visible node inside the frustum that would be
    expanded is kept instead (deferred: never dropped untested); cull_nodes from the kept nodes
    (from_root False) against the same buffer then keeps exactly the set an unbounded walk
    keeps (its tests are the same), or fewer nodes against a fuller buffer.
    planes : (P, 4) float64 inward (n, d), P <= 62;  stacks : (>= N + len(roots),) int64
    sw, sh, sample_move, tile_shift : the screen's centre test, as in cull_nodes
    budget : nodes visited before expansion stops (NO_BUDGET: never)
    returns (kept count, nodes visited, plane tests, outside the frustum, hidden, tested,
    deferred)"""
    cols = (width + tw - 1) // tw
    cam = np.empty((8, 3))
    r = np.empty(12)
    planes_count = planes.shape[0]
    full = (np.int64(1) << planes_count) - 1
    top = 0
    for k in range(len(roots) - 1, -1, -1):
        stack_node[top] = roots[k]
        stack_mask[top] = full
        top += 1
    count = visited = tests = outside_count = hidden = tested = deferred = 0
    while top > 0:
        top -= 1
        node, mask = stack_node[top], stack_mask[top]
        if not nonempty[node]:
            continue
        visited += 1
        outside, straddle, planes_tested = _box_planes(
            lo[node, 0], lo[node, 1], lo[node, 2], hi[node, 0], hi[node, 1], hi[node, 2],
            planes, mask, tol)
        tests += planes_tested
        if outside:
            outside_count += 1
            continue
        zmin = _box_to_camera(lo, hi, node, eye, rot, cam)
        n = child_count[node]
        if n == 0 and zmin <= nearest_far:
            out[count] = node  # nearer than every covered pixel's bound: cannot be hidden
            count += 1
            continue
        tested += 1
        if _box_hidden(cam, near, tx, ty, width, height, move, shift, sample_move, tile_shift,
                       sw, sh, depth, tile_max, cols, tw, th, margin, recede, r):
            hidden += 1
            continue
        x0, x1, y0, y1 = int(r[0]), int(r[1]), int(r[2]), int(r[3])
        testable = r[5] > 0
        if n > 0 and (straddle != 0 or not testable
                      or _touches(x0, x1, y0, y1, tile_any, cols, tw, th)):
            if visited > budget and straddle == 0 and testable:
                out[count] = node  # over budget: kept whole for the refinement after
                count += 1
                deferred += 1
                continue
            first = first_child[node]
            for c in range(n - 1, -1, -1):  # first child on top: depth-first in stored order
                stack_node[top] = first + c
                stack_mask[top] = straddle
                top += 1
            continue
        out[count] = node
        count += 1
    return count, visited, tests, outside_count, hidden, tested, deferred

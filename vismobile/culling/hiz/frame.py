"""The `occlusion` stage's usual frame in one compiled call (numba, cached on disk): occluder
candidates in shells around the eye, the best rasterised, the fused frustum and buffer walk
from the root, then the rounds that take occluders from what is still open. It calls the same
kernels in the same order as the stage's Python path (occlusion.DepthBufferOcclusion.apply with
an in-memory World, vfc deferred and no first_reach), so it decides exactly as that path; it
only saves the Python between them (issue 32: a dozen calls a frame, 0.3-0.6 ms on W2).
"""
from __future__ import annotations

import numpy as np
from numba import njit

from .tiles import build_tiles, tile_shifts
from .candidates import (facing_occluders, gather_candidates, gather_shell_candidates,
                         lod_ancestors, score_candidates)
from .raster import DEPTH_SLACK, SLACK_PX, rasterise, stamp_near
from .walks import NO_BUDGET, cull_nodes, frustum_cull_nodes

# The fused walk expands at most about this many nodes when later rounds follow; the rest is
# kept whole and refined by cull_nodes after them (walks.frustum_cull_nodes), against the
# fuller buffer of the later rounds, where more of it goes at a coarse level. Tiled W2, frames
# from 300 (docs/culling-performance.md, issue 32): 16,384 -> 1,024 took 0.92x the time at
# 923k (sent 1.341x -> 1.393x the visible set; MOC 1.54x) and 0.84x at 5.0M (1.373x -> 1.424x;
# MOC 1.59x); W2 (at most ~1,100 nodes a frame) sends the same. 16,384 was set for 5.0M's
# worst frames (59,633 nodes unbounded); 1,024 bounds them further.
WALK_BUDGET = 1024


# Slots of occlusion_frame's counters (occlusion.FRAME_COUNTERS names them).
(OCCLUDERS, PIXELS, CANDIDATES, CANDIDATE_NODES, VISITED, PLANE_TESTS, VFC_CULLED, VFC_ACCEPTED,
 NODES_TESTED, NODES_CULLED, FRAME_SLOTS) = range(11)


@njit(cache=True, nogil=True)
def top_scored(ids, score, count):
    """(<= count,) ids with the largest positive scores, best first; among equal scores the
    earlier id in `ids` first (a stable order). Only ranks occluders: never affects safety."""
    good = np.flatnonzero(score > 0)
    if len(good) > count:
        cut = -np.partition(-score[good], count - 1)[count - 1]  # the count-th largest
        keep = np.empty(count, dtype=np.int64)
        n = 0
        for k in range(len(good)):  # those above the cut, then ties at it in order
            if score[good[k]] > cut:
                keep[n] = good[k]
                n += 1
        for k in range(len(good)):
            if n < count and score[good[k]] == cut:
                keep[n] = good[k]
                n += 1
        good = np.sort(keep[:n])
    order = np.argsort(-score[good], kind="mergesort")
    return ids[good[order]]


@njit(cache=True, nogil=True, inline="always")
def occluder_shift(nearest, move, tx, ty):
    """occlusion.shift: the largest screen shift (x / z units) of a rasterised occluder point
    moved by `move` per coordinate, at depth >= nearest (0 when nothing was rasterised, inf when
    too near). The same arithmetic as the Python method."""
    if nearest == np.inf:
        return 0.0
    reach = np.sqrt(3.0) * move
    z = nearest - reach
    if not z > 0:
        return np.inf
    tangent = max(ty, tx) * nearest / z + reach / z
    return reach / z * (1.0 + tangent)


@njit(cache=True, nogil=True)
def sample_clip(clip, move, tx, ty, width, height, half):
    """The least depth >= clip (to 2^-40 relative, erring deeper) beyond which every occluder
    point's screen shift (occluder_shift) stays within half - SLACK_PX pixels of a width x
    height buffer: clipped there, the occluders a pixel bounds over its centre's `half`
    neighbourhood (occlusion `samples`) hold all the device may draw at that centre; inf when
    no depth is."""
    px = 0.5 * max(width / tx, height / ty)
    limit = half - SLACK_PX
    if occluder_shift(clip, move, tx, ty) * px <= limit:
        return clip
    low, high = clip, 2.0 * max(clip, 1e-300)
    while not occluder_shift(high, move, tx, ty) * px <= limit:
        if high == np.inf:
            return np.inf
        low, high = high, 2.0 * high
    for _ in range(64):  # the shift falls with depth: bisect, high always fitting
        mid = 0.5 * (low + high)
        if not low < mid < high or high - low <= 2.0 ** -40 * high:
            break
        if occluder_shift(mid, move, tx, ty) * px <= limit:
            high = mid
        else:
            low = mid
    return high


@njit(cache=True, nogil=True)
def _choose(cands, found, normals, v0, centroids, radius, areas, planes, eye, grazing, count,
            vertices, triangles, delta, gamma8):
    """The best `count` candidates by solid angle that certainly face the eye (occlusion.best,
    then occlusion.facing)."""
    ids = cands[:found]
    score = score_candidates(ids, normals, v0, centroids, radius, areas, planes, eye, grazing)
    chosen = top_scored(ids, score, count)
    keep = facing_occluders(chosen, vertices, triangles, chosen, normals, v0, centroids, eye,
                            delta, gamma8, grazing)
    return chosen[keep]


@njit(cache=True, nogil=True)
def _draw(chosen, groups, tri_points, points, normals, offsets, piece_start, piece_end, piece_a,
          piece_b, partner, partner_any, stamp, frame, eye, rot, clip, tx, ty, width, height,
          depth, mask, centre, crease_far, slack, half, local, move, tw, th, rows, cols,
          tile_near, tile_shift, tile_max, tile_any, tile_min):
    """occlusion.rasterise after the frame's first call: chosen into the buffer (sorted by plane
    group, stable), the per-tile shift table when `local`, the tiles. Returns (nearest,
    pixels written)."""
    order = chosen[np.argsort(groups[chosen], kind="mergesort")]
    nearest, written = rasterise(order, groups, tri_points, points, normals, offsets,
                                 piece_start, piece_end, piece_a, piece_b, partner, partner_any,
                                 stamp, frame, eye, rot, clip, tx, ty, width, height, depth, mask,
                                 centre, crease_far, slack, half)
    if local:
        stamp_near(order, tri_points, points, eye, rot, clip, tx, ty, width, height, tw, th,
                   tile_near)
        tile_shifts(tile_near, np.sqrt(3.0) * move, max(tx, ty), rows, cols, tile_shift)
    build_tiles(depth, width, height, tw, th, tile_max, tile_any, tile_min)
    return nearest, written


@njit(cache=True, nogil=True)
def _nearest_far(tile_min, margin, recede):
    d = tile_min.min() if len(tile_min) else np.inf
    return d + margin * d * d + recede


@njit(cache=True, nogil=True)
def occlusion_frame(lo, hi, first_child, child_count, nonempty, parent, tol, vertices, triangles,
                    normals, v0, centroids, radius, areas, groups, tri_points, points, offsets,
                    piece_start, piece_end, piece_a, piece_b, partner, partner_any, stamp, lists,
                    history, bits, cands, stack, later, out, masks, below, roots, up_mark,
                    draw_mark, planes, eye, rot, near, tx, ty, move, clip, order_slack, half,
                    margin, recede, delta, gamma8, grazing, detail, shell, limit, growth, count,
                    rounds, width, height, tw, th, depth, mask, centre, crease_far, tile_max,
                    tile_any, tile_min, tile_near, tile_shift, local_px, sw, sh, sample_move,
                    frame, stats):
    """One frame of the occlusion stage from the root (module docstring): the buffer and tiles
    are left as the Python path leaves them, stats (FRAME_SLOTS,) int64 gets its counters added.
    Returns (kept draw nodes in out, or -1 when the first round wrote no pixel (the caller walks
    the frustum alone), the frame stamp reached, nearest rasterised depth, the first round's
    last shell, every rasterised occluder id (K,) int64, out, stack, below: the scratch given,
    or larger ones when a round needed more (the caller keeps them), and whether the per-tile
    shift table is kept (1, 0; -1 when nothing was rasterised)).
    Contract: the kernels' (errs toward keeping), as called by occlusion.apply."""
    rows, cols = (height + th - 1) // th, (width + tw - 1) // tw
    slack = DEPTH_SLACK + order_slack
    none = np.zeros(0, dtype=np.int64)
    # Round 1: candidates from the root's frustum, nearest shells first.
    frame += 1
    n_roots = lod_ancestors(np.zeros(1, dtype=np.int64), parent, lo, hi, eye, detail, up_mark,
                            frame, roots)
    found, visited, reach = gather_shell_candidates(
        lo, hi, first_child, child_count, nonempty, roots[:n_roots].copy(), planes, tol, eye,
        detail, lists, history, none, bits, cands, stack, later, shell, limit, growth)
    stats[CANDIDATES] += found
    stats[CANDIDATE_NODES] += visited
    chosen = _choose(cands, found, normals, v0, centroids, radius, areas, planes, eye, grazing,
                     count, vertices, triangles, delta, gamma8)
    nearest, written, local = np.inf, 0, False
    if len(chosen):
        frame += 1
        order = chosen[np.argsort(groups[chosen], kind="mergesort")]
        nearest, written = rasterise(order, groups, tri_points, points, normals, offsets,
                                     piece_start, piece_end, piece_a, piece_b, partner,
                                     partner_any, stamp, frame, eye, rot, clip, tx, ty, width,
                                     height, depth, mask, centre, crease_far, slack, half)
        pixels = occluder_shift(nearest, move, tx, ty) * 0.5 * max(width / tx, height / ty)
        local = pixels > local_px
        if local:
            stamp_near(order, tri_points, points, eye, rot, clip, tx, ty, width, height, tw, th,
                       tile_near)
            tile_shifts(tile_near, np.sqrt(3.0) * move, max(tx, ty), rows, cols, tile_shift)
        build_tiles(depth, width, height, tw, th, tile_max, tile_any, tile_min)
    else:
        tile_max[:] = np.inf
        tile_min[:] = np.inf
        tile_any[:] = False
    stats[OCCLUDERS] += len(chosen)
    stats[PIXELS] += written
    if not written:
        return -1, frame, nearest, reach, chosen, out, stack, below, int(local) if len(chosen) else -1
    # The fused frustum and buffer walk from the root.
    budget = WALK_BUDGET if rounds > 1 else NO_BUDGET
    kept, visited, tests, outside, culled, tested, deferred = frustum_cull_nodes(
        lo, hi, first_child, child_count, nonempty, np.zeros(1, dtype=np.int64), planes, tol,
        eye, rot, near, tx, ty, width, height, move, occluder_shift(nearest, move, tx, ty),
        margin, recede, depth, tile_max, tile_any, tile_shift, tw, th, out, stack, masks,
        _nearest_far(tile_min, margin, recede), sw, sh, sample_move, budget)
    stats[VISITED] += visited
    stats[PLANE_TESTS] += tests
    stats[VFC_CULLED] += outside
    stats[VFC_ACCEPTED] += kept
    stats[NODES_TESTED] += tested
    stats[NODES_CULLED] += culled
    refined = deferred == 0  # else the deferred nodes are refined after the rounds at least
    for _ in range(rounds - 1 if not np.isfinite(tile_max).all() else 0):
        # Occluders seen through what is still open, then the nodes again.
        nodes = out[:kept].copy()
        need = kept + len(lo)  # the walks' scratch bound (the Python path grows it the same)
        if len(stack) < need:
            stack = np.empty(need, dtype=np.int64)
        frame += 1
        n_roots = lod_ancestors(nodes, parent, lo, hi, eye, detail, up_mark, frame, roots)
        found, visited = gather_candidates(lo, hi, first_child, child_count, nonempty,
                                           roots[:n_roots].copy(), planes, tol, eye, detail,
                                           lists, none, chosen, bits, cands, stack)
        stats[CANDIDATES] += found
        stats[CANDIDATE_NODES] += visited
        extra = _choose(cands, found, normals, v0, centroids, radius, areas, planes, eye,
                        grazing, count, vertices, triangles, delta, gamma8)
        if not len(extra):
            break
        chosen = np.concatenate((chosen, extra))
        stats[OCCLUDERS] += len(extra)
        frame += 1
        near_extra, more = _draw(extra, groups, tri_points, points, normals, offsets,
                                 piece_start, piece_end, piece_a, piece_b, partner, partner_any,
                                 stamp, frame, eye, rot, clip, tx, ty, width, height, depth, mask,
                                 centre, crease_far, slack, half, local, move, tw, th, rows,
                                 cols,
                                 tile_near, tile_shift, tile_max, tile_any, tile_min)
        nearest = min(nearest, near_extra)
        stats[PIXELS] += more
        if not more:
            break
        kept, out, stack, below = _cull_again(
            nodes, lo, hi, first_child, child_count, nonempty, parent, draw_mark, up_mark,
            frame + 1, eye, rot, near, tx, ty, width, height, move, nearest, margin, recede,
            depth, tile_max, tile_any, tile_min, tile_shift, tw, th, out, stack, below, sw, sh,
            sample_move, stats)
        frame += 1
        refined = True
    if not refined:
        kept, out, stack, below = _cull_again(
            out[:kept].copy(), lo, hi, first_child, child_count, nonempty, parent, draw_mark,
            up_mark, frame + 1, eye, rot, near, tx, ty, width, height, move, nearest, margin,
            recede, depth, tile_max, tile_any, tile_min, tile_shift, tw, th, out, stack, below,
            sw, sh, sample_move, stats)
        frame += 1
    return kept, frame, nearest, reach, chosen, out, stack, below, int(local)


@njit(cache=True, nogil=True)
def _cull_again(nodes, lo, hi, first_child, child_count, nonempty, parent, draw_mark, up_mark,
                frame, eye, rot, near, tx, ty, width, height, move, nearest, margin, recede,
                depth, tile_max, tile_any, tile_min, tile_shift, tw, th, out, stack, below, sw,
                sh, sample_move, stats):
    """occlusion._node_pass from the draw nodes themselves (hiz.cull_nodes, from_root False,
    stamped with frame) against the current buffer, the scratch grown as the Python path grows
    it; counters added to stats. Returns (kept count, out, stack, below)."""
    need = len(nodes) + len(lo)
    if len(stack) < need:
        stack = np.empty(need, dtype=np.int64)
    if len(below) < need:
        below = np.empty(need, dtype=np.uint8)
    if len(out) < need:  # out is written from here on: kept indexes the new one
        out = np.empty(need, dtype=np.int64)
    kept, visited, culled = cull_nodes(
        lo, hi, first_child, child_count, nonempty, parent, nodes, draw_mark, up_mark, frame,
        eye, rot, near, tx, ty, width, height, move, occluder_shift(nearest, move, tx, ty),
        margin, recede, depth, tile_max, tile_any, tile_shift, tw, th, out, stack, below,
        _nearest_far(tile_min, margin, recede), False, sw, sh, sample_move)
    stats[VISITED] += visited
    stats[NODES_TESTED] += visited
    stats[NODES_CULLED] += culled
    return kept, out, stack, below

"""A whole `vfc,occlusion,tbfc` frame in one compiled call (chained_frame): occlusion's
compiled frame (hiz.frame.occlusion_frame: candidates, rasterise, the fused frustum and buffer
walk, further rounds), then the distinct gather of the draw nodes, tbfc's back-face test,
occlusion's triangle test and the ranking of the sent triangles as next frame's candidates
(occlusion.observe). The same kernels in the same order as Culler.cull with those stages
(CullState.finish with tbfc's and occlusion's filters, then observe), so it sends exactly the
same triangles with the same counters; it only saves the Python between them (issue 32: about
a quarter of a W2 frame played after a render was that Python).

The Culler takes this path (Culler._chain, cull_chained) only when vfc, occlusion and tbfc (and
bfc, a render flag) are its only stages on a static partition: any other filter would have to
run between. A frame the compiled frame does not cover (the device cannot order depths; no
occluder pixel written) goes the stages' way.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from .facing import not_backfacing
from .gather import count_marked, extract_marked, mark_nodes
from .hiz.buffer import hidden_triangles
from .hiz.candidates import score_candidates
from .hiz.frame import FRAME_SLOTS, occlusion_frame, occluder_shift, top_scored
from .kernels import run_count
from .state import CullResult

# Slots of chain_finish's counts.
GATHERED, FRONT, SUBPIXEL, HIDDEN, RUNS, CHAIN_SLOTS = range(6)


@njit(cache=True, nogil=True)
def chain_finish(nodes, words, masks, span, bits, summary, tops, ranges, vertices, triangles,
                 eye, tbfc_delta, gamma8, rot, near, tx, ty, width, height, move, shift, margin,
                 recede, depth, tile_max, tile_shift, tw, th, sw, sh, sample_move, normals, v0,
                 centroids, radius, areas, planes, grazing, occluders, counts):
    """(sent ids (S,) int64 sorted, next frame's history (<= occluders,) int64) for the draw
    nodes (D,) int64: their distinct triangle ids (gather: mark_nodes, count_marked,
    extract_marked, bitmap left cleared), those tbfc keeps (facing.not_backfacing with
    tbfc_delta), those occlusion's buffer test keeps (hiz.hidden_triangles with the buffer;
    neither hidden nor, with a screen, covering no pixel centre), and the best `occluders` of
    them by estimated solid angle (occlusion.observe). counts (CHAIN_SLOTS,) int64 gets the
    gathered, front-facing, sub-pixel, hidden counts and the draw batches.
    Contract: the kernels' (each errs toward keeping), as CullState.finish calls them."""
    ntops = mark_nodes(words, masks, span, nodes, bits, summary, tops, ranges)
    size = count_marked(bits, summary, tops, ntops)
    ids = np.empty(size, dtype=np.int64)
    extract_marked(bits, summary, tops, ntops, ids)
    # tbfc in place: the k-th id is read before any write at an index <= k.
    front = not_backfacing(ids, vertices, triangles, eye, tbfc_delta, gamma8, ids)
    hidden = np.empty(front, dtype=np.bool_)
    subpixel = np.empty(front, dtype=np.bool_)
    zmin = np.empty(front)
    hidden_triangles(ids[:front], vertices, triangles, eye, rot, near, tx, ty, width, height,
                     move, shift, margin, recede, depth, tile_max, tile_shift, tw, th, True, sw,
                     sh, sample_move, hidden, subpixel, zmin)
    sent = 0
    for k in range(front):
        counts[SUBPIXEL] += subpixel[k]
        counts[HIDDEN] += hidden[k]
        if not (hidden[k] or subpixel[k]):
            ids[sent] = ids[k]
            sent += 1
    out = ids[:sent]
    counts[GATHERED] += size
    counts[FRONT] += front
    counts[RUNS] += run_count(out)
    if sent == 0:
        return out, np.zeros(0, dtype=np.int64)
    score = score_candidates(out, normals, v0, centroids, radius, areas, planes, eye, grazing)
    return out, top_scored(out, score, occluders)


@njit(cache=True, nogil=True)
def chained_frame(lo, hi, first_child, child_count, nonempty, parent, tol, vertices, triangles,
                  normals, v0, centroids, radius, areas, groups, tri_points, points, offsets,
                  piece_start, piece_end, piece_a, piece_b, partner, partner_any, stamp, lists,
                  history, bits, cands, stack, later, out, masks, below, roots, up_mark,
                  draw_mark, planes, eye, rot, near, tx, ty, move, clip, order_slack, half, margin,
                  recede, delta, gamma8, grazing, detail, shell, limit, growth, count, rounds,
                  width, height, tw, th, depth, mask, centre, crease_far, tile_max, tile_any,
                  tile_min, tile_near, tile_shift, local_px, sw, sh, sample_move, frame, stats,
                  clear_shift, g_words, g_masks, g_span, g_bits, g_summary, g_tops, g_ranges,
                  tbfc_delta, counts):
    """occlusion.apply's start (buffer cleared, the shift table too when clear_shift), its
    compiled frame (occlusion_frame, the same arguments up to stats) and, when that kept draw
    nodes, chain_finish over them (g_*: the tree's gather pairs and bitmap, tbfc_delta, counts).
    Returns occlusion_frame's tuple, then the sent ids and next frame's history (empty when
    the frame kept none: kept -1) and g_ranges (a larger one when the nodes needed more)."""
    depth[:] = np.inf
    if clear_shift:
        tile_near[:] = np.inf
        tile_shift[:] = np.inf
    (kept, frame, nearest, reach, chosen, out, stack, below, local) = occlusion_frame(
        lo, hi, first_child, child_count, nonempty, parent, tol, vertices, triangles, normals,
        v0, centroids, radius, areas, groups, tri_points, points, offsets, piece_start,
        piece_end, piece_a, piece_b, partner, partner_any, stamp, lists, history, bits, cands,
        stack, later, out, masks, below, roots, up_mark, draw_mark, planes, eye, rot, near, tx,
        ty, move, clip, order_slack, half, margin, recede, delta, gamma8, grazing, detail, shell,
        limit, growth, count, rounds, width, height, tw, th, depth, mask, centre, crease_far,
        tile_max, tile_any, tile_min, tile_near, tile_shift, local_px, sw, sh, sample_move,
        frame, stats)
    none = np.zeros(0, dtype=np.int64)
    if kept < 0:
        return kept, frame, nearest, reach, chosen, out, stack, below, local, none, none, g_ranges
    if len(g_ranges) < kept:
        g_ranges = np.empty((kept, 2), dtype=np.int64)
    sent, ranked = chain_finish(
        out[:kept], g_words, g_masks, g_span, g_bits, g_summary, g_tops, g_ranges, vertices,
        triangles, eye, tbfc_delta, gamma8, rot, near, tx, ty, width, height, move,
        occluder_shift(nearest, move, tx, ty), margin, recede, depth, tile_max, tile_shift, tw,
        th, sw, sh, sample_move, normals, v0, centroids, radius, areas, planes, grazing, count,
        counts)
    return kept, frame, nearest, reach, chosen, out, stack, below, local, sent, ranked, g_ranges


def cull_chained(stage, tbfc, camera, planes, cull_back: bool):
    """The frame of a Culler whose stages are vfc, occlusion (`stage`) and tbfc (bfc may join:
    cull_back) in one compiled call: a CullResult with the same triangles, draw nodes and
    counters as Culler.cull's stage by stage, with stage's state (buffer, history, occluders)
    left as its apply and observe leave it; None when this frame is not the compiled frame's
    (stage.compiled off, options it does not run, the device cannot order depths, no occluder
    pixel written): the caller then culls stage by stage (apply starts afresh)."""
    if not (stage.compiled and stage.tables and stage.first_reach is None
            and stage.first_candidates > 0 and stage.triangles and not stage.self_occluders):
        return None
    eye, *_, order = stage._view(camera)
    if not order < np.inf:
        return None
    tree = stage.tree
    stage._camera, stage._planes = camera, np.ascontiguousarray(planes, dtype=np.float64)
    arguments = stage._frame_arguments(camera)[0]
    stats = np.zeros(FRAME_SLOTS, dtype=np.int64)
    counts = np.zeros(CHAIN_SLOTS, dtype=np.int64)
    groups, bitmap = tree.groups, tree._bitmap
    (kept, stage._frame, stage.nearest, stage.reach, chosen, stage._out, stage._stack,
     stage._below, local, sent, history, bitmap.ranges) = chained_frame(
        *arguments, stats, stage._shift_written, groups.words, groups.masks, groups.span,
        bitmap.bits, bitmap.summary, bitmap.tops, bitmap.ranges,
        tbfc.delta(np.asarray(eye, dtype=np.float64)), counts)
    stage._shift_written = local == 1
    stage._local = None if local < 0 else bool(local)
    stage.frame_occluders = chosen
    if kept < 0:  # nothing occludes: the stages' way (the frustum walk alone)
        return None
    stage.history = history
    nodes = stage._out[:kept].copy()
    (occluders, pixels, candidates, candidate_nodes, visited, tests, outside, accepted, tested,
     culled) = stats.tolist()
    gathered, front, subpixel, hidden, runs = counts.tolist()[:CHAIN_SLOTS]
    name = stage.name
    result = {"nodes_visited": visited, "plane_tests": tests,
              "triangles_tested": gathered + front, f"{name}.occluders": occluders,
              f"{name}.pixels_covered": pixels, f"{name}.candidates": candidates,
              f"{name}.candidate_nodes": candidate_nodes, "vfc.nodes_culled": outside,
              "vfc.nodes_accepted": accepted, f"{name}.nodes_tested": tested,
              f"{name}.nodes_culled": culled, tbfc._tested_key: gathered,
              tbfc._culled_key: gathered - front, f"{name}.triangles_tested": front,
              f"{name}.subpixel_culled": subpixel, f"{name}.triangles_culled": hidden,
              "triangles_sent": len(sent), "draw_batches": runs, "nodes_drawn": kept}
    if cull_back:
        result["bfc.render_flag"] = 1
    return CullResult(sent, nodes, result, cull_back)

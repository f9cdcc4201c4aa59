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
from numba import njit, types
from numba.experimental import structref

from .facing import not_backfacing
from .gather import count_marked, extract_marked, mark_nodes
from .hiz import GUARD_PX
from .hiz.buffer import hidden_triangles
from .hiz.candidates import score_candidates
from .hiz.frame import FRAME_SLOTS, occlusion_frame, occluder_shift, top_scored
from .kernels import run_count
from .occluder_choice import GRAZING, SHELL_GROWTH
from .occlusion import LOCAL_SHIFT_PX, ZBUFFER_MARGIN
from .precision import device_move
from .state import CullResult
from .triangle_backface import DEVICE_ABSOLUTE, DEVICE_RELATIVE, GAMMA_8

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


@structref.register
class ChainTablesType(types.StructRef):
    """numba's type of ChainTables (fields typed as given, literals widened)."""

    def preprocess_fields(self, fields):
        return tuple((name, types.unliteral(kind)) for name, kind in fields)


class ChainTables(structref.StructRefProxy):
    """What chained_frame reads that stays the same from frame to frame (TABLE_FIELDS: the
    tree, the world's occluder tables, the buffer, tiles and scratch of the occlusion stage,
    the gather's pairs and bitmap, the stages' constants) in one numba structref: the call
    unboxes one pointer instead of some seventy arrays (numba's dispatch cost grows with the
    argument count: 3 us against 16 us warm for 60 arrays, more after a render)."""


TABLE_FIELDS = (
    "lo", "hi", "first_child", "child_count", "nonempty", "parent", "tol", "vertices",
    "triangles", "normals", "v0", "centroids", "radius", "areas", "groups", "tri_points",
    "points", "offsets", "piece_start", "piece_end", "piece_a", "piece_b", "partner",
    "partner_any", "stamp", "lists", "bits", "cands", "later", "masks", "roots", "up_mark",
    "draw_mark", "half", "gamma8", "grazing", "detail", "shell", "limit", "growth", "count",
    "rounds", "width", "height", "tw", "th", "depth", "mask", "centre", "crease_far",
    "tile_max", "tile_any", "tile_min", "tile_near", "tile_shift", "local_px", "sw", "sh",
    "g_words", "g_masks", "g_span", "g_bits", "g_summary", "g_tops", "zbuffer_margin",
    "magnitude", "device_relative", "device_absolute", "tbfc_relative", "tbfc_magnitude",
    "tbfc_absolute")
structref.define_constructor(ChainTables, ChainTablesType, TABLE_FIELDS)
structref.define_boxing(ChainTablesType, ChainTables)


@njit(cache=True)
def _pack(fields):
    return ChainTables(*fields)


def chain_tables(stage, tbfc) -> ChainTables:
    """The stage's ChainTables, built once per preparation and kept on the stage under a key
    of what may replace them: prepare (a new buffer), a stage-by-stage frame growing its
    scratch, the options. The tables hold the arrays, so the ids in the key stay theirs."""
    key = (id(stage.depth), id(stage._cands), id(stage._later), id(stage._masks),
           stage.screen, stage.rounds, stage.occluders, stage.detail, stage.first_candidates,
           tbfc.magnitude, tbfc.relative, tbfc.absolute, tbfc.arithmetic)
    held = getattr(stage, "_chain_tables", None)
    if held is not None and held[0] == key:
        return held[1]
    tree = stage.tree
    groups, bitmap = tree.groups, tree._bitmap
    absolute = device_move(tbfc.arithmetic, 0.0) if tbfc.absolute is None else tbfc.absolute
    tables = _pack((
        tree.lo, tree.hi, tree.first_child, tree.child_count, tree.nonempty, stage.parent,
        float(tree.tol), stage.vertices, stage.triangles_, stage.normals, stage.v0,
        stage.centroids, stage.radius, stage.areas, stage.groups, stage.tri_points,
        stage.points, stage.offsets, stage.piece_start, stage.piece_end, stage.piece_a,
        stage.piece_b, stage.partner, stage.partner_any, stage.stamp, stage.lists, stage.bits,
        stage._cands, stage._later, stage._masks, stage._roots, stage.up_mark,
        stage.draw_mark, float(stage.half), GAMMA_8, GRAZING, stage.detail, stage.shell,
        stage.first_candidates, float(SHELL_GROWTH), stage.occluders, stage.rounds,
        stage.width, stage.height, *stage.tile, stage.depth, stage.mask, stage.centre,
        stage.crease_far, stage.tile_max, stage.tile_any, stage.tile_min, stage.tile_near,
        stage.tile_shift, GUARD_PX if stage.screen is None else LOCAL_SHIFT_PX,
        *((0, 0) if stage.screen is None else stage.screen), groups.words, groups.masks,
        groups.span, bitmap.bits, bitmap.summary, bitmap.tops, ZBUFFER_MARGIN,
        float(stage.magnitude), DEVICE_RELATIVE, DEVICE_ABSOLUTE, tbfc.relative,
        float(tbfc.magnitude), float(absolute)))
    stage._chain_tables = (key, tables)
    return tables


@njit(cache=True, nogil=True)
def chained_frame(t, history, stack, out, below, g_ranges, planes, eye, rot, near, tx, ty,
                  move, clip, order_slack, scale, frame, clear_shift):
    """occlusion.apply's start (buffer cleared, the shift table too when clear_shift), its
    compiled frame (occlusion_frame over the tables t, history and the scratch stack, out,
    below, with the camera's view: eye (3,), rot (3, 3), near, tx, ty, move, clip, the depth
    order slack and the scale of the stage's _view) and, when that kept draw nodes,
    chain_finish over them (g_ranges: the bitmap's node ranges). margin, recede, the triangle
    tests' move and tbfc's delta are computed here with the Python path's arithmetic
    (occlusion._frame_arguments, samples, TriangleBackface.delta: the same bits).
    Returns occlusion_frame's tuple, then the sent ids and next frame's history (empty when
    the frame kept none: kept -1), g_ranges (a larger one when the nodes needed more), and
    the counters: FRAME_SLOTS (stats) and CHAIN_SLOTS (counts) int64."""
    margin = t.zbuffer_margin / near
    recede = np.sqrt(3.0) * move
    eye_abs = max(abs(eye[0]), abs(eye[1]), abs(eye[2]))
    delta = t.device_relative * max(t.magnitude, eye_abs) + t.device_absolute
    sample_move = move
    if t.sw > 0:
        sample_move = max(t.device_relative * scale + t.device_absolute, move)
    tbfc_delta = t.tbfc_relative * max(t.tbfc_magnitude, eye_abs) + t.tbfc_absolute
    stats = np.zeros(FRAME_SLOTS, dtype=np.int64)
    counts = np.zeros(CHAIN_SLOTS, dtype=np.int64)
    depth = t.depth
    depth[:] = np.inf
    if clear_shift:
        t.tile_near[:] = np.inf
        t.tile_shift[:] = np.inf
    (kept, frame, nearest, reach, chosen, out, stack, below, local) = occlusion_frame(
        t.lo, t.hi, t.first_child, t.child_count, t.nonempty, t.parent, t.tol, t.vertices,
        t.triangles, t.normals, t.v0, t.centroids, t.radius, t.areas, t.groups, t.tri_points,
        t.points, t.offsets, t.piece_start, t.piece_end, t.piece_a, t.piece_b, t.partner,
        t.partner_any, t.stamp, t.lists, history, t.bits, t.cands, stack, t.later, out,
        t.masks, below, t.roots, t.up_mark, t.draw_mark, planes, eye, rot, near, tx, ty, move,
        clip, order_slack, t.half, margin, recede, delta, t.gamma8, t.grazing, t.detail,
        t.shell, t.limit, t.growth, t.count, t.rounds, t.width, t.height, t.tw, t.th, depth,
        t.mask, t.centre, t.crease_far, t.tile_max, t.tile_any, t.tile_min, t.tile_near,
        t.tile_shift, t.local_px, t.sw, t.sh, sample_move, frame, stats)
    none = np.zeros(0, dtype=np.int64)
    if kept < 0:
        return (kept, frame, nearest, reach, chosen, out, stack, below, local, none, none,
                g_ranges, stats, counts)
    if len(g_ranges) < kept:
        g_ranges = np.empty((kept, 2), dtype=np.int64)
    sent, ranked = chain_finish(
        out[:kept], t.g_words, t.g_masks, t.g_span, t.g_bits, t.g_summary, t.g_tops, g_ranges,
        t.vertices, t.triangles, eye, tbfc_delta, t.gamma8, rot, near, tx, ty, t.width,
        t.height, move, occluder_shift(nearest, move, tx, ty), margin, recede, depth,
        t.tile_max, t.tile_shift, t.tw, t.th, t.sw, t.sh, sample_move, t.normals, t.v0,
        t.centroids, t.radius, t.areas, planes, t.grazing, t.count, counts)
    return (kept, frame, nearest, reach, chosen, out, stack, below, local, sent, ranked,
            g_ranges, stats, counts)


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
    eye, rotation, tx, ty, move, clip, scale, order = stage._view(camera)
    if not order < np.inf:
        return None
    stage._camera = camera
    stage._planes = np.ascontiguousarray(planes, dtype=np.float64)
    bitmap = stage.tree._bitmap
    (kept, stage._frame, stage.nearest, stage.reach, chosen, stage._out, stage._stack,
     stage._below, local, sent, history, bitmap.ranges, stats, counts) = chained_frame(
        chain_tables(stage, tbfc), stage.history, stage._stack, stage._out, stage._below,
        bitmap.ranges, stage._planes, eye, rotation, camera.near, tx, ty, move, clip, order, scale,
        stage._frame, stage._shift_written)
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

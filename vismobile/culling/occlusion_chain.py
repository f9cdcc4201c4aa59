"""A whole `vfc,occlusion,tbfc` frame in one compiled call (chained_frame): occlusion's
compiled frame (hiz.frame.occlusion_frame: candidates, rasterise, the fused frustum and buffer
walk, further rounds), then the distinct gather of the draw nodes, tbfc's back-face test,
occlusion's triangle test and the ranking of the sent triangles as next frame's candidates
(occlusion.observe). The same kernels in the same order as Culler.cull with those stages
(CullState.finish with tbfc's and occlusion's filters, then observe), so it sends exactly the
same triangles with the same counters; it only saves the Python between them (issue 32: about
a quarter of a W2 frame played after a render was that Python). The frustum planes and the
stage's view are computed in the call too (view_planes, chain_view: the Python path's bits),
and what stays the same from frame to frame goes in as one structref (ChainTables), so the
Python left around the call is a few lookups and the result's dict.

The Culler takes this path (Culler._chain, cull_chained) only when vfc, occlusion and tbfc (and
bfc, a render flag) are its only stages on a static partition: any other filter would have to
run between. A frame the compiled frame does not cover (the device cannot order depths; no
occluder pixel written) goes the stages' way.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit, types
from numba.experimental import structref

from .facing import not_backfacing
from .gather import count_marked, extract_marked, mark_nodes
from .hiz import GUARD_PX
from .hiz.buffer import hidden_triangles
from .hiz.candidates import score_candidates
from .hiz.frame import (CANDIDATE_NODES, CANDIDATES, FRAME_SLOTS, NODES_CULLED, NODES_TESTED,
                        OCCLUDERS, PIXELS, PLANE_TESTS, VFC_ACCEPTED, VFC_CULLED, VISITED,
                        occlusion_frame, occluder_shift, sample_clip, top_scored)
from .kernels import run_count
from .prefetch import prefetch
from .occluder_choice import GRAZING, SHELL_GROWTH
from ..world.view_planes import view_planes
from .backface import half_tangents
from .occlusion import LOCAL_SHIFT_PX, NEAR_RELATIVE, ZBUFFER_MARGIN
from .precision import culling_planes, culling_push, device_move
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


@njit(cache=True, nogil=True)
def chain_counters(stats, counts, sent, kept):
    """(19,) int64: the frame's counters in chain_tables' names' order, from occlusion_frame's
    stats, chain_finish's counts, the sent count and the draw nodes kept."""
    gathered, front = counts[GATHERED], counts[FRONT]
    values = np.empty(19, dtype=np.int64)
    values[0], values[1], values[2] = stats[VISITED], stats[PLANE_TESTS], gathered + front
    values[3], values[4], values[5] = stats[OCCLUDERS], stats[PIXELS], stats[CANDIDATES]
    values[6], values[7] = stats[CANDIDATE_NODES], stats[VFC_CULLED]
    values[8] = stats[VFC_ACCEPTED]
    values[9], values[10], values[11] = stats[NODES_TESTED], stats[NODES_CULLED], gathered
    values[12], values[13], values[14] = gathered - front, front, counts[SUBPIXEL]
    values[15], values[16], values[17] = counts[HIDDEN], sent, counts[RUNS]
    values[18] = kept
    return values


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
    "tbfc_absolute", "move_absolute", "near_relative")
structref.define_constructor(ChainTables, ChainTablesType, TABLE_FIELDS)
structref.define_boxing(ChainTablesType, ChainTables)


@njit(cache=True)
def _pack(fields):
    return ChainTables(*fields)


def chain_tables(stage, tbfc) -> tuple:
    """(ChainTables, the result's counter names in chain_counters' order) of the stage, built
    once per preparation and kept on the stage under a key of what may replace them: prepare
    (a new buffer), a stage-by-stage frame growing its scratch, the options. The tables hold
    the arrays, so the ids in the key stay theirs."""
    key = (id(stage.depth), id(stage._cands), id(stage._later), id(stage._masks),
           stage.screen, stage.rounds, stage.occluders, stage.detail, stage.first_candidates,
           tbfc.magnitude, tbfc.relative, tbfc.absolute, tbfc.arithmetic, stage.arithmetic,
           stage.name)
    held = getattr(stage, "_chain_tables", None)
    if held is not None and held[0] == key:
        return held[1:]
    tree = stage.tree
    groups, bitmap = tree.groups, tree._bitmap
    absolute = device_move(tbfc.arithmetic, 0.0) if tbfc.absolute is None else tbfc.absolute
    tables = _pack((
        tree.lo, tree.hi, tree.first_child, stage.walk_children, tree.nonempty, stage.parent,
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
        float(tbfc.magnitude), float(absolute), device_move(stage.arithmetic, 0.0),
        NEAR_RELATIVE))
    name = stage.name
    names = ("nodes_visited", "plane_tests", "triangles_tested", f"{name}.occluders",
             f"{name}.pixels_covered", f"{name}.candidates", f"{name}.candidate_nodes",
             "vfc.nodes_culled", "vfc.nodes_accepted", f"{name}.nodes_tested",
             f"{name}.nodes_culled", tbfc._tested_key, tbfc._culled_key,
             f"{name}.triangles_tested", f"{name}.subpixel_culled",
             f"{name}.triangles_culled", "triangles_sent", "draw_batches", "nodes_drawn")
    stage._chain_tables = (key, tables, names)
    return tables, names


@njit(cache=True, nogil=True)
def chain_view(t, x, y, z, yaw, pitch, near, tx, ty):
    """occlusion._view's (eye (3,), rotation (3, 3) rows right, up, forward, move, clip,
    scale, depth order slack) for the camera at (x, y, z), yaw and pitch in degrees, with the
    same arithmetic (Camera.axes, precision.device_move and depth_order, the near clip and
    sample_clip): the same bits. The order slack is inf when the device cannot order depths."""
    yaw, pitch = math.radians(yaw), math.radians(pitch)
    cy, sy, cp, sp = math.cos(yaw), math.sin(yaw), math.cos(pitch), math.sin(pitch)
    rot = np.empty((3, 3))
    rot[2, 0], rot[2, 1], rot[2, 2] = -sy * cp, sp, -cy * cp
    rot[0, 0], rot[0, 1], rot[0, 2] = cy, 0.0, -sy
    rot[1, 0] = rot[0, 1] * rot[2, 2] - rot[0, 2] * rot[2, 1]
    rot[1, 1] = rot[0, 2] * rot[2, 0] - rot[0, 0] * rot[2, 2]
    rot[1, 2] = rot[0, 0] * rot[2, 1] - rot[0, 1] * rot[2, 0]
    eye = np.empty(3)
    eye[0], eye[1], eye[2] = x, y, z
    scale = max(t.magnitude, abs(x), abs(y), abs(z))
    move = 2.0 * (t.device_relative * scale + t.move_absolute)
    clip = near * (1.0 + t.near_relative) + max(t.device_relative * scale, 2.0 * move)
    if t.half < 0.5:
        clip = sample_clip(clip, move, tx, ty, t.width, t.height, t.half)
    order = np.inf
    if move < 2.0 * near:
        order = 2.0 * move / (2.0 * near - move)
    return eye, rot, move, clip, scale, order


@njit(cache=True, nogil=True)
def warm_caches(t, nodes, ids, occluders):
    """Hints (culling/prefetch.py: no effect on any value) for what the frame is likely to read
    cold after a render: the tree records of last frame's draw nodes `nodes`, their neighbours
    and three levels of ancestors (the fused walk's), and the rows of last frame's sent
    triangles `ids` (the triangle test's), asked for before the rasteriser's work so their
    misses overlap it; and the occluder-table rows of the first round's history `occluders`
    (the candidates the choice scores first and the rasteriser draws: their plane, group,
    pieces, stamp, corners' indices and scores' inputs), asked for before the shells' walk.
    Only hints: ids out of range (a caller may have changed its result) are skipped, and a
    prefetch never faults. (Also reading those rows to prefetch their corners measured no
    gain: the reads are demand misses.)"""
    count = len(t.lo)
    for k in range(len(nodes)):
        node = nodes[k]
        for _ in range(4):
            if not 0 <= node < count:
                break
            for near in (node - 2, node, node + 2):
                at = max(near, 0)
                prefetch(t.lo, at)
                prefetch(t.hi, at)
            prefetch(t.nonempty, node)
            prefetch(t.child_count, node)
            prefetch(t.first_child, node)
            node = t.parent[node]
    for k in range(len(ids)):
        prefetch(t.triangles, ids[k])
    rows = len(t.groups)
    for k in range(len(occluders)):
        h = occluders[k]
        if not 0 <= h < rows:
            continue
        prefetch(t.tri_points, h)
        prefetch(t.groups, h)
        prefetch(t.normals, h)
        prefetch(t.offsets, h)
        prefetch(t.piece_start, h)
        prefetch(t.stamp, h)
        prefetch(t.centroids, h)
        prefetch(t.v0, h)
        prefetch(t.radius, h)
        prefetch(t.areas, h)


@njit(cache=True, nogil=True)
def chained_frame(t, history, stack, out, below, g_ranges, given, x, y, z, yaw, pitch, near,
                  far, half_angles, tx, ty, plane_margin, plane_limit, frame, clear_shift,
                  warm_nodes, warm_ids):
    """The frame's planes (given (6, 4), or with none given (0, 4) the camera's pushed out by
    plane_margin and limited to plane_limit: view_planes, as precision.culling_planes; the
    camera at (x, y, z), yaw, pitch, near, far, half_angles (4,) Camera's (ch, sh, cv, sv)),
    its view (chain_view, tx and ty the half tangents, as occlusion._view), then
    occlusion.apply's start (buffer cleared, the shift table too when clear_shift), its
    compiled frame (occlusion_frame over the tables t, history and the scratch stack, out,
    below) and, when that kept draw nodes, chain_finish over them (g_ranges: the bitmap's
    node ranges). margin, recede, the triangle tests' move and tbfc's delta are computed
    here with the Python path's arithmetic (occlusion._frame_arguments, samples,
    TriangleBackface.delta: the same bits).
    Returns occlusion_frame's tuple, then the sent ids and next frame's history (empty when
    the frame kept none: kept -1), g_ranges (a larger one when the nodes needed more), the
    counters (chain_counters; kept < 0: occlusion_frame's FRAME_SLOTS), the planes and a
    copy of the draw nodes. kept is -2 when the device cannot order depths (nothing run but
    the planes and the view): the caller culls stage by stage."""
    warm_caches(t, warm_nodes, warm_ids, history)
    planes = given
    if len(given) == 0:
        ch, sh, cv, sv = half_angles[0], half_angles[1], half_angles[2], half_angles[3]
        planes = view_planes(x, y, z, yaw, pitch, ch, sh, cv, sv, near, far, plane_margin,
                             plane_limit)
    eye, rot, move, clip, scale, order_slack = chain_view(t, x, y, z, yaw, pitch, near, tx, ty)
    none = np.zeros(0, dtype=np.int64)
    stats = np.zeros(FRAME_SLOTS, dtype=np.int64)
    counts = np.zeros(CHAIN_SLOTS, dtype=np.int64)
    if not order_slack < np.inf:
        return (-2, frame, np.inf, np.inf, none, out, stack, below, -1, none, none, g_ranges,
                stats, planes, none)
    margin = t.zbuffer_margin / near
    recede = np.sqrt(3.0) * move
    eye_abs = max(abs(eye[0]), abs(eye[1]), abs(eye[2]))
    delta = t.device_relative * max(t.magnitude, eye_abs) + t.device_absolute
    sample_move = move
    if t.sw > 0:
        sample_move = max(t.device_relative * scale + t.device_absolute, move)
    tbfc_delta = t.tbfc_relative * max(t.tbfc_magnitude, eye_abs) + t.tbfc_absolute
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
    if kept < 0:
        return (kept, frame, nearest, reach, chosen, out, stack, below, local, none, none,
                g_ranges, stats, planes, none)
    if len(g_ranges) < kept:
        g_ranges = np.empty((kept, 2), dtype=np.int64)
    sent, ranked = chain_finish(
        out[:kept], t.g_words, t.g_masks, t.g_span, t.g_bits, t.g_summary, t.g_tops, g_ranges,
        t.vertices, t.triangles, eye, tbfc_delta, t.gamma8, rot, near, tx, ty, t.width,
        t.height, move, occluder_shift(nearest, move, tx, ty), margin, recede, depth,
        t.tile_max, t.tile_shift, t.tw, t.th, t.sw, t.sh, sample_move, t.normals, t.v0,
        t.centroids, t.radius, t.areas, planes, t.grazing, t.count, counts)
    return (kept, frame, nearest, reach, chosen, out, stack, below, local, sent, ranked,
            g_ranges, chain_counters(stats, counts, len(sent), kept), planes,
            out[:kept].copy())


EMPTY_PLANES = np.zeros((0, 4))


def cull_chained(stage, tbfc, camera, arithmetic: str, scale: float, cull_back: bool) -> tuple:
    """(result, planes) of the frame of a Culler whose stages are vfc, occlusion (`stage`) and
    tbfc (bfc may join: cull_back) in one compiled call, planes the frame's frustum planes
    (precision.culling_planes for the Culler's arithmetic and scale, computed in the call).
    result is a CullResult with the same triangles, draw nodes and counters as Culler.cull's
    stage by stage, with stage's state (buffer, history, occluders) left as its apply and
    observe leave it; None when this frame is not the compiled frame's (stage.compiled off,
    options it does not run, the device cannot order depths, no occluder pixel written):
    the caller then culls stage by stage with the planes (apply starts afresh)."""
    if not (stage.compiled and stage.tables and stage.first_reach is None
            and stage.first_candidates > 0 and stage.triangles and not stage.self_occluders):
        return None, culling_planes(camera, arithmetic, scale)
    given, push, limit = culling_push(camera, arithmetic, scale)
    tx, ty = half_tangents(camera.fov, camera.aspect)
    (x, y, z), bitmap = camera.position, stage.tree._bitmap
    tables, names = chain_tables(stage, tbfc)
    if not hasattr(stage, "_warm"):  # last frame's draw nodes and sent ids: warm_caches
        stage._warm = (np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64))
    (kept, frame, nearest, reach, chosen, out, stack, below, local, sent, history, ranges,
     counters, planes, nodes) = chained_frame(
        tables, stage.history, stage._stack, stage._out, stage._below, bitmap.ranges,
        EMPTY_PLANES if given is None else given, x, y, z, float(camera.yaw),
        float(camera.pitch), float(camera.near), float(camera.far), camera.half_angles(), tx,
        ty, push, limit, stage._frame, stage._shift_written, stage._warm[0], stage._warm[1])
    if kept == -2:  # the device cannot order depths: the stages' way (_unordered)
        return None, planes
    stage._camera, stage._planes = camera, planes
    (stage._frame, stage.nearest, stage.reach, stage._out, stage._stack, stage._below,
     bitmap.ranges) = frame, nearest, reach, out, stack, below, ranges
    stage._shift_written = local == 1
    stage._local = None if local < 0 else bool(local)
    stage.frame_occluders = chosen
    if kept < 0:  # nothing occludes: the stages' way (the frustum walk alone)
        return None, planes
    stage.history = history
    stage._warm = (nodes, sent)
    result = dict(zip(names, counters.tolist()))
    if cull_back:
        result["bfc.render_flag"] = 1
    return CullResult(sent, nodes, result, cull_back), planes

"""Culling of the moving objects of an AnimatedPartition (partition/dynamic.py), after the static
stages have culled the static triangles of the same frame.

Per frame at time t: the BVH holds each object's temporal bounding volume (world/swept.py: a box
holding it over the interval around t in which its channels stay within one key segment); only
the objects whose interval ended are swept anew, and then the BVH is refitted (rebuilt when its
SAH cost degraded). The frustum walk over the swept boxes gives the candidates; only they are
posed (matrices, exact boxes: animated.moved_boxes). Then per stage:
- frustum (`vfc`, `vfc_thesis`, `portals`, `pvs`, `occlusion`): BVH walk over the swept boxes,
  then each candidate's exact box at t, against the frame's conservative planes
  (kernels._box_planes, tol toward keeping);
- `portals`: an object is kept when its box overlaps a cell the stage found visible this frame
  (grown by the tree's slack), or overlaps no cell at all; every object in the frustum is kept
  in a frame where the stage fell back to the frustum. A sight line into a cell the flood did
  not reach crosses a wall, whatever it ends on;
- `pvs`: the baked sets list static triangles per view cell, not cells, so moving objects are
  culled by the frustum only (conservative);
- `occlusion`: the object box, then each of its triangles at t, against this frame's depth
  buffer (hiz walks and hidden_triangles, the same tests and margins as static nodes and
  triangles; tested points move by the device's rounding at the moved boxes' scale). Moving
  objects occlude too: the largest in the frustum offer their triangles posed at this frame's
  time (moving_occluders.py, `occluders`), rasterised after the static occluders, so nothing
  is hidden behind last frame's pose;
- `tbfc`: each triangle at t, the exact test with tbfc's bound (facing.not_backfacing);
- `cbfc`, `cbfc_thesis`, `cone`, `horizon`, `occlusion_thesis`: moving objects are not culled
  by them (conservative: their tables hold rest-pose normals and boxes).
Cost: a compare per moving object (is its interval over?), sweeping and refitting only when
intervals end (once per key segment: W2's walkers every 60 frames), posing only the candidates;
never the static world.
"""
from __future__ import annotations

import numpy as np
from numba import njit
from numba.cpython.unsafe.numbers import trailing_zeros

from ..partition.dynamic import DynamicBVH, refit_rows
from ..world.animated import BOX_PAD, _move_box, moved_boxes, transform_rows
from ..world.motion import _matrices
from ..world.swept import SPAN, TABLE_LIMIT, bake_intervals, baked_boxes, expired, swept_boxes
from .facing import not_backfacing
from .hiz import cull_nodes, hidden_triangles
from .kernels import _box_planes
from .moving_occluders import moving_occluders
from .occlusion import ZBUFFER_MARGIN
from .precision import device_move
from .triangle_backface import GAMMA_8

FRUSTUM = ("vfc", "vfc_thesis", "portals", "pvs", "occlusion")


@njit(cache=True, nogil=True)
def bvh_frustum(lo, hi, first, start, count, order, n_nodes, boxes, planes, tol, out, stack,
                masks, whole):
    """Objects (indices into boxes (M, 2, 3)) whose boxes are not outside the planes (P, 4),
    written to out; returns (count, nodes visited, plane tests). Errs toward keeping by tol.
    whole[k] (M,) bool is set for each object found: its box lies wholly inside every plane
    (by tol), so any box inside it is kept too."""
    if n_nodes == 0:
        return 0, 0, 0
    full = (np.int64(1) << len(planes)) - 1
    top, found, visited, tests = 1, 0, 0, 0
    stack[0], masks[0] = 0, full
    while top > 0:
        top -= 1
        node, mask = stack[top], masks[top]
        visited += 1
        outside, straddle, n = _box_planes(lo[node, 0], lo[node, 1], lo[node, 2], hi[node, 0],
                                           hi[node, 1], hi[node, 2], planes, mask, tol)
        tests += n
        if outside:
            continue
        if first[node] >= 0:
            for c in range(first[node], first[node] + 2):
                stack[top], masks[top] = c, straddle
                top += 1
            continue
        for i in range(start[node], start[node] + count[node]):
            k = order[i]
            across = straddle
            if straddle:
                gone, across, n = _box_planes(boxes[k, 0, 0], boxes[k, 0, 1], boxes[k, 0, 2],
                                              boxes[k, 1, 0], boxes[k, 1, 1], boxes[k, 1, 2],
                                              planes, straddle, tol)
                tests += n
                if gone:
                    continue
            whole[k] = across == 0
            out[found] = k
            found += 1
    return found, visited, tests


@njit(cache=True, nogil=True, inline="always")
def _in_order(items, n, bits, out):
    """out[:n] = the distinct values items[:n] (each < 64 len(bits)) in ascending order, through
    the bitmap bits (all zero before and after): O(n + the words between the least and the
    greatest), no sort."""
    low, high = len(bits), -1
    for i in range(n):
        v = items[i]
        w = v >> 6
        bits[w] |= np.uint64(1) << np.uint64(v & 63)
        low, high = min(low, w), max(high, w)
    j = 0
    for w in range(low, high + 1):
        word = bits[w]
        bits[w] = 0
        while word:
            out[j] = w * 64 + trailing_zeros(word)
            j += 1
            word &= word - np.uint64(1)


@njit(cache=True, nogil=True)
def frustum_pose(lo, hi, first, start, count, order, n_nodes, swept, planes, tol, out, stack,
                 masks, whole, t, record, links, tt, tv, rt, rv, arc, st, sv, pre, post, rest,
                 pad, matrices, boxes, scratch, bits):
    """One frame's frustum decision for the moving objects, in one compiled call: the swept
    boxes through the BVH (bvh_frustum), the candidates in ascending order (_in_order); those
    whose swept box lies wholly inside the planes are kept as they are (their exact box, inside
    it, would be: the same decision) and left unposed (whole[k] stays True: MovingObjects.settle
    poses them when a stage needs their matrices or boxes); the others posed at time t
    (motion's _matrices into matrices) and their exact boxes (animated._move_box's arithmetic,
    into boxes) tested against the planes. out[:count] = the objects kept, ascending; returns
    (count, BVH nodes visited, candidates, plane tests). scratch: (2 M,) int64, bits: (M / 64
    + 1,) uint64 zeros."""
    found, visited, tests = bvh_frustum(lo, hi, first, start, count, order, n_nodes, swept,
                                        planes, tol, out, stack, masks, whole)
    m = len(scratch) // 2
    candidates, need = scratch[:m], scratch[m:]
    _in_order(out, found, bits, candidates)
    posed = 0
    for i in range(found):
        if not whole[candidates[i]]:
            need[posed] = candidates[i]
            posed += 1
    _matrices(t, need[:posed], record, links, tt, tv, rt, rv, arc, st, sv, pre, post,
              matrices)
    full = (np.int64(1) << len(planes)) - 1
    kept, j = 0, 0
    for i in range(found):
        k = candidates[i]
        if not whole[k]:
            _move_box(rest[k], matrices[k], pad, boxes[k])
            outside, _, n = _box_planes(boxes[k, 0, 0], boxes[k, 0, 1], boxes[k, 0, 2],
                                        boxes[k, 1, 0], boxes[k, 1, 1], boxes[k, 1, 2], planes,
                                        full, tol)
            tests += n
            if outside:
                continue
        out[kept] = k
        kept += 1
    return kept, visited, found, tests


@njit(cache=True, nogil=True)
def advance(t, valid_from, valid_until, rows, loop, duration, step, tt, tv, ts, rt, rv, rs, st,
            sv, ss, pre, post, rest, swept, order, lo, hi, first, start, count, parent,
            leaf_of, n_nodes, area_sum, span, table_start, table_lo, table_hi, table_boxes,
            missed):
    """MovingObjects.pose's update in one compiled call: the tracks whose interval does not
    hold t (swept.expired, into rows) given their next swept box, from the baked intervals
    (swept.baked_boxes) or, for a track without one, swept anew (swept.swept_boxes); then, when
    any, the BVH nodes above them refitted (dynamic.refit_rows) and the largest |coordinate|
    of all swept boxes read off the root's box (it is their exact bound). Returns (tracks
    renewed, that largest |coordinate|, the SAH cost, its numerator); (0, -1, -1, area_sum)
    when nothing expired."""
    n = expired(t, valid_from, valid_until, rows)
    if n == 0 or n_nodes == 0:
        return n, (-1.0 if n == 0 else 0.0), (-1.0 if n == 0 else 0.0), area_sum
    gone = baked_boxes(t, rows[:n], loop, duration, table_start, table_lo, table_hi,
                       table_boxes, swept, valid_from, valid_until, missed)
    if gone:
        swept_boxes(t, missed[:gone], loop, duration, step, tt, tv, ts, rt, rv, rs, st, sv, ss,
                    pre, post, rest, swept, valid_from, valid_until, span)
    cost, area_sum = refit_rows(swept, rows[:n], order, lo, hi, first, start, count, parent,
                                leaf_of, n_nodes, area_sum)
    most = 0.0
    for j in range(3):
        most = max(most, max(abs(lo[0, j]), abs(hi[0, j])))
    return n, most, cost, area_sum


@njit(cache=True, nogil=True)
def _boxes_meet_cells(boxes, objects, cells_lo, cells_hi, visible, grow, keep):
    """keep[i] for objects[i]: its box overlaps (within grow) a visible cell, or no cell."""
    for i in range(len(objects)):
        k = objects[i]
        any_cell, seen = False, False
        for c in range(len(cells_lo)):
            meets = True
            for j in range(3):
                if boxes[k, 0, j] > cells_hi[c, j] + grow or boxes[k, 1, j] < cells_lo[c, j] - grow:
                    meets = False
                    break
            if meets:
                any_cell = True
                if visible[c]:
                    seen = True
                    break
        keep[i] = seen or not any_cell


@njit(cache=True, nogil=True)
def _object_ids(objects, start, triangles, out, last):
    """out = triangles[start[k]:start[k + 1]] for k in objects, in order; returns True when they
    came out ascending and above `last`."""
    count, ordered = 0, True
    for i in range(len(objects)):
        k = objects[i]
        for j in range(start[k], start[k + 1]):
            t = triangles[j]
            ordered = ordered and t > last
            last = t
            out[count] = t
            count += 1
    return ordered


@njit(cache=True, nogil=True)
def _ascending(ids):
    for i in range(1, len(ids)):
        if ids[i] <= ids[i - 1]:
            return False
    return True


@njit(cache=True, nogil=True)
def merge_sorted(a, b):
    """(len(a) + len(b),) int64 the union of two sorted arrays with no common element."""
    out = np.empty(len(a) + len(b), dtype=np.int64)
    i = j = k = 0
    while i < len(a) and j < len(b):
        if a[i] < b[j]:
            out[k] = a[i]
            i += 1
        else:
            out[k] = b[j]
            j += 1
        k += 1
    while i < len(a):
        out[k] = a[i]
        i += 1
        k += 1
    while j < len(b):
        out[k] = b[j]
        j += 1
        k += 1
    return out


def _ranges(start, objects) -> np.ndarray:
    """Concatenated arange(start[k], start[k + 1]) for k in objects, int64."""
    a, b = start[objects], start[objects + 1]
    lengths = b - a
    total = int(lengths.sum())
    if not total:
        return np.zeros(0, dtype=np.int64)
    offsets = np.repeat(a - np.cumsum(lengths) + lengths, lengths)
    return np.arange(total, dtype=np.int64) + offsets


class MovingObjects:
    """The moving half of a Culler over an AnimatedPartition (module docstring).

    pose(time), then cull(state) -> (S,) int64 sorted world triangle ids of moving objects to
    draw; counts
    moving.* counters in state.stats. `stages`: the Culler's stage objects by name (portals,
    pvs and occlusion are read after their static pass of the same frame).
    """

    def __init__(self, partition, stages: dict, arithmetic: str):
        self.animated = a = partition.animated
        self.stages, self.arithmetic = stages, arithmetic
        self.bvh = DynamicBVH(a.rest_boxes)
        m = len(a.motion)
        self._out = np.empty(max(m, 1), dtype=np.int64)
        self._scratch = np.empty(2 * max(m, 1), dtype=np.int64)  # frustum_pose's
        self._bits = np.zeros(max(m, 1) // 64 + 1, dtype=np.uint64)  # its bitmap, kept zero
        self._stack = np.empty(2 * m + 64, dtype=np.int64)
        self._masks = np.empty(2 * m + 64, dtype=np.int64)
        self._posed = np.empty_like(a.rest_vertices)
        self.frustum = any(name in stages for name in FRUSTUM)
        # stages that read the kept objects' matrices or exact boxes (else ids straight)
        self.exact = any(name in stages for name in ("portals", "occlusion", "tbfc"))
        # occlusion's box walk over the objects as a flat tree of leaves
        self._leaf = (np.full(m, -1, np.int64), np.zeros(m, np.int64), np.ones(m, np.bool_),
                      np.full(m, -1, np.int64), np.full(m, -1, np.int64),
                      np.full(m, -1, np.int64))
        self._frame = 0
        self.boxes = a.rest_boxes.copy()  # exact boxes at the frame's time (candidates' rows)
        self.matrices = np.empty((m, 4, 4))  # exact matrices (candidates' and `always` rows)
        self.swept = a.rest_boxes.copy()  # temporal bounding volumes (world/swept.py)
        self.valid_from = np.full(m, np.inf)  # nothing valid yet: the first frame sweeps all
        self.valid_until = np.full(m, -np.inf)
        self._expired = np.empty(m, dtype=np.int64)
        self._missed = np.empty(m, dtype=np.int64)  # tracks without a baked interval at t
        self._table = (None,)  # (span, swept.bake_intervals' arrays), baked at the first pose
        self._argument_tuples = None  # _arguments
        self.always = np.zeros(0, dtype=np.int64)  # rows whose matrices every pose computes
        self.time, self.magnitude, self._rest = None, 0.0, False
        self._frame_objects = None
        self.span = SPAN  # the swept boxes' windows (seconds: swept.SPAN)
        self.whole = np.zeros(m, dtype=np.bool_)  # kept by in_frustum unposed (settle poses)
        self._all = np.arange(m, dtype=np.int64)

    def pose(self, time) -> float:
        """Bring the swept boxes to `time` (None: the rest pose): the tracks whose interval
        ended are swept anew and the BVH refitted (rebuilt when its SAH cost degraded), and the
        `always` rows' matrices computed. Returns the largest |coordinate| of the swept boxes
        (they hold every exact box: the Culler's planes are inflated for it)."""
        a, motion = self.animated, self.animated.motion
        self.time, self.expired, self.rebuilt = time, 0, False
        self._frame_objects = None  # this frame's in_frustum (frame_objects)
        if time is None:
            if not self._rest:  # the rest boxes, exact: valid for no time
                self.swept[:] = a.rest_boxes
                self.valid_from.fill(np.inf)
                self.valid_until.fill(-np.inf)
                self.magnitude = float(np.abs(self.swept).max(initial=0.0))
                self.rebuilt = self.bvh.update(self.swept)
                self._rest = True
            self.matrices[self.always] = np.eye(4)
            return self.magnitude
        t = float(time)
        if not np.isfinite(t):
            raise ValueError(f"time must be finite, got {time}")
        self._rest = False
        c, b = motion.channels, self.bvh
        if self._table[0] != self.span:  # the swept boxes of every interval, baked once
            self._table = (self.span, *bake_intervals(
                motion.loop, motion.duration, motion.step, *c["translation"], *c["rotation"],
                *c["scale"], motion.pre, motion.post, a.rest_boxes, self.span, TABLE_LIMIT))
        count, most, cost, area_sum = advance(t, *self._arguments[0], b.node_count, b.area_sum,
                                              self.span, *self._table[1:], self._missed)
        if count:
            self.magnitude = most
            self.rebuilt = b.refitted(cost, area_sum, self.swept)
            self.expired = count
        if len(self.always):
            motion.matrices(t, self.matrices, self.always)
        return self.magnitude

    def frame_objects(self, state) -> tuple:
        """in_frustum for the frame's planes, computed once a frame (occlusion's moving
        occluders ask first, cull after)."""
        if self._frame_objects is None or self._frame_objects[0] is not state:
            self._frame_objects = (state, *self.in_frustum(np.ascontiguousarray(state.planes),
                                                            self._tol(state)))
        return self._frame_objects[1:]

    def occluders(self, state, stage):
        """`occlusion`'s extra_occluders: the rasteriser's tables of this frame's moving
        occluders, posed at the frame's time (moving_occluders.py), or None."""
        if not self.frustum:
            return None
        objects = self.frame_objects(state)[0]
        if not len(objects):
            return None
        self.settle(objects)
        return moving_occluders(self.animated, self.matrices, self._posed, objects, self.boxes,
                                state.camera.eye, state.planes, stage._view(state.camera)[6],
                                stage.occluders)

    def _exact(self, rows) -> None:
        """Matrices and exact boxes (animated.moved_boxes) of rows at the posed time."""
        if self.time is None:
            self.matrices[rows] = np.eye(4)
        else:
            self.animated.motion.matrices(self.time, self.matrices, rows)
        self.boxes[rows] = moved_boxes(self.animated.rest_boxes[rows], self.matrices[rows])

    def in_frustum(self, planes, tol) -> tuple:
        """(objects (K,) int64 sorted whose exact box at the posed time is not outside the
        planes (P, 4), BVH nodes visited, candidates, plane tests): the swept boxes through the
        BVH, then the candidates posed (matrices, exact boxes) and tested. After pose()."""
        b = self.bvh
        if self.time is None:  # the rest pose: identity matrices, the rest boxes
            found, visited, tests = bvh_frustum(b.lo, b.hi, b.first, b.start, b.count, b.order,
                                                b.node_count, self.swept, planes, tol,
                                                self._out, self._stack, self._masks, self.whole)
            candidates = np.sort(self._out[:found])
            self._exact(candidates)
            self.whole[candidates] = False
            return candidates, visited, len(candidates), tests
        _, head, middle, tail = self._arguments
        kept, visited, found, tests = frustum_pose(*head, b.node_count, self.swept, planes, tol,
                                                   *middle, self.time, *tail)
        return self._out[:kept].copy(), visited, found, tests

    @property
    def _arguments(self) -> tuple:
        """The arrays advance and frustum_pose take, gathered once (each is kept and written
        in place): (advance's before the node count, frustum_pose's before the node count,
        between the tolerance and the time, after the time)."""
        if self._argument_tuples is None:
            motion, c, b = self.animated.motion, self.animated.motion.channels, self.bvh
            self._argument_tuples = (
                (self.valid_from, self.valid_until, self._expired, motion.loop, motion.duration,
                 motion.step, *c["translation"], *c["rotation"], *c["scale"], motion.pre,
                 motion.post, self.animated.rest_boxes, self.swept, b.order, b.lo, b.hi,
                 b.first, b.start, b.count, b.parent, b.leaf_of),
                (b.lo, b.hi, b.first, b.start, b.count, b.order),
                (self._out, self._stack, self._masks, self.whole),
                (*motion.records, *c["translation"][:2], *c["rotation"][:2], motion.arc,
                 *c["scale"][:2], motion.pre, motion.post, self.animated.rest_boxes, BOX_PAD,
                 self.matrices, self.boxes, self._scratch, self._bits))
        return self._argument_tuples

    def settle(self, objects) -> None:
        """Matrices and exact boxes at the posed time for those of objects (K,) int64 that
        in_frustum kept unposed (their swept box wholly inside the frustum)."""
        need = objects[self.whole[objects]]
        if len(need):
            self._exact(need)
            self.whole[need] = False

    def cull(self, state, static) -> np.ndarray:
        """(S,) int64 sorted: static (the static half's world ids, sorted) with the moving
        objects' ids to draw; after pose(time) and the static stages of the same frame."""
        static = np.ascontiguousarray(static, dtype=np.int64)
        a = self.animated
        state.count("moving.objects", len(a.motion))
        state.count("moving.rebuilds", int(self.rebuilt))
        state.count("moving.swept", self.expired)
        if self.frustum:
            objects, visited, candidates, tests = self.frame_objects(state)
            state.count("moving.nodes_visited", visited)
            state.count("moving.candidates", candidates)
            state.count("plane_tests", tests)
        else:
            objects = self._all
            self._exact(objects)
        if self.exact and len(objects):
            self.settle(objects)
        boxes, matrices = self.boxes, self.matrices
        if not len(objects):
            state.count("moving.objects_sent", 0)
            state.count("moving.triangles_sent", 0)
            return static
        if "portals" in self.stages and len(objects):
            objects = self._cells("portals", state, boxes, objects)
        occlusion = self.stages.get("occlusion")
        usable = occlusion is not None and getattr(occlusion, "_camera", None) is state.camera \
            and occlusion._view(state.camera)[7] < np.inf
        if usable and len(objects):
            objects = self._occluded_boxes(occlusion, state, boxes, objects)
        state.count("moving.objects_sent", len(objects))
        if "tbfc" not in self.stages and not usable:  # whole objects: their ids straight
            count = int((a.tri_start[objects + 1] - a.tri_start[objects]).sum())
            state.count("moving.triangles_sent", count)
            out = np.empty(len(static) + count, dtype=np.int64)
            out[:len(static)] = static
            if _object_ids(objects, a.tri_start, a.moving_triangles, out[len(static):],
                           static[-1] if len(static) else -1):
                return out  # already one ascending list: moving ids after the static ones
            return merge_sorted(static, np.sort(out[len(static):]))
        local = _ranges(a.tri_start, objects)
        if len(local):
            transform_rows(  # the objects' rows only: O(what is in view)
                a.rest_vertices, a.vertex_start, np.ascontiguousarray(matrices),
                           objects, self._posed)
            if "tbfc" in self.stages:
                local = self._backfacing(state, local, boxes[objects])
            if usable and occlusion.triangles and len(local):
                local = self._occluded_triangles(occlusion, state, boxes[objects], local)
        state.count("moving.triangles_sent", len(local))
        ids = a.moving_triangles[local]
        if not _ascending(ids):
            ids = np.sort(ids)
        if not len(ids):
            return static
        if not len(static) or ids[0] > static[-1]:
            return np.concatenate([static, ids])
        return merge_sorted(static, ids)

    def _scale(self, state, boxes=None) -> float:
        return max(self.magnitude, *map(abs, state.camera.position))

    def _tol(self, state) -> float:
        return float(state.tree.tol) * max(1.0, self._scale(state)
                                           / max(state.tree.scale, 1e-300))

    def _cells(self, name, state, boxes, objects) -> np.ndarray:
        stage = self.stages[name]
        cells = getattr(stage, "frame_cells", None)
        if cells is None:  # the stage fell back to the frustum this frame: nothing more
            return objects
        visible = np.zeros(len(stage.cell_lo), dtype=np.bool_)
        visible[cells] = True
        keep = np.empty(len(objects), dtype=np.bool_)
        _boxes_meet_cells(boxes, objects, stage.cell_lo, stage.cell_hi, visible,
                          float(state.tree.tol), keep)
        state.count(f"moving.{name}_culled", int((~keep).sum()))
        return objects[keep]

    def _occluded_boxes(self, stage, state, boxes, objects) -> np.ndarray:
        camera = state.camera
        eye, rotation, tx, ty, move = stage._view(camera)[:5]
        tested = max(move, 2.0 * device_move(self.arithmetic, self._scale(state, boxes)))
        margin = ZBUFFER_MARGIN / camera.near
        recede = np.sqrt(3.0) * move
        first, count, nonempty, parent, draw, up = self._leaf
        self._frame += 1
        out = np.empty(len(objects) + 1, dtype=np.int64)
        stack = np.empty(len(objects) + 1, dtype=np.int64)
        below = np.empty(len(objects) + 1, dtype=np.uint8)
        lo = np.ascontiguousarray(boxes[:, 0])
        hi = np.ascontiguousarray(boxes[:, 1])
        kept, _, culled = cull_nodes(
            lo, hi, first, count, nonempty, parent, objects, draw, up, self._frame, eye,
            rotation, camera.near, tx, ty, stage.width, stage.height, tested,
            stage.shift(camera, move), margin, recede, stage.depth, stage.tile_max,
            stage.tile_any, stage.tile_shift, *stage.tile, out, stack, below,
            stage.nearest_far(margin, recede), False, *stage.samples(camera, tested))
        state.count("moving.occlusion_culled", culled)
        return np.sort(out[:kept])

    def _occluded_triangles(self, stage, state, boxes, local) -> np.ndarray:
        camera = state.camera
        eye, rotation, tx, ty, move = stage._view(camera)[:5]
        tested = max(move, 2.0 * device_move(self.arithmetic, self._scale(state, boxes)))
        margin = ZBUFFER_MARGIN / camera.near
        recede = np.sqrt(3.0) * move
        n = len(local)
        hidden, subpixel = np.empty(n, dtype=np.bool_), np.empty(n, dtype=np.bool_)
        zmin = np.empty(n)
        hidden_triangles(local, self._posed, self.animated.local_triangles, eye, rotation,
                         camera.near, tx, ty, stage.width, stage.height, tested,
                         stage.shift(camera, move), margin, recede, stage.depth, stage.tile_max,
                         stage.tile_shift, *stage.tile, True, *stage.samples(camera, tested),
                         hidden, subpixel, zmin)
        gone = hidden | subpixel
        state.count("moving.occlusion_triangles_culled", int(gone.sum()))
        return local[~gone]

    def _backfacing(self, state, local, boxes) -> np.ndarray:
        stage = self.stages["tbfc"]
        eye = np.asarray(state.camera.eye, dtype=np.float64)
        scale = max(stage.magnitude, self._scale(state, boxes))
        absolute = device_move(self.arithmetic, 0.0) if stage.absolute is None else stage.absolute
        delta = stage.relative * scale + absolute
        kept = np.empty(len(local), dtype=np.int64)
        count = not_backfacing(local, self._posed, self.animated.local_triangles, eye, delta,
                               GAMMA_8, kept)
        state.count("moving.tbfc_culled", len(local) - count)
        return kept[:count]


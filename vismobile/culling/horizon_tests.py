"""The `horizon` stage's per-frame tests in numba (culling/horizon.py): node boxes and triangles
against a horizon in one call each, the off-screen test of triangles and, with a screen, the
pixel-centre test (hiz's _covers_no_sample). A call costs a few microseconds of dispatch, so
each test is one call. One kernel serves both arithmetics: the horizon's limit picks the test
(_hidden), None the float64 one (terrain/horizon.py's hidden_one), a number the 16.16 one
(terrain/horizon_fixed.py's hidden_one_fixed); numba compiles the kernel once for each and
prunes the other branch (a None argument's branches go before typing)."""
from __future__ import annotations

import numpy as np
from numba import njit

from ..terrain.horizon import hidden_one
from ..terrain.horizon_fixed import hidden_one_fixed
from .hiz.buffer import _covers_no_sample
from .hiz.raster import _to_camera

# No horizon cast: the kernels' horizon arguments (test False, origin, limit .. clamp).
NO_HORIZON = (False, np.zeros(3), None, np.zeros(3), np.array([0.0, 0, -1]),
              np.array([1.0, 0, 0]), np.array([-1.0, 1.0]), np.array([1.0, 2.0]),
              np.full((1, 1), -np.inf), np.full(1, np.inf), np.zeros((0, 0)), False)
# No screen: _triangles' sample arguments (eye, rotation, near, tx, ty, width 0, height, move).
NO_SCREEN = (np.zeros(3), np.eye(3), 1.0, 1.0, 1.0, 0, 0, 0.0)
# No object boxes: _triangles' object arguments (object ids, boxes, stamp, verdict, frame).
NO_OBJECTS = (np.zeros(0, np.int32), np.zeros((0, 2, 3)), np.zeros(0, np.int64),
              np.zeros(0, np.int8), 0)
OFF, BEHIND, TEST = 1, 2, 3  # an object box's verdict for this frame (_verdict)


@njit(cache=True, inline="always")
def _hidden(points, grow, acc, origin, limit, eye, forward, right, tans, depths, values, ceiling,
            bases, clamp):
    """True when the hull of points (C, 3), each grown to its cube of half-side grow, lies
    behind the horizon origin .. clamp: limit None, a float64 Horizon's arrays
    (Horizon.hidden_points' verdict); else a 16.16 FixedHorizon's origin, range limit and raw
    arrays (FixedHorizon.hidden_points': corners rounded outward to 16.16, none beyond
    +-limit). Errs towards False (not hidden) as those do. acc: (5,) int64 scratch."""
    if limit is None:
        return hidden_one(points, origin, eye, forward, right, tans, depths, values, ceiling,
                          bases, clamp, grow)
    return hidden_one_fixed(points, origin, grow, limit, eye, forward, right, tans, depths,
                            values, ceiling, bases, clamp, acc)


def off_screen(corners, planes, slack: float) -> np.ndarray:
    """(K,) bool: triangles (K, 3, 3) whose three corners all lie more than `slack` outside one
    of the inward planes (P, 4) (unit normals; inside where n.x + d >= 0): the whole triangle
    is outside the frustum. planes are the Culler's conservative planes (pushed out by the
    arithmetic's margin); slack adds the tree's tolerance and the device's vertex move, so a
    triangle the device could draw inside the frustum is never called off screen."""
    corners = np.asarray(corners, np.float64)
    ids = np.arange(len(corners))
    off, _, _ = _triangles(corners, ids, np.asarray(planes, np.float64), float(slack), 0.0,
                           *NO_HORIZON, *NO_SCREEN, *NO_OBJECTS)
    return off


@njit(cache=True, inline="always")
def _outside(c, planes, slack):
    for p in range(planes.shape[0]):
        a, b, e, d = planes[p, 0], planes[p, 1], planes[p, 2], planes[p, 3] + slack
        if (a * c[0, 0] + b * c[0, 1] + e * c[0, 2] + d < 0
                and a * c[1, 0] + b * c[1, 1] + e * c[1, 2] + d < 0
                and a * c[2, 0] + b * c[2, 1] + e * c[2, 2] + d < 0):
            return True
    return False


@njit(cache=True, inline="always")
def _box_off(box, planes, slack):
    """True when the box (2, 3) lies more than slack outside one plane (its p-vertex does)."""
    for p in range(planes.shape[0]):
        d = planes[p, 3] + slack
        for a in range(3):
            d += planes[p, a] * (box[1, a] if planes[p, a] > 0 else box[0, a])
        if d < 0:
            return True
    return False


@njit(cache=True, inline="always")
def _box_corners(box, out):
    for c in range(8):
        for a in range(3):
            out[c, a] = box[1, a] if (c >> a) & 1 else box[0, a]


@njit(cache=True, inline="always")
def _verdict(o, object_boxes, stamp, verdict, frame, planes, slack, test, origin, limit, eye,
             forward, right, tans, depths, values, ceiling, bases, clamp, box8, acc):
    """The verdict (OFF, BEHIND, TEST) of object o's box this frame, computed once a frame
    (stamp) and kept in verdict: its triangles lie in the box, grown by the margin as their
    corners are, so a box off screen or behind the horizon holds only such triangles."""
    if stamp[o] != frame:
        stamp[o] = frame
        box = object_boxes[o]
        verdict[o] = TEST
        if _box_off(box, planes, slack):
            verdict[o] = OFF
        elif test:
            _box_corners(box, box8)
            if _hidden(box8, 0.0, acc, origin, limit, eye, forward, right, tans, depths, values,
                       ceiling, bases, clamp):
                verdict[o] = BEHIND
    return verdict[o]


@njit(cache=True)
def _triangles(corners, ids, planes, slack, grow, test, origin, limit, eye, forward, right, tans,
               depths, values, ceiling, bases, clamp, view_eye, rotation, near, tx, ty, sw, sh,
               sample_move, object_ids, object_boxes, stamp, verdict, frame):
    """(off, behind, subpixel) (K,) bool for triangles ids (K,) of corners (T, 3, 3): off
    screen (see off_screen), else (when test) behind the horizon origin .. clamp (_hidden;
    horizon_arrays, fixed_arrays or NO_HORIZON; corners grown by grow), else (sw > 0)
    covering no pixel centre of an sw x sh screen (hiz's _covers_no_sample: the camera
    view_eye (3,), rotation (3, 3) rows right, up, forward, near, half tangents tx, ty, corners
    moved by up to sample_move per coordinate). With object boxes (object_ids (T,),
    object_boxes (O, 2, 3) grown by grow; stamp (O,) int64 and verdict (O,) int8 kept between
    calls, frame a new number each frame) a triangle whose object's box is off screen or
    behind is decided by the box, tested once a frame (_verdict)."""
    off = np.zeros(ids.shape[0], dtype=np.bool_)
    behind = np.zeros(ids.shape[0], dtype=np.bool_)
    subpixel = np.zeros(ids.shape[0], dtype=np.bool_)
    acc = np.empty(5, np.int64)
    cam = np.empty((3, 3))
    px = np.empty(3)
    py = np.empty(3)
    box8 = np.empty((8, 3))
    boxes = object_boxes.shape[0] > 0
    last, v = -1, TEST  # triangles come object by object: the last object's verdict
    for n in range(ids.shape[0]):
        if boxes:
            o = object_ids[ids[n]]
            if o != last:
                last = o
                v = _verdict(o, object_boxes, stamp, verdict, frame, planes, slack, test,
                             origin, limit, eye, forward, right, tans, depths, values, ceiling,
                             bases, clamp, box8, acc)
            if v == OFF:
                off[n] = True
                continue
            if v == BEHIND:
                behind[n] = True
                continue
        c = corners[ids[n]]
        if _outside(c, planes, slack):
            off[n] = True
        elif test and _hidden(c, grow, acc, origin, limit, eye, forward, right, tans, depths,
                              values, ceiling, bases, clamp):
            behind[n] = True
        elif sw > 0:
            subpixel[n] = _no_centre(c, view_eye, rotation, near, tx, ty, sw, sh, sample_move,
                                     cam, px, py)
    return off, behind, subpixel


@njit(cache=True, inline="always")
def _no_centre(c, view_eye, rotation, near, tx, ty, sw, sh, sample_move, cam, px, py):
    """hiz's _covers_no_sample of the world triangle c (3, 3) (cam, px, py: scratch)."""
    for k in range(3):
        _to_camera(c[k], view_eye, rotation, cam[k])
    return _covers_no_sample(cam, near, tx, ty, sw, sh, sample_move, 16, px, py)


@njit(cache=True)
def _nodes(bounds, nodes, grow, test, origin, limit, eye, forward, right, tans, depths, values,
           ceiling, bases, clamp):
    """(K,) bool: node boxes bounds[nodes] (K, 2, 3), grown by grow, behind the horizon
    (_hidden; none when not test)."""
    out = np.zeros(nodes.shape[0], dtype=np.bool_)
    corners = np.empty((8, 3))
    acc = np.empty(5, np.int64)
    for n in range(nodes.shape[0] if test else 0):
        box = bounds[nodes[n]]
        for c in range(8):
            for a in range(3):
                corners[c, a] = box[1, a] + grow if (c >> a) & 1 else box[0, a] - grow
        out[n] = _hidden(corners, 0.0, acc, origin, limit, eye, forward, right, tans, depths,
                         values, ceiling, bases, clamp)
    return out


def horizon_arrays(horizon) -> tuple:
    """A float64 Horizon's arguments for _triangles and _nodes (test True, origin, limit None
    .. clamp)."""
    return (True, horizon.origin, None, horizon.eye, horizon.forward, horizon.right,
            horizon.tans, horizon.depths, horizon.values, horizon.ceiling, horizon.bases,
            horizon.clamp)


def fixed_arrays(horizon) -> tuple:
    """A 16.16 FixedHorizon's arguments for _triangles and _nodes (test True, origin, limit
    and its raw arrays)."""
    return (True, horizon.origin, float(horizon.limit), horizon.eye, horizon.forward,
            horizon.right, horizon.tans, horizon.depths, horizon.values, horizon.ceiling,
            horizon.bases, horizon.clamp)

"""The `horizon` stage's per-frame tests in numba (culling/horizon.py): node boxes and triangles
against a float64 horizon (terrain/horizon.py's hidden_one) in one call each, and the off-screen
test of triangles. A call costs a few microseconds of dispatch, so each test is one call."""
from __future__ import annotations

import numpy as np
from numba import njit

from ..terrain.horizon import hidden_one


def off_screen(corners, planes, slack: float) -> np.ndarray:
    """(K,) bool: triangles (K, 3, 3) whose three corners all lie more than `slack` outside one
    of the inward planes (P, 4) (unit normals; inside where n.x + d >= 0): the whole triangle
    is outside the frustum. planes are the Culler's conservative planes (pushed out by the
    arithmetic's margin); slack adds the tree's tolerance and the device's vertex move, so a
    triangle the device could draw inside the frustum is never called off screen."""
    corners = np.asarray(corners, np.float64)
    ids = np.arange(len(corners))
    off, _ = _triangles(corners, ids, np.asarray(planes, np.float64), float(slack), False,
                        *_NO_HORIZON)
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


@njit(cache=True)
def _triangles(corners, ids, planes, slack, test, origin, eye, forward, right, tans, depths,
               values, ceiling, bases, clamp, grow):
    """(off, behind) (K,) bool for triangles ids (K,) of corners (T, 3, 3): off screen (see
    off_screen), else (when test) behind the horizon (hidden_one, corners grown by grow)."""
    off = np.zeros(ids.shape[0], dtype=np.bool_)
    behind = np.zeros(ids.shape[0], dtype=np.bool_)
    for n in range(ids.shape[0]):
        c = corners[ids[n]]
        if _outside(c, planes, slack):
            off[n] = True
        elif test:
            behind[n] = hidden_one(c, origin, eye, forward, right, tans, depths, values,
                                   ceiling, bases, clamp, grow)
    return off, behind


@njit(cache=True)
def _nodes(bounds, nodes, grow, origin, eye, forward, right, tans, depths, values, ceiling,
           bases, clamp):
    """(K,) bool: node boxes bounds[nodes] (K, 2, 3), grown by grow, behind the horizon."""
    out = np.zeros(nodes.shape[0], dtype=np.bool_)
    corners = np.empty((8, 3))
    for n in range(nodes.shape[0]):
        box = bounds[nodes[n]]
        for c in range(8):
            for a in range(3):
                corners[c, a] = box[1, a] + grow if (c >> a) & 1 else box[0, a] - grow
        out[n] = hidden_one(corners, origin, eye, forward, right, tans, depths, values,
                            ceiling, bases, clamp, 0.0)
    return out


def horizon_arrays(horizon) -> tuple:
    """The float64 Horizon's arrays in _triangles' and _nodes' order (origin .. clamp)."""
    return (horizon.origin, horizon.eye, horizon.forward, horizon.right, horizon.tans,
            horizon.depths, horizon.values, horizon.ceiling, horizon.bases, horizon.clamp)


_NO_HORIZON = (np.zeros(3), np.zeros(3), np.array([0.0, 0, -1]), np.array([1.0, 0, 0]),
               np.array([-1.0, 1.0]), np.array([1.0, 2.0]), np.full((1, 1), -np.inf),
               np.full(1, np.inf), np.zeros((0, 0)), False, 0.0)

"""The 16.16 fixed-point tests of the floating horizon (horizon.py's FixedHorizon and the
`horizon` culling stage's fixed16.16 kernels): the device's multiply-high and divides, and a
hull of points tested against a 16.16 horizon, every rounding toward visible."""
from __future__ import annotations

import numpy as np
from numba import njit

from .horizon_bands import bands_hide

ONE = 1 << 16
SLOPE_LIMIT = (1 << 31) - 1  # int32: slopes clamp into +-this (raw)


@njit(cache=True, inline="always")
def _fmul(a, b):
    """16.16 product rounded down (the device's multiply-high)."""
    return (a * b) >> 16


@njit(cache=True, inline="always")
def _fdiv_floor(a, b):
    """16.16 quotient a / b (b > 0) rounded down."""
    return (a << 16) // b


@njit(cache=True, inline="always")
def _fdiv_ceil(a, b):
    """16.16 quotient a / b (b > 0) rounded up."""
    return -(((-a) << 16) // b)


@njit(cache=True, inline="always")
def _fixed_point(x, y, w, forward, right, acc):
    """Folds one raw 16.16 point (x, y, w) relative to the eye into acc (5,) int64 = (zmin,
    tmin, tmax, mmin, mmax), each rounded toward visible; False when it is not in front."""
    z_lo = _fmul(x, forward[0]) + _fmul(w, forward[2])  # exact value < z_lo + 2
    l_lo = _fmul(x, right[0]) + _fmul(w, right[2])
    z_hi, l_hi = z_lo + 2, l_lo + 2
    if z_lo <= 0:
        return False
    acc[0] = min(acc[0], z_lo)
    acc[1] = min(acc[1], _fdiv_floor(l_lo, z_hi if l_lo >= 0 else z_lo))
    acc[2] = max(acc[2], _fdiv_ceil(l_hi, z_lo if l_hi >= 0 else z_hi))
    acc[4] = max(acc[4], _fdiv_ceil(y, z_lo if y >= 0 else z_hi))
    acc[3] = min(acc[3], _fdiv_floor(y, z_hi if y >= 0 else z_lo))
    return True


@njit(cache=True, inline="always")
def _fixed_start(acc):
    acc[0], acc[1], acc[2], acc[3], acc[4] = 1 << 60, 1 << 60, -(1 << 60), 1 << 60, -(1 << 60)


@njit(cache=True, inline="always")
def _fixed_verdict(acc, tans, depths, values, ceiling, bases, clamp):
    """True when the hull folded into acc (_fixed_point) lies behind the 16.16 horizon."""
    zmin, tmin, tmax, mmin, mmax = acc[0], acc[1], acc[2], acc[3], acc[4]
    if mmax >= SLOPE_LIMIT or mmin <= -SLOPE_LIMIT:
        return False
    need = mmax + ((ONE + abs(mmax)) >> 14) + 1  # the slopes rounded outward
    above = mmin - ((ONE + abs(mmin)) >> 14) - 1
    return bands_hide(zmin, tmin, tmax, need, above, tans, depths, values, ceiling, bases, clamp)


@njit(cache=True)
def _hidden_fixed(points, eye, forward, right, tans, depths, values, ceiling, bases, clamp):
    """_hidden in 16.16 raw integers (points (K, C, 3) raw: corners of boxes rounded
    outward)."""
    out = np.zeros(points.shape[0], dtype=np.bool_)
    acc = np.empty(5, np.int64)
    for n in range(points.shape[0]):
        _fixed_start(acc)
        front = True
        for c in range(points.shape[1]):
            if not _fixed_point(points[n, c, 0] - eye[0], points[n, c, 1] - eye[1],
                                points[n, c, 2] - eye[2], forward, right, acc):
                front = False
                break
        out[n] = front and _fixed_verdict(acc, tans, depths, values, ceiling, bases, clamp)
    return out


@njit(cache=True, inline="always")
def hidden_one_fixed(points, origin, grow, limit, eye, forward, right, tans, depths, values,
                     ceiling, bases, clamp, acc):
    """FixedHorizon.hidden_points for one hull of float64 points (C, 3), in one pass: each
    point less origin is taken as its cube of half-side grow, its 8 corners rounded outward to
    16.16 (low corners down, high up, as hidden_points does); never hidden when a corner lies
    beyond +-limit. acc: (5,) int64 scratch."""
    _fixed_start(acc)
    for q in range(points.shape[0]):
        for c in range(8):
            x = (points[q, 0] + (grow if c & 1 else -grow)) - origin[0]
            y = (points[q, 1] + (grow if c & 2 else -grow)) - origin[1]
            w = (points[q, 2] + (grow if c & 4 else -grow)) - origin[2]
            if abs(x) > limit or abs(y) > limit or abs(w) > limit:
                return False
            rx = np.int64(np.ceil(x * ONE)) if c & 1 else np.int64(np.floor(x * ONE))
            ry = np.int64(np.ceil(y * ONE)) if c & 2 else np.int64(np.floor(y * ONE))
            rw = np.int64(np.ceil(w * ONE)) if c & 4 else np.int64(np.floor(w * ONE))
            if not _fixed_point(rx - eye[0], ry - eye[1], rw - eye[2], forward, right, acc):
                return False
    return _fixed_verdict(acc, tans, depths, values, ceiling, bases, clamp)

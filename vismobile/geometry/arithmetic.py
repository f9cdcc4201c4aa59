"""Arithmetic modes of the device: float64 (reference), float32 and fixed16.16, with error bounds.

A mode decides how the device stores positions and evaluates plane tests. Each mode here can
  - quantize values to what it can hold (round to nearest), refusing with ProfileError what it
    cannot hold (out of range, not finite, or too coarse for the world);
  - evaluate plane-vs-point and plane-vs-box exactly as the device would (bit-exact emulation:
    float32 rounds every operation, fixed16.16 keeps int32 values, multiplies into int64 and
    shifts right by 16, detecting int32 overflow of every partial sum);
  - bound the error of that evaluation against the exact real-number value of the float64 inputs,
    so callers can inflate planes and boxes and keep every decision conservative.

Error model (Higham, "Accuracy and Stability of Numerical Algorithms", ch. 2-3):
float: fl(a op b) = (a op b)(1 + e), |e| <= u; a dot product of 3 terms plus an offset evaluated
left to right has error <= gamma_4 * (sum |n_i p_i| + |d|), gamma_k = k u / (1 - k u).
fixed16.16: rounding to the grid costs <= 2^-17 per input, each product shifted down costs < 2^-16.
"""
from __future__ import annotations

import numpy as np

from ..errors import ProfileError
# The 16.16 format and its range are the device's (profile.py): one definition, used here.
from ..device.profile import FIXED_LIMIT, FIXED_ONE, to_fixed

MODES = ("float64", "float32", "fixed16.16")

FIXED_QUANTUM = 1.0 / FIXED_ONE
INT32_MIN, INT32_MAX = -(2**31), 2**31 - 1

# A world is refused when its coordinates carry more error than this fraction of its size.
RESOLUTION_LIMIT = 2.0**-10
# Safety factor on bounds computed in float64 (the bound's own rounding, a few ulps).
_BOUND_SLACK = 1.0 + 2.0**-40
# Smallest float32 normal; products below it lose relative accuracy (absolute slack per op).
_F32_TINY = float(np.finfo(np.float32).tiny)


def check_mode(mode: str) -> str:
    """Return mode when it is one of MODES, else raise ProfileError naming the choices."""
    if mode not in MODES:
        raise ProfileError(f"unknown arithmetic mode {mode!r}; choose one of {', '.join(MODES)}")
    return mode


def unit_roundoff(mode: str) -> float:
    """Relative rounding error u of one operation (float modes); 0 for fixed16.16 (absolute)."""
    return {"float64": 2.0**-53, "float32": 2.0**-24, "fixed16.16": 0.0}[check_mode(mode)]


def max_magnitude(mode: str) -> float:
    """Largest finite magnitude the mode can store."""
    return {"float64": float(np.finfo(np.float64).max), "float32": float(np.finfo(np.float32).max),
            "fixed16.16": FIXED_LIMIT}[check_mode(mode)]


def representation_error(magnitude, mode: str) -> np.ndarray:
    """Upper bound on |quantize(x) - x| for |x| <= magnitude: array like magnitude, float64.

    Float modes: u * |x| (plus half the smallest subnormal); fixed16.16: 2^-17 everywhere.
    """
    magnitude = np.abs(np.asarray(magnitude, dtype=np.float64))
    if check_mode(mode) == "fixed16.16":
        return np.full_like(magnitude, FIXED_QUANTUM / 2.0)
    tiny = {"float64": 2.0**-1075, "float32": 2.0**-150}[mode]
    return magnitude * unit_roundoff(mode) * _BOUND_SLACK + tiny


def quantize(values, mode: str, what: str = "value") -> np.ndarray:
    """Round values to the nearest number the mode can hold, returned as float64 (same shape).

    Raises ProfileError naming `what` when a value is not finite or outside the mode's range.
    """
    values = np.asarray(values, dtype=np.float64)
    check_mode(mode)
    if not np.all(np.isfinite(values)):
        raise ProfileError(f"{what}: not finite")
    if mode == "float64":
        return values.copy()
    peak = float(np.abs(values).max()) if values.size else 0.0
    if peak > max_magnitude(mode):
        raise ProfileError(f"{what}: magnitude {peak:.6g} exceeds the {mode} range "
                           f"+-{max_magnitude(mode):.6g}")
    if mode == "float32":
        return values.astype(np.float32).astype(np.float64)
    return np.rint(values * FIXED_ONE) / FIXED_ONE


def check_resolution(vertices, mode: str, what: str = "world") -> float:
    """Refuse a point set the mode would blur: returns its worst representation error.

    Raises ProfileError when a coordinate is out of range, or when the representation error at
    the largest coordinate exceeds RESOLUTION_LIMIT times the set's size (largest box side):
    e.g. a 10-unit room translated to 1e7 under float32 (ulp 1).
    vertices : (V, 3) float64
    """
    vertices = np.asarray(vertices, dtype=np.float64).reshape(-1, 3)
    quantize(vertices, mode, what)  # range and finiteness
    if not len(vertices):
        return 0.0
    size = float(np.ptp(vertices, axis=0).max())
    error = float(representation_error(np.abs(vertices).max(), mode))
    if size > 0.0 and error > RESOLUTION_LIMIT * size:
        raise ProfileError(f"{what}: {mode} cannot resolve it: position error {error:.3g} at "
                           f"magnitude {np.abs(vertices).max():.3g} exceeds "
                           f"{RESOLUTION_LIMIT:.3g} x its size {size:.3g}")
    return error


# ---- plane evaluation as the device does it ------------------------------------------------

def plane_distance(planes, points, mode: str) -> tuple:
    """Device value of n.p + d for every point and plane, and a bound on its error (rigorous).

    The bound holds against the exact real value computed from the float64 inputs, so it
    includes the rounding of the inputs to the mode. Raises ProfileError when an input is out of
    range or a sum overflows the mode (fixed16.16: int32).
    planes : (K, 4) float64 rows (nx, ny, nz, d)
    points : (N, 3) float64
    returns (values (N, K) float64, bounds (N, K) float64), |values - exact| <= bounds
    """
    planes = np.asarray(planes, dtype=np.float64).reshape(-1, 4)
    points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    shape = (len(points), len(planes))
    rows_plane = np.broadcast_to(planes[None], shape + (4,)).reshape(-1, 4)
    rows_point = np.broadcast_to(points[:, None], shape + (3,)).reshape(-1, 3)
    values, bounds = paired_plane_distance(rows_plane, rows_point, mode)
    return values.reshape(shape), bounds.reshape(shape)


def paired_plane_distance(planes, points, mode: str) -> tuple:
    """Device value of n_i.p_i + d_i for row i of planes and points, and its error bound.

    Same contract as plane_distance; planes (M, 4), points (M, 3) -> (values (M,), bounds (M,)).
    """
    planes = np.asarray(planes, dtype=np.float64).reshape(-1, 4)
    points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    check_mode(mode)
    if mode == "fixed16.16":
        return _fixed_distance(planes, points), _fixed_bound(planes, points)
    dtype = np.float64 if mode == "float64" else np.float32
    n = quantize(planes, mode, "plane").astype(dtype)
    p = quantize(points, mode, "point").astype(dtype)
    with np.errstate(over="ignore", invalid="ignore"):
        # left to right, one rounding per operation, as a scalar device loop does it
        value = (p[:, 0] * n[:, 0] + p[:, 1] * n[:, 1]) + p[:, 2] * n[:, 2]
        value = value + n[:, 3]
    if not np.all(np.isfinite(value)):
        raise ProfileError(f"plane distance overflows {mode}")
    scale = np.einsum("ij,ij->i", np.abs(points), np.abs(planes[:, :3])) + np.abs(planes[:, 3])
    return value.astype(np.float64), _float_bound(mode, scale)


def _float_bound(mode: str, scale):
    """Float-mode bound for a term scale sum |n_i||p_i| + |d| (exact inputs)."""
    u = unit_roundoff(mode)
    gamma4 = 4 * u / (1 - 4 * u)
    # input rounding: |n_q p_q - n p| <= (2u + u^2)|n p|, |d_q - d| <= u|d|; then gamma_4 on
    # the rounded terms, which are at most (1+u)^2 times the exact ones
    relative = gamma4 * (1 + u) ** 2 + 2 * u + u * u
    underflow = 8 * _F32_TINY if mode == "float32" else 8 * 2.0**-1022
    return (relative * np.asarray(scale, dtype=np.float64) + underflow) * _BOUND_SLACK


def _fixed_distance(planes: np.ndarray, points: np.ndarray) -> np.ndarray:
    """fixed16.16 n.p + d: int64 products shifted right by 16 (floor), int32 sums checked."""
    n = to_fixed(planes, "plane").astype(np.int64)  # int64: products must not wrap
    p = to_fixed(points, "point").astype(np.int64)
    total = n[:, 3].copy()
    for axis in range(3):  # the three terms of the dot product
        total = total + ((p[:, axis] * n[:, axis]) >> 16)
        if total.size and (total.min() < INT32_MIN or total.max() > INT32_MAX):
            raise ProfileError("fixed16.16 overflow in plane distance: the world or camera is "
                               "too far from the origin for fixed-point plane tests")
    return total.astype(np.float64) / FIXED_ONE


def _fixed_bound(planes: np.ndarray, points: np.ndarray) -> np.ndarray:
    """fixed16.16 bound: rounding the inputs 2^-17 (|p|_1 + |n|_1 + 1) + 3 * 2^-34, plus
    3 * 2^-16 for the three shifted products."""
    half = FIXED_QUANTUM / 2
    p1 = np.abs(points).sum(axis=1)
    n1 = np.abs(planes[:, :3]).sum(axis=1)
    return (half * (p1 + n1 + 1.0) + 3 * half * half + 3 * FIXED_QUANTUM) * _BOUND_SLACK


def distance_error_bound(mode: str, magnitude: float, offset: float | None = None) -> float:
    """Bound on the error of a unit-normal plane test in the mode, valid for every point with
    |coordinate| <= magnitude and every plane with |d| <= offset (default sqrt(3) * magnitude).
    """
    check_mode(mode)
    magnitude = float(abs(magnitude))
    offset = np.sqrt(3.0) * magnitude if offset is None else float(abs(offset))
    if mode == "fixed16.16":
        # |p|_1 <= 3 magnitude and |n|_1 <= sqrt(3) for a unit normal
        row = np.array([[np.sqrt(3.0), 0.0, 0.0, offset]])
        return float(_fixed_bound(row, np.array([[3 * magnitude, 0.0, 0.0]]))[0])
    # sum |n_i||p_i| <= |n|_2 |p|_2 <= sqrt(3) magnitude for a unit normal
    return float(_float_bound(mode, np.sqrt(3.0) * magnitude + offset))


def box_plane_extremes(planes, boxes, mode: str) -> tuple:
    """Device p-vertex and n-vertex distances of every box to every plane, and their bounds.

    The device picks, per plane, the box corner farthest along n (p-vertex) and the nearest
    (n-vertex) by the sign of n (no arithmetic), then evaluates n.x + d in the mode.
    planes : (K, 4) float64; boxes : (N, 2, 3) float64 min/max corners
    returns (pmax, pbound, nmin, nbound), each (N, K) float64
    """
    planes = np.asarray(planes, dtype=np.float64).reshape(-1, 4)
    boxes = np.asarray(boxes, dtype=np.float64).reshape(-1, 2, 3)
    shape = (len(boxes), len(planes))
    positive = planes[None, :, :3] >= 0  # (1, K, 3)
    rows_plane = np.broadcast_to(planes[None], shape + (4,)).reshape(-1, 4)
    out = []
    for near, far in ((0, 1), (1, 0)):  # p-vertex, then n-vertex
        vertex = np.where(positive, boxes[:, None, far], boxes[:, None, near]).reshape(-1, 3)
        values, bounds = paired_plane_distance(rows_plane, vertex, mode)
        out += [values.reshape(shape), bounds.reshape(shape)]
    return tuple(out)


def box_certainly_outside(planes, boxes, mode: str) -> np.ndarray:
    """(N,) bool: a box is outside some plane even allowing the mode's error (device p-vertex test).

    Errs toward 'not outside' by at most twice the error bound; never calls outside a box that
    reaches the inside half-space of every plane.
    """
    pmax, pbound, _, _ = box_plane_extremes(planes, boxes, mode)
    return np.any(pmax + pbound < 0.0, axis=1)


# ---- inflation: keep float64 decisions conservative for a device in another mode ----------

def inflate_planes(planes, mode: str, magnitude: float) -> np.ndarray:
    """Planes (K, 4) float64 with every offset d raised by the mode's plane-test error bound.

    Errs outward: a point with |coordinate| <= magnitude that is inside the original plane is
    inside the inflated one even when tested in the mode; the region grows by the bound
    (distance_error_bound, computed for the inflated offsets).
    """
    planes = np.array(planes, dtype=np.float64).reshape(-1, 4)
    if not len(planes):
        return planes
    offset = float(np.abs(planes[:, 3]).max())
    first = distance_error_bound(mode, magnitude, offset)
    # the inflated offsets are up to `margin` larger; the bound is affine in the offset with a
    # slope far below 1/2, so bounding at offset + 2 * first covers the inflated planes too
    margin = distance_error_bound(mode, magnitude, offset + 2.0 * first)
    planes[:, 3] += margin
    return planes


def inflate_boxes(boxes, mode: str) -> np.ndarray:
    """Boxes (N, 2, 3) float64 grown on every side by the mode's representation error.

    Errs outward by one rounding: any point inside the box stays inside after the device rounds it.
    """
    boxes = np.array(boxes, dtype=np.float64).reshape(-1, 2, 3)
    error = representation_error(np.abs(boxes).max(axis=1), mode)  # (N, 3)
    boxes[:, 0] -= error
    boxes[:, 1] += error
    return boxes

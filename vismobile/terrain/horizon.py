"""Floating-horizon occlusion from a terrain (seed 001, Szenberg 1997), conservative.

An ES 1.1 device cannot read its depth buffer back, so the CPU casts the terrain's horizon
itself, Szenberg's way: with a level camera at the eye (pitch plays no part: whether a point
is hidden by the ground depends only on the eye), each band of horizontal directions is
marched in slices parallel to the screen, z_{k+1} = z_k (1 + step). For each band and slice the
ground is bounded from below by the minimum sample over a min-mip block covering the slice's
piece of the band, which gives a lower bound of the elevation slope (h - eye_y) / z of the
terrain there; the horizon H[band, k] is the running maximum over the slices up to k.

A point at depth z with slope m is hidden if, in its band, H at the last slice ending before z
exceeds m: the ray from the eye to it then passes below ground in front of it. A box is hidden
when all its corners are in front of the eye and, over every band its corners span, the
horizon before its nearest depth exceeds its largest corner slope (a linear-fractional function
peaks at a corner). Every bound errs toward "visible", so the test never hides a box that any
pixel of the full-resolution terrain render would show; `lower` lowers the ground further for
LOD meshes that sink below the samples (by their vertical error).

Fixed point (seed 001 ran in fixed point; here on fixed16.16 profiles, `arithmetic=
"fixed16.16"`): the same cast and test in 16.16 integers (int64 products shifted right by 16,
as the device's int32 multiply-high). The frame is defined by the quantized eye, forward and
right vectors, so they carry no error; every other rounding is directed toward "visible":
ground minima floor, the lowering ceil, ground slopes floor and box slopes ceil, box corners
outward, band ranges outward, a box's depth down; the slice pieces' map boxes widen by a few
quanta plus 2^-14 of their size (the quantized axes are orthonormal only within 2^-16); and a
box is hidden only when the horizon beats its slope by (1 + |slope|) 2^-14, which covers the
eye's rounding to the 16.16 grid. Slopes are clamped into int32 in the same safe direction.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit


def min_mip(heights) -> list:
    """[(2^(n-k))^2 float64 minima over blocks of 2^k cells, samples on the block edge
    included] for k = 0..n."""
    h = np.asarray(heights, dtype=np.float64)
    level = np.minimum(np.minimum(h[:-1, :-1], h[1:, :-1]), np.minimum(h[:-1, 1:], h[1:, 1:]))
    mips = [level]
    while level.shape[0] > 1:
        k = level.shape[0] // 2
        level = level.reshape(k, 2, k, 2).min(axis=(1, 3))
        mips.append(level)
    return mips


def pack(mips) -> tuple:
    """(flat minima, offsets (levels + 1,), sizes) for the numba kernel."""
    offsets = np.r_[0, np.cumsum([m.size for m in mips])].astype(np.int64)
    sizes = np.array([m.shape[0] for m in mips], dtype=np.int64)
    return np.concatenate([m.ravel() for m in mips]), offsets, sizes


@njit(cache=True, inline="always")
def _lowest_in(flat, offsets, sizes, i0, i1, j0, j1, start):
    """Lowest height over map cells rows i0..i1, columns j0..j1 (all on the map): the min of
    the at most 2 x 2 pyramid cells of the first level where the range spans that few, never
    above the true minimum (each pyramid cell holds the min of the cells it covers)."""
    level = 0
    while (j1 >> level) - (j0 >> level) > 1 or (i1 >> level) - (i0 >> level) > 1:
        level += 1
    size = sizes[level]
    low = start
    for i in range(i0 >> level, (i1 >> level) + 1):
        for j in range(j0 >> level, (j1 >> level) + 1):
            low = min(low, flat[offsets[level] + i * size + j])
    return low


@njit(cache=True)
def _cast(flat, offsets, sizes, spacing, eye, forward, right, tans, depths, lower, horizon):
    """horizon[b, k]: running max over slices <= k of the lowest slope in band b, slice k."""
    bands = tans.shape[0] - 1
    slices = depths.shape[0] - 1
    cells = sizes[0]
    for b in range(bands):
        best = -np.inf
        for k in range(slices):
            z0, z1 = depths[k], depths[k + 1]
            # World bbox of the slice's piece of the band (a quadrilateral).
            xmin, xmax, wmin, wmax = np.inf, -np.inf, np.inf, -np.inf
            for z in (z0, z1):
                for t in (tans[b], tans[b + 1]):
                    x = eye[0] + forward[0] * z + right[0] * t * z
                    w = eye[2] + forward[2] * z + right[2] * t * z
                    xmin, xmax = min(xmin, x), max(xmax, x)
                    wmin, wmax = min(wmin, w), max(wmax, w)
            j0 = int(np.floor(xmin / spacing))
            j1 = int(np.floor(xmax / spacing))
            i0 = int(np.floor(wmin / spacing))
            i1 = int(np.floor(wmax / spacing))
            if j1 < 0 or i1 < 0 or j0 >= cells or i0 >= cells:
                horizon[b, k] = best
                continue
            if j0 < 0 or i0 < 0 or j1 >= cells or i1 >= cells:
                # Part of the piece is off the map, where there is no ground.
                horizon[b, k] = best
                continue
            low = _lowest_in(flat, offsets, sizes, i0, i1, j0, j1, np.inf)
            rise = low - lower - eye[1]
            # Lowest slope over the slice's depths: the far end when above the eye.
            slope = rise / z1 if rise > 0 else rise / z0
            best = max(best, slope)
            horizon[b, k] = best


@dataclass
class Horizon:
    """One frame's horizon.

    eye      : (3,) float64
    forward, right : (3,) float64 level camera axes (y = 0)
    tans     : (B+1,) float64 band edges as tan of the horizontal angle
    depths   : (S+1,) float64 slice boundaries along forward
    values   : (B, S) float64 running max of lowest slopes (-inf: nothing yet)
    """

    eye: np.ndarray
    forward: np.ndarray
    right: np.ndarray
    tans: np.ndarray
    depths: np.ndarray
    values: np.ndarray

    def hidden(self, boxes) -> np.ndarray:
        """(K,) bool: box (K, 2, 3) entirely hidden by the ground (errs visible)."""
        return _hidden(np.asarray(boxes, dtype=np.float64).reshape(-1, 2, 3), self.eye,
                       self.forward, self.right, self.tans, self.depths, self.values)


@njit(cache=True)
def _hidden(boxes, eye, forward, right, tans, depths, values):
    out = np.zeros(boxes.shape[0], dtype=np.bool_)
    bands = tans.shape[0] - 1
    for n in range(boxes.shape[0]):
        zmin, tmin, tmax, mmax = np.inf, np.inf, -np.inf, -np.inf
        for c in range(8):
            x = boxes[n, (c >> 0) & 1, 0] - eye[0]
            y = boxes[n, (c >> 1) & 1, 1] - eye[1]
            w = boxes[n, (c >> 2) & 1, 2] - eye[2]
            z = x * forward[0] + w * forward[2]
            lateral = x * right[0] + w * right[2]
            if z <= 0:
                zmin = -1.0
                break
            zmin = min(zmin, z)
            tmin, tmax = min(tmin, lateral / z), max(tmax, lateral / z)
            mmax = max(mmax, y / z)
        if zmin <= depths[0] or tmin < tans[0] or tmax > tans[bands]:
            continue
        # Last slice that ends before the box's nearest depth.
        k = np.searchsorted(depths, zmin, side="right") - 2
        if k < 0:
            continue
        b0 = np.searchsorted(tans, tmin, side="right") - 1
        b1 = np.searchsorted(tans, tmax, side="left") - 1
        hidden = True
        for b in range(max(b0, 0), min(b1, bands - 1) + 1):
            if not values[b, k] > mmax:
                hidden = False
                break
        out[n] = hidden
    return out


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


@njit(cache=True)
def _cast_fixed(flat, offsets, sizes, spacing, eye, forward, right, tans, depths, lower, horizon):
    """_cast in 16.16 raw integers: horizon[b, k] a lower bound of every ground slope in band b
    up to slice k (-SLOPE_LIMIT - 1: nothing yet)."""
    bands = tans.shape[0] - 1
    slices = depths.shape[0] - 1
    cells = sizes[0]
    nothing = -SLOPE_LIMIT - 1
    tmax = max(abs(tans[0]), abs(tans[bands]))
    for b in range(bands):
        best = nothing
        for k in range(slices):
            z0, z1 = depths[k], depths[k + 1]
            xmin, xmax, wmin, wmax = 1 << 60, -(1 << 60), 1 << 60, -(1 << 60)
            for z in (z0, z1):
                for t in (tans[b], tans[b + 1]):
                    tz = _fmul(t, z)
                    x = eye[0] + _fmul(forward[0], z) + _fmul(right[0], tz)
                    w = eye[2] + _fmul(forward[2], z) + _fmul(right[2], tz)
                    xmin, xmax = min(xmin, x), max(xmax, x)
                    wmin, wmax = min(wmin, w), max(wmax, w)
            # Rounding of the three products (< 1 quantum each, and t z's error times |right|)
            # plus the frame's departure from orthonormal (2^-14 of the piece's reach).
            margin = 8 + ((z1 + _fmul(tmax, z1)) >> 14)
            j0 = (xmin - margin) // spacing
            j1 = (xmax + margin) // spacing
            i0 = (wmin - margin) // spacing
            i1 = (wmax + margin) // spacing
            if j1 < 0 or i1 < 0 or j0 >= cells or i0 >= cells:
                horizon[b, k] = best
                continue
            if j0 < 0 or i0 < 0 or j1 >= cells or i1 >= cells:
                horizon[b, k] = best
                continue
            low = _lowest_in(flat, offsets, sizes, i0, i1, j0, j1, 1 << 60)
            rise = low - lower - eye[1]
            slope = _fdiv_floor(rise, z1) if rise > 0 else _fdiv_floor(rise, z0)
            slope = min(max(slope, nothing), SLOPE_LIMIT)
            best = max(best, slope)
            horizon[b, k] = best


@njit(cache=True)
def _hidden_fixed(boxes, eye, forward, right, tans, depths, values):
    """_hidden in 16.16 raw integers (boxes (K, 2, 3) raw, low corner floored, high ceiled)."""
    out = np.zeros(boxes.shape[0], dtype=np.bool_)
    bands = tans.shape[0] - 1
    for n in range(boxes.shape[0]):
        zmin, tmin, tmax, mmax = 1 << 60, 1 << 60, -(1 << 60), -(1 << 60)
        behind = False
        for c in range(8):
            x = boxes[n, (c >> 0) & 1, 0] - eye[0]
            y = boxes[n, (c >> 1) & 1, 1] - eye[1]
            w = boxes[n, (c >> 2) & 1, 2] - eye[2]
            z_lo = _fmul(x, forward[0]) + _fmul(w, forward[2])  # exact value < z_lo + 2
            l_lo = _fmul(x, right[0]) + _fmul(w, right[2])
            z_hi, l_hi = z_lo + 2, l_lo + 2
            if z_lo <= 0:
                behind = True
                break
            zmin = min(zmin, z_lo)
            tmin = min(tmin, _fdiv_floor(l_lo, z_hi if l_lo >= 0 else z_lo))
            tmax = max(tmax, _fdiv_ceil(l_hi, z_lo if l_hi >= 0 else z_hi))
            mmax = max(mmax, _fdiv_ceil(y, z_lo if y >= 0 else z_hi))
        if behind or mmax >= SLOPE_LIMIT:
            continue
        if zmin <= depths[0] or tmin < tans[0] or tmax > tans[bands]:
            continue
        k = np.searchsorted(depths, zmin, side="right") - 2
        if k < 0:
            continue
        b0 = np.searchsorted(tans, tmin, side="right") - 1
        b1 = np.searchsorted(tans, tmax, side="left") - 1
        need = mmax + ((ONE + abs(mmax)) >> 14) + 1
        hidden = True
        for b in range(max(b0, 0), min(b1, bands - 1) + 1):
            if not values[b, k] > need:
                hidden = False
                break
        out[n] = hidden
    return out


@dataclass
class FixedHorizon:
    """One frame's horizon in 16.16 (raw int64 values of int32 quantities; see Horizon)."""

    eye: np.ndarray
    forward: np.ndarray
    right: np.ndarray
    tans: np.ndarray
    depths: np.ndarray
    values: np.ndarray
    limit: float

    def hidden(self, boxes) -> np.ndarray:
        """(K,) bool: box (K, 2, 3) entirely hidden by the ground (errs visible; boxes beyond
        the 16.16 range are never hidden)."""
        boxes = np.asarray(boxes, dtype=np.float64).reshape(-1, 2, 3)
        inside = (np.abs(boxes) <= self.limit).all(axis=(1, 2))
        raw = np.empty(boxes.shape, np.int64)
        raw[:, 0] = np.floor(np.clip(boxes[:, 0], -self.limit, self.limit) * ONE)
        raw[:, 1] = np.ceil(np.clip(boxes[:, 1], -self.limit, self.limit) * ONE)
        out = _hidden_fixed(raw, self.eye, self.forward, self.right, self.tans, self.depths,
                            self.values)
        return out & inside


class HorizonCaster:
    """Casts horizons of one heightmap (min-mip built once).

    arithmetic: "float64", or "fixed16.16" for the device's 16.16 integers (fixed16.16
    profiles: HorizonCaster.for_profile); the map, its heights and the far plane must then lie
    within +-FIXED_LIMIT (ProfileError otherwise).
    """

    def __init__(self, heightmap, bands: int = 120, step: float = 0.01,
                 arithmetic: str = "float64"):
        if arithmetic not in ("float64", "fixed16.16"):
            raise ValueError(f"arithmetic must be float64 or fixed16.16, got {arithmetic!r}")
        self.heightmap = heightmap
        self.bands = bands
        self.step = step
        self.arithmetic = arithmetic
        self.flat, self.offsets, self.sizes = pack(min_mip(heightmap.heights))
        if arithmetic == "fixed16.16":
            from ..profile import to_fixed

            to_fixed(heightmap.bounds(), f"terrain {heightmap.name}")  # range check
            self.flat_raw = np.floor(self.flat * ONE).astype(np.int64)

    @classmethod
    def for_profile(cls, heightmap, profile, bands: int = 120, step: float = 0.01):
        """The caster in the profile's arithmetic (fixed16.16 when its vertex format is)."""
        return cls(heightmap, bands, step, "fixed16.16" if profile.fixed else "float64")

    def cast(self, camera, lower: float = 0.0, far: float | None = None) -> Horizon:
        """Horizon for camera's eye over the horizontal span of its frustum.

        lower : world units to sink the ground (a drawn LOD's vertical error)
        """
        eye = camera.eye
        if not (0 <= eye[0] <= self.heightmap.extent and 0 <= eye[2] <= self.heightmap.extent) \
                or eye[1] < float(self.heightmap.height_at(eye[0], eye[2])):
            # Off the map or under the ground: the ground-as-solid argument does not hold.
            return Horizon(eye, np.array([0.0, 0, -1]), np.array([1.0, 0, 0]),
                           np.array([-1.0, 1.0]), np.array([1.0, 2.0]), np.full((1, 1), -np.inf))
        yaw = np.radians(camera.yaw)
        forward = np.array([-np.sin(yaw), 0.0, -np.cos(yaw)])
        right = np.array([np.cos(yaw), 0.0, -np.sin(yaw)])
        # Horizontal span: the frustum's corner directions in level-camera terms.
        r, u, f = camera.basis()
        ty = np.tan(np.radians(camera.fov) / 2)
        tx = ty * camera.aspect
        corners = np.array([f + sx * tx * r + sy * ty * u for sx in (-1, 1) for sy in (-1, 1)])
        depth = corners @ forward
        lateral = corners @ right
        ok = depth > 1e-6
        span = np.abs(lateral[ok] / depth[ok]).max() * 1.01 if ok.all() else 4.0
        tans = np.linspace(-span, span, self.bands + 1)
        far = far if far is not None else camera.far
        near = max(camera.near, 0.5 * self.heightmap.spacing)
        count = int(np.ceil(np.log(far / near) / np.log1p(self.step)))
        depths = near * (1 + self.step) ** np.arange(count + 1)
        if self.arithmetic == "fixed16.16":
            return self._cast_fixed(eye, forward, right, tans, depths, lower)
        values = np.empty((self.bands, count))
        _cast(self.flat, self.offsets, self.sizes, self.heightmap.spacing, eye, forward, right,
              tans, depths, float(lower), values)
        return Horizon(eye, forward, right, tans, depths, values)

    def _cast_fixed(self, eye, forward, right, tans, depths, lower) -> FixedHorizon:
        from ..profile import FIXED_LIMIT, to_fixed

        depths = depths[depths <= FIXED_LIMIT]
        raw = [to_fixed(a, "horizon").astype(np.int64) for a in (eye, forward, right, tans, depths)]
        tans_raw = np.unique(raw[3])
        depths_raw = np.unique(raw[4])
        lower_raw = int(np.ceil(float(lower) * ONE))
        spacing_raw = int(round(self.heightmap.spacing * ONE))
        if spacing_raw / ONE != self.heightmap.spacing:
            # The mip blocks' indices need the exact spacing: a coarser one would misplace them.
            from ..errors import ProfileError

            raise ProfileError(f"terrain {self.heightmap.name}: spacing "
                               f"{self.heightmap.spacing:g} is not a 16.16 number")
        values = np.empty((len(tans_raw) - 1, len(depths_raw) - 1), np.int64)
        _cast_fixed(self.flat_raw, self.offsets, self.sizes, spacing_raw, raw[0], raw[1],
                    raw[2], tans_raw, depths_raw, lower_raw, values)
        return FixedHorizon(raw[0], raw[1], raw[2], tans_raw, depths_raw, values, FIXED_LIMIT)

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

Only drawn ground occludes (issue 30). The near plane clips a hole in ground closer than it,
and the GPU shows what is behind the hole (the hill's far side seen from inside, objects'
buried bases), so a ray is counted hidden only when (1) it passes below the ground in a slice
that lies wholly beyond zclip, the largest level depth of the near rectangle (every frustum
point the near plane clips has a smaller level depth), and (2) it is above the ground where it
crosses the near plane: its slope beats, per band, the ceiling, the highest ground slope over
the slices before zclip (max-mip, raised by `lower`) and, before the first slice, a bound from
the ground under the eye and the steepest cell gradient around it. Then the ray crosses the
ground downward between the near plane and the blocking slice: that front face is drawn, and
the tile holding it is never hidden itself (its own ray would need an earlier crossing). A box
is hidden when its lowest corner slope beats the ceiling of its bands and its highest is
beaten by the horizon.

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

from dataclasses import dataclass, field

import numpy as np
from numba import njit

from .horizon_mips import (_highest_in, _lowest_in, cell_gradients,  # noqa: F401
                           max_mip, max_mip_cells, min_mip, pack)
from .horizon_bands import bands_hide, level_bands, no_stops, stops_raw  # noqa: F401
from .horizon_fixed import (ONE, SLOPE_LIMIT, _fdiv_ceil, _fdiv_floor, _fmul,  # noqa: F401
                            _hidden_fixed, hidden_one_fixed)


@njit(cache=True)
def _cast(flat, offsets, sizes, spacing, eye, forward, right, tans, depths, lower, horizon,
          high_flat, zclip, ceiling, bflat, bases, top, stop_high, stop_low):
    """horizon[b, k]: running max over slices <= k wholly beyond zclip of the lowest slope in
    band b, slice k; ceiling[b] (in: the bound before the first slice) raised to the highest
    ground slope over the slices starting before zclip. Solids with a bottom (bflat: min-mip
    of the negated per-cell bases; empty for a ground): bases[b, k] the highest base slope of
    the piece that set horizon[b, k], which a hidden ray must beat too. top: the highest solid
    anywhere (+inf: unknown). A band stops early (its later values stay, a lower bound of the
    full cast's, so any stop is safe) once its horizon beats every later solid slope or
    stop_high[b] (the frustum's highest slope in the band: all it shows beyond is hidden), or
    once every later solid slope is below stop_low[b] (the frustum's lowest: nothing more
    can be hidden); +inf / -inf: no such stop. Returns the pieces cast (before the stops)."""
    bands = tans.shape[0] - 1
    slices = depths.shape[0] - 1
    cells = sizes[0]
    bottoms = bflat.shape[0] > 0
    rise_top = top - eye[1]
    laters = np.empty(slices)  # the highest solid slope beyond each slice's start
    for k in range(slices):
        laters[k] = rise_top / depths[k] if rise_top > 0 else rise_top / depths[slices]
    cast = 0
    for b in range(bands):
        best = -np.inf
        bbest = -np.inf
        for k in range(slices):
            if bottoms:
                bases[b, k] = bbest
            z0, z1 = depths[k], depths[k + 1]
            later = laters[k]
            if z0 >= zclip and (best >= later or best >= stop_high[b] or later < stop_low[b]):
                for rest in range(k, slices):
                    horizon[b, rest] = best
                    if bottoms:
                        bases[b, rest] = bbest
                break
            cast += 1
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
            if z0 < zclip:
                # The near plane may clip this slice: its ground may not occlude, and a ray
                # must pass above all of it (the highest slope, drawn ground raised by lower).
                high = _highest_in(high_flat, offsets, sizes, i0, i1, j0, j1, -np.inf)
                rise = high + lower - eye[1]
                ceiling[b] = max(ceiling[b], rise / z0 if rise > 0 else rise / z1)
                horizon[b, k] = best
                continue
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
            if not bottoms:
                best = max(best, slope)
            elif slope > best:
                # Highest base slope over the slice's depths: the near end when above the eye.
                brise = -_lowest_in(bflat, offsets, sizes, i0, i1, j0, j1, np.inf) - eye[1]
                bslope = brise / z0 if brise > 0 else brise / z1
                if bslope < slope:
                    best, bbest = slope, bslope
                    bases[b, k] = bbest
            horizon[b, k] = best
    return cast


# A ground goes down without end: no bottoms to pass above.
NO_BOTTOMS, NO_BOTTOMS_RAW = np.zeros(0), np.zeros(0, np.int64)
NO_BASES, NO_BASES_RAW = np.zeros((0, 0)), np.zeros((0, 0), np.int64)


@dataclass
class Horizon:
    """One frame's horizon.

    eye      : (3,) float64
    forward, right : (3,) float64 level camera axes (y = 0)
    tans     : (B+1,) float64 band edges as tan of the horizontal angle
    depths   : (S+1,) float64 slice boundaries along forward
    values   : (B, S) float64 running max of lowest slopes (-inf: nothing yet)
    ceiling  : (B,) float64 a ray hidden in band b must have a slope above ceiling[b] (it then
               passes above the ground where the near plane cuts it); +inf: nothing hidden
    bases    : (B, S) float64 a hidden ray's slope must also beat bases[b, k] (solids with a
               bottom: it passes above it), or (0, 0) for a ground
    origin   : (3,) float64 the map's origin: boxes are taken relative to it (eye already is)
    clamp    : True when every frustum ray lies within the bands (tans): the parts of a box
               beyond them are outside the frustum, so only the bands it meets are tested
    """

    eye: np.ndarray
    forward: np.ndarray
    right: np.ndarray
    tans: np.ndarray
    depths: np.ndarray
    values: np.ndarray
    ceiling: np.ndarray
    bases: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    origin: np.ndarray = field(default_factory=lambda: np.zeros(3))
    clamp: bool = False
    pieces: int = -1  # bands x slices the cast read (-1: not counted)

    @classmethod
    def nothing(cls, eye) -> "Horizon":
        """A horizon that hides nothing (the ground's or the solids' argument does not hold for
        this eye)."""
        return cls(np.asarray(eye, dtype=np.float64), np.array([0.0, 0, -1]),
                   np.array([1.0, 0, 0]), np.array([-1.0, 1.0]), np.array([1.0, 2.0]),
                   np.full((1, 1), -np.inf), np.full(1, np.inf), pieces=0)

    def hidden(self, boxes) -> np.ndarray:
        """(K,) bool: box (K, 2, 3) entirely hidden by drawn ground (errs visible)."""
        boxes = np.asarray(boxes, dtype=np.float64).reshape(-1, 2, 3)
        return self.hidden_points(box_corners(boxes))

    def hidden_points(self, points, grow: float = 0.0) -> np.ndarray:
        """(K,) bool: the convex hull of points (K, C, 3), each grown to a cube of half-side
        grow, entirely hidden (errs visible)."""
        points = np.asarray(points, dtype=np.float64) - self.origin
        return _hidden(points, self.eye, self.forward, self.right, self.tans, self.depths,
                       self.values, self.ceiling, self.bases, self.clamp, float(grow))


def box_corners(boxes) -> np.ndarray:
    """(K, 8, 3) corners of boxes (K, 2, 3); corner c takes the high side on axis j when bit j
    of c is set."""
    return boxes[:, CORNER_BITS, AXES]


CORNER_BITS = (np.arange(8)[:, None] >> np.arange(3)[None, :]) & 1  # (8, 3)
AXES = np.arange(3)[None, :]


@njit(cache=True)
def _hidden(points, eye, forward, right, tans, depths, values, ceiling, bases, clamp,
            grow=0.0):
    """(K,) bool: the convex hull of points (K, C, 3) (a box's 8 corners, a triangle's 3), each
    grown to a cube of half-side grow, lies wholly behind the horizon: a linear-fractional
    slope peaks at a hull vertex. A grown point is taken as the box of its cube's moves in the
    level frame (depth and lateral by grow (|a_x| + |a_z|) for the axis a, height by grow):
    its slopes' extremes lie at that box's corners, so each bound is its corner's ratio."""
    out = np.zeros(points.shape[0], dtype=np.bool_)
    origin = np.zeros(3)
    for n in range(points.shape[0]):
        out[n] = hidden_one(points[n], origin, eye, forward, right, tans, depths, values,
                            ceiling, bases, clamp, grow)
    return out


@njit(cache=True, inline="always")
def hidden_one(points, origin, eye, forward, right, tans, depths, values, ceiling, bases,
               clamp, grow):
    """_hidden for one hull of points (C, 3), taken relative to origin (3,) first."""
    dz = grow * (abs(forward[0]) + abs(forward[2]))
    dl = grow * (abs(right[0]) + abs(right[2]))
    zmin, tmin, tmax, mmin, mmax = np.inf, np.inf, -np.inf, np.inf, -np.inf
    for q in range(points.shape[0]):
        x = (points[q, 0] - origin[0]) - eye[0]
        y = (points[q, 1] - origin[1]) - eye[1]
        w = (points[q, 2] - origin[2]) - eye[2]
        z = x * forward[0] + w * forward[2]
        lateral = x * right[0] + w * right[2]
        z_lo, z_hi = z - dz, z + dz
        if z_lo <= 0:
            return False
        zmin = min(zmin, z_lo)
        l_lo, l_hi, y_lo, y_hi = lateral - dl, lateral + dl, y - grow, y + grow
        tmin = min(tmin, l_lo / (z_hi if l_lo >= 0 else z_lo))
        tmax = max(tmax, l_hi / (z_lo if l_hi >= 0 else z_hi))
        mmin = min(mmin, y_lo / (z_hi if y_lo >= 0 else z_lo))
        mmax = max(mmax, y_hi / (z_lo if y_hi >= 0 else z_hi))
    return bands_hide(zmin, tmin, tmax, mmax, mmin, tans, depths, values, ceiling, bases, clamp)


@njit(cache=True)
def _cast_fixed(flat, offsets, sizes, spacing, eye, forward, right, tans, depths, lower, horizon,
                high_flat, zclip, ceiling, bflat, bases, top, stop_high, stop_low):
    """_cast in 16.16 raw integers: horizon[b, k] a lower bound of every drawn ground slope in
    band b up to slice k (-SLOPE_LIMIT - 1: nothing yet), ceiling[b] an upper bound of the
    ground slopes before zclip (SLOPE_LIMIT: everything), bases[b, k] an upper bound of the
    base slopes of the piece that set horizon[b, k] (bflat: raw floored negated bases);
    stop_high, stop_low as _cast's, raw."""
    bands = tans.shape[0] - 1
    slices = depths.shape[0] - 1
    cells = sizes[0]
    nothing = -SLOPE_LIMIT - 1
    tmax = max(abs(tans[0]), abs(tans[bands]))
    bottoms = bflat.shape[0] > 0
    rise_top = top - eye[1]
    laters = np.empty(slices, np.int64)
    for k in range(slices):
        laters[k] = (_fdiv_ceil(rise_top, depths[k]) if rise_top > 0 else
                     _fdiv_ceil(rise_top, depths[slices]))
    cast = 0
    for b in range(bands):
        best = nothing
        bbest = nothing
        for k in range(slices):
            if bottoms:
                bases[b, k] = bbest
            z0, z1 = depths[k], depths[k + 1]
            later = laters[k]
            if z0 >= zclip and (best >= later or best >= stop_high[b] or later < stop_low[b]):
                for rest in range(k, slices):
                    horizon[b, rest] = best
                    if bottoms:
                        bases[b, rest] = bbest
                break
            cast += 1
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
            if z0 < zclip:
                high = _highest_in(high_flat, offsets, sizes, i0, i1, j0, j1, -(1 << 60))
                if high > -(1 << 60):
                    rise = high + lower - eye[1]
                    up = _fdiv_ceil(rise, z0) if rise > 0 else _fdiv_ceil(rise, z1)
                    ceiling[b] = max(ceiling[b], min(max(up, nothing), SLOPE_LIMIT))
                horizon[b, k] = best
                continue
            if j1 < 0 or i1 < 0 or j0 >= cells or i0 >= cells:
                horizon[b, k] = best
                continue
            if j0 < 0 or i0 < 0 or j1 >= cells or i1 >= cells:
                horizon[b, k] = best
                continue
            low = _lowest_in(flat, offsets, sizes, i0, i1, j0, j1, 1 << 60)
            if low <= -(1 << 59):  # a cell of the piece has no solid (a map of objects)
                horizon[b, k] = best
                continue
            rise = low - lower - eye[1]
            slope = _fdiv_floor(rise, z1) if rise > 0 else _fdiv_floor(rise, z0)
            slope = min(max(slope, nothing), SLOPE_LIMIT)
            if not bottoms:
                best = max(best, slope)
            elif slope > best:
                high = -_lowest_in(bflat, offsets, sizes, i0, i1, j0, j1, 1 << 60)
                # Clamped: no base known (+big) stays beyond any slope, none (-big) below.
                brise = min(max(high, -(1 << 40)), 1 << 40) - eye[1]
                bslope = _fdiv_ceil(brise, z0) if brise > 0 else _fdiv_ceil(brise, z1)
                bslope = min(max(bslope, nothing), SLOPE_LIMIT)
                if bslope < slope:
                    best, bbest = slope, bslope
                    bases[b, k] = bbest
            horizon[b, k] = best
    return cast


@dataclass
class FixedHorizon:
    """One frame's horizon in 16.16 (raw int64 values of int32 quantities; see Horizon)."""

    eye: np.ndarray
    forward: np.ndarray
    right: np.ndarray
    tans: np.ndarray
    depths: np.ndarray
    values: np.ndarray
    ceiling: np.ndarray
    limit: float
    bases: np.ndarray = field(default_factory=lambda: np.zeros((0, 0), np.int64))
    origin: np.ndarray = field(default_factory=lambda: np.zeros(3))
    clamp: bool = False
    pieces: int = -1  # bands x slices the cast read (-1: not counted)

    def hidden(self, boxes) -> np.ndarray:
        """(K,) bool: box (K, 2, 3) entirely hidden by the ground (errs visible; boxes beyond
        the 16.16 range are never hidden)."""
        boxes = np.asarray(boxes, dtype=np.float64).reshape(-1, 2, 3) - self.origin
        inside = (np.abs(boxes) <= self.limit).all(axis=(1, 2))
        raw = np.empty(boxes.shape, np.int64)
        raw[:, 0] = np.floor(np.clip(boxes[:, 0], -self.limit, self.limit) * ONE)
        raw[:, 1] = np.ceil(np.clip(boxes[:, 1], -self.limit, self.limit) * ONE)
        out = _hidden_fixed(box_corners(raw), self.eye, self.forward, self.right, self.tans,
                            self.depths, self.values, self.ceiling, self.bases, self.clamp)
        return out & inside

    def hidden_points(self, points, grow: float = 0.0) -> np.ndarray:
        """(K,) bool: the hull of points (K, C, 3) entirely hidden; each point is taken as its
        cube of half-side grow rounded outward to 16.16 (8 corners), so the test errs visible."""
        points = np.asarray(points, dtype=np.float64)
        k, c = points.shape[:2]
        flat = (np.repeat(points.reshape(-1, 1, 3), 2, axis=1) + np.array([-grow, grow])[:, None]
                - self.origin)
        inside = (np.abs(flat) <= self.limit).all(axis=(1, 2)).reshape(k, c).all(axis=1)
        raw = np.empty(flat.shape, np.int64)
        raw[:, 0] = np.floor(np.clip(flat[:, 0], -self.limit, self.limit) * ONE)
        raw[:, 1] = np.ceil(np.clip(flat[:, 1], -self.limit, self.limit) * ONE)
        corners = box_corners(raw).reshape(k, c * 8, 3)
        out = _hidden_fixed(corners, self.eye, self.forward, self.right, self.tans, self.depths,
                            self.values, self.ceiling, self.bases, self.clamp)
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
        self.high_flat = pack(max_mip(heightmap.heights))[0]
        self.gradient_mip = pack(max_mip_cells(cell_gradients(heightmap.heights,
                                                              heightmap.spacing)))[0]
        if arithmetic == "fixed16.16":
            from ..device.profile import to_fixed

            to_fixed(heightmap.bounds(), f"terrain {heightmap.name}")  # range check
            self.flat_raw = np.floor(self.flat * ONE).astype(np.int64)
            self.high_flat_raw = np.ceil(self.high_flat * ONE).astype(np.int64)

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
            return Horizon.nothing(eye)
        forward, right, tans, deepest, clamp = level_bands(camera, self.bands)
        span = tans[-1]
        far = far if far is not None else camera.far
        near = max(camera.near, 0.5 * self.heightmap.spacing)
        count = int(np.ceil(np.log(far / near) / np.log1p(self.step)))
        depths = near * (1 + self.step) ** np.arange(count + 1)
        # Largest level depth of the near rectangle: every point the near plane clips from
        # the frustum (the pyramid from the eye to that rectangle) lies at a smaller one.
        zclip = camera.near * float(deepest) * (1 + 1e-9)
        ceiling = np.full(self.bands, self._first_ceiling(eye, zclip, near, span, lower))
        if self.arithmetic == "fixed16.16":
            return self._cast_fixed(eye, forward, right, tans, depths, lower, zclip, ceiling)
        values = np.empty((self.bands, count))
        pieces = _cast(self.flat, self.offsets, self.sizes, self.heightmap.spacing, eye,
                       forward, right, tans, depths, float(lower), values, self.high_flat,
                       zclip, ceiling, NO_BOTTOMS, NO_BASES, np.inf, *no_stops(self.bands))
        return Horizon(eye, forward, right, tans, depths, values, ceiling, pieces=pieces)

    def _first_ceiling(self, eye, zclip, first, span, lower) -> float:
        """Slope a ray must beat to pass above the ground at every level depth z <= z1 =
        min(zclip, first slice) (the near plane crosses it there when not in a slice): with
        g0 the ground under the eye and G the steepest cell gradient within z1 sqrt(1 + span^2),
        the ground at z is at most g0 + lower + G z sqrt(1 + span^2), so
        m > G sqrt(1 + span^2) - (eye_y - g0 - lower) / z1 suffices; +inf when the eye is not
        above the (raised) ground."""
        hm = self.heightmap
        z1 = min(zclip, first)
        g0 = max(float(hm.height_at(eye[0], eye[2])),
                 float(hm.height_at(eye[0], eye[2], alternating=True)))
        clear = eye[1] - g0 - float(lower)
        if not clear > 0:
            return np.inf
        reach = z1 * np.sqrt(1 + span * span)
        i0, i1 = (int(np.floor((eye[2] + s * reach) / hm.spacing)) for s in (-1, 1))
        j0, j1 = (int(np.floor((eye[0] + s * reach) / hm.spacing)) for s in (-1, 1))
        steep = _highest_in(self.gradient_mip, self.offsets, self.sizes, i0, i1, j0, j1, 0.0)
        return steep * np.sqrt(1 + span * span) - clear / z1

    def _cast_fixed(self, eye, forward, right, tans, depths, lower, zclip,
                    first_ceiling) -> FixedHorizon:
        from ..device.profile import FIXED_LIMIT, to_fixed

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
        # The first ceiling is found in float64 (a few operations per frame) and rounded up
        # with a margin of 2^-14 of its size plus 4 quanta (the eye's rounding).
        start = float(first_ceiling[0])
        if np.isfinite(start) and abs(start) < SLOPE_LIMIT / ONE / 2:
            start_raw = int(np.ceil(start * ONE)) + ((ONE + abs(int(start * ONE))) >> 14) + 4
        else:
            start_raw = SLOPE_LIMIT if not start < 0 else -SLOPE_LIMIT - 1
        ceiling = np.full(len(tans_raw) - 1, start_raw, np.int64)
        zclip_raw = int(np.ceil(zclip * ONE)) + 2
        pieces = _cast_fixed(self.flat_raw, self.offsets, self.sizes, spacing_raw, raw[0],
                             raw[1], raw[2], tans_raw, depths_raw, lower_raw, values,
                             self.high_flat_raw, zclip_raw, ceiling, NO_BOTTOMS_RAW,
                             NO_BASES_RAW, 1 << 40, *stops_raw(*no_stops(len(tans_raw) - 1)))
        return FixedHorizon(raw[0], raw[1], raw[2], tans_raw, depths_raw, values, ceiling,
                            FIXED_LIMIT, pieces=pieces)

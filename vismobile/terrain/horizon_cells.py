"""The floating horizon over any map of solid columns: the terrain horizon's caster and test
(horizon.py: the same kernels, float64 and 16.16) run on a square grid of cells that hold,
each, a column of solid: a lower bound of its top over the whole cell (tops, -inf where no
cell-wide solid is known), an upper bound of its top wherever a solid touches the cell (highs,
the near plane's ceiling), and an upper bound of its bottom (bases; none for a ground that goes
down without end). Object worlds fill it from buildings, walls and grounds found in their
geometry (culling/horizon_solids.py); a heightmap is the case with no bottoms.

A ray is hidden when, in its band, a slice wholly beyond the near plane's reach holds solid
above and below it along its whole width (horizon.py's values and bases) and the ray passes
above every solid near the eye (the ceiling): it then enters that solid through a drawn face
between the near plane and the slice.
"""
from __future__ import annotations

import numpy as np

from .horizon import (NO_BASES, NO_BASES_RAW, ONE, SLOPE_LIMIT, FixedHorizon, Horizon, _cast,
                      _cast_fixed)
from .horizon_bands import frame_bands, frustum_slopes, stops_raw
from .horizon_mips import _highest_in, pack, pyramid

NOTHING_RAW = -(1 << 60)  # raw "no solid" (below every 16.16 value)


def _raw(values, rounding) -> np.ndarray:
    """16.16 raw int64 of finite values (rounded by `rounding`), NOTHING_RAW for -inf and
    -NOTHING_RAW / 2 for +inf."""
    finite = np.isfinite(values)
    out = np.where(finite, rounding(np.where(finite, values, 0.0) * ONE), NOTHING_RAW)
    return np.where(values == np.inf, -NOTHING_RAW // 2, out).astype(np.int64)


class CellCaster:
    """Casts horizons over a map of solid columns (mips built once).

    tops    : (n, n) float64, n a power of two, row i along z and column j along x: a lower
              bound of the solid's top over the whole cell, -inf where none covers it
    highs   : (n, n) float64 an upper bound of every solid's top touching the cell (-inf: none)
    bases   : (n, n) float64 an upper bound of the bottom of the solid of `tops`, or None when
              every solid goes down without end (a ground)
    origin  : (x, z) of the map's low corner; spacing: cell size. In fixed16.16 both must be
              16.16 numbers and the map within +-FIXED_LIMIT (ProfileError otherwise).
    Contract (the caller's claim: each column is solid between its base and top, bounded by
    drawn faces that face out): a box hidden(...) calls hidden is seen by no pixel; every bound
    and rounding errs toward visible.
    """

    def __init__(self, tops, highs, bases=None, origin=(0.0, 0.0), spacing: float = 1.0,
                 bands: int = 120, step: float = 0.01, arithmetic: str = "float64",
                 name: str = "map"):
        if arithmetic not in ("float64", "fixed16.16"):
            raise ValueError(f"arithmetic must be float64 or fixed16.16, got {arithmetic!r}")
        tops = np.asarray(tops, dtype=np.float64)
        n = tops.shape[0]
        if tops.shape != (n, n) or n < 1 or n & (n - 1) or np.shape(highs) != tops.shape:
            raise ValueError(f"horizon maps must be square with a power-of-two side, got "
                             f"{tops.shape}")
        self.bands, self.step, self.arithmetic, self.name = bands, step, arithmetic, name
        self.spacing = float(spacing)
        self.origin = np.array([origin[0], 0.0, origin[1]], dtype=np.float64)
        self.flat, self.offsets, self.sizes = pack(pyramid(tops, np.min))
        self.high_flat = pack(pyramid(highs, np.max))[0]
        self.top = float(self.high_flat[-1])  # the highest solid (the pyramid's root)
        self.bflat = (np.zeros(0) if bases is None else
                      pack(pyramid(-np.asarray(bases, dtype=np.float64), np.min))[0])
        if arithmetic == "fixed16.16":
            from ..errors import ProfileError
            from ..device.profile import to_fixed

            to_fixed(np.array([self.origin, self.origin + n * self.spacing]), f"{name} map")
            for values in (self.flat, self.high_flat, self.bflat):
                to_fixed(values[np.isfinite(values)], f"{name} heights")  # range check
            for value, what in ((self.spacing, "spacing"), (origin[0], "origin"),
                                (origin[1], "origin")):
                if round(value * ONE) / ONE != value:
                    # The mip blocks' indices need exact numbers: rounding would misplace them.
                    raise ProfileError(f"{name}: {what} {value:g} is not a 16.16 number")
            self.flat_raw = _raw(self.flat, np.floor)
            self.high_flat_raw = _raw(self.high_flat, np.ceil)
            self.bflat_raw = _raw(self.bflat, np.floor)

    def nothing(self, eye) -> Horizon:
        """A horizon that hides nothing (the solids' argument does not hold for this eye)."""
        return Horizon.nothing(eye)

    def cast(self, camera, far: float | None = None):
        """Horizon (FixedHorizon in fixed16.16) for camera's eye over the horizontal span of
        its frustum, slices from the first cell's reach to `far` (default the camera's, cut to
        the map's reach)."""
        eye = np.asarray(camera.eye, dtype=np.float64)
        local = eye - self.origin
        forward, right, tans, deepest, clamp, highs, lows = frame_bands(camera, self.bands)
        span = tans[-1]
        size = self.sizes[0] * self.spacing
        reach = float(np.hypot(max(abs(local[0]), abs(local[0] - size)),
                               max(abs(local[2]), abs(local[2] - size))))
        far = min(far if far is not None else camera.far, reach)
        depths = self._slices_to(max(camera.near, self.spacing), camera.far, far)
        if len(depths) < 2:
            return self.nothing(eye)
        near, count = depths[0], len(depths) - 1
        # Largest level depth of the near rectangle (horizon.py): slices before it only
        # raise the ceiling.
        zclip = camera.near * float(deepest) * (1 + 1e-9)
        first = self._first_ceiling(local, min(zclip, near), span)
        if self.arithmetic == "fixed16.16":
            return self._cast_fixed(camera, local, forward, right, tans, depths, zclip, first,
                                    clamp)
        values = np.empty((self.bands, count))
        bases = np.empty((self.bands, count)) if len(self.bflat) else NO_BASES
        ceiling = np.full(self.bands, first)
        pieces = _cast(self.flat, self.offsets, self.sizes, self.spacing, local, forward, right,
                       tans, depths, 0.0, values, self.high_flat, zclip, ceiling, self.bflat,
                       bases, self.top, highs, lows)
        return Horizon(local, forward, right, tans, depths, values, ceiling, bases, self.origin,
                       clamp, pieces)

    def slices(self, near: float, far: float) -> np.ndarray:
        """Slice boundaries from near to far: one cell thick while step z is thinner (finer
        slices would see the same cells), then growing by 1 + step."""
        if not far > near:
            return np.zeros(0)
        turn = min(max(self.spacing / self.step, near), far)
        linear = near + self.spacing * np.arange(int(np.ceil((turn - near) / self.spacing)) + 1)
        start = linear[-1]
        count = max(0, int(np.ceil(np.log(max(far, start) / start) / np.log1p(self.step))))
        return np.concatenate([linear, start * (1 + self.step) ** np.arange(1, count + 1)])

    def _slices_to(self, near: float, deepest: float, far: float) -> np.ndarray:
        """slices(near, far) for far <= deepest, cut from slices(near, deepest) (kept per
        near and deepest: the same values, without the per-frame powers)."""
        if not far > near:
            return np.zeros(0)
        cache = self.__dict__.setdefault("_slice_cache", {})
        full = cache.get((near, deepest))
        if full is None:
            if len(cache) > 8:
                cache.clear()
            full = cache[(near, deepest)] = self.slices(near, deepest)
        if not far < deepest:
            return full
        return full[:int(np.searchsorted(full, far, side="left")) + 1]

    def _first_ceiling(self, local, z1, span) -> float:
        """Slope a ray must beat to pass above every solid within level depth z1 of the eye
        (before the first slice): -inf when no solid touches the cells within z1 sqrt(1 +
        span^2), (top - eye) / z1 when all of them are below the eye, +inf (nothing hidden)
        when one reaches the eye's height (the eye may be inside it)."""
        reach = z1 * np.sqrt(1 + span * span)
        i0, i1 = (int(np.floor((local[2] + s * reach) / self.spacing)) for s in (-1, 1))
        j0, j1 = (int(np.floor((local[0] + s * reach) / self.spacing)) for s in (-1, 1))
        top = _highest_in(self.high_flat, self.offsets, self.sizes, i0, i1, j0, j1, -np.inf)
        rise = top - local[1]
        if rise == -np.inf:
            return -np.inf
        return rise / z1 if rise < 0 else np.inf

    def _cast_fixed(self, camera, local, forward, right, tans, depths, zclip, first,
                    clamp) -> FixedHorizon:
        from ..device.profile import FIXED_LIMIT, to_fixed

        depths = depths[depths <= FIXED_LIMIT]
        raw = [to_fixed(a, "horizon").astype(np.int64)
               for a in (local, forward, right, tans, depths)]
        tans_raw, depths_raw = np.unique(raw[3]), np.unique(raw[4])
        shape = (len(tans_raw) - 1, len(depths_raw) - 1)
        values = np.empty(shape, np.int64)
        bases = np.empty(shape, np.int64) if len(self.bflat) else NO_BASES_RAW
        # The first ceiling is found in float64 and rounded up with a margin of 2^-14 of its
        # size plus 4 quanta (the eye's rounding), as the terrain's.
        if np.isfinite(first) and abs(first) < SLOPE_LIMIT / ONE / 2:
            start = int(np.ceil(first * ONE)) + ((ONE + abs(int(first * ONE))) >> 14) + 4
        else:
            start = SLOPE_LIMIT if not first < 0 else -SLOPE_LIMIT - 1
        ceiling = np.full(shape[0], start, np.int64)
        bflat = self.bflat_raw if len(self.bflat) else np.zeros(0, np.int64)
        pieces = _cast_fixed(
            self.flat_raw, self.offsets, self.sizes, int(round(self.spacing * ONE)), raw[0],
            raw[1], raw[2], tans_raw, depths_raw, 0, values, self.high_flat_raw,
            int(np.ceil(zclip * ONE)) + 2, ceiling, bflat, bases,
            int(self.high_flat_raw[-1]) if np.isfinite(self.top) else 1 << 40,
            *stops_raw(*frustum_slopes(camera, forward, right, tans_raw / ONE)))
        return FixedHorizon(raw[0], raw[1], raw[2], tans_raw, depths_raw, values, ceiling,
                            FIXED_LIMIT, bases, self.origin, clamp, pieces)

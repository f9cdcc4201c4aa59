"""A terrain's ground as the occluder of the `horizon` culling stage (culling/horizon.py).

A terrain world played with a LOD method (app/terrain_scene.py) culls its objects with the
engine's stages; the horizon stage then casts Szenberg's floating horizon over the heightmap
(terrain/horizon.py's HorizonCaster) instead of looking for solids in the objects' geometry.

The drawn ground is the LOD's, not the samples': each drawn piece with nested vertical error E
(world units) whose box lies at distance d from the eye satisfies lambda_b E / d <= P, P the
frame's error bound in pixels (the scene measures it over the drawn pieces, so it holds even
where a piece exceeds tau). A drawn point p then lies within c |p - eye| of the full-resolution
ground vertically, c = P / lambda_b. In the horizon's slope terms (slope m = (h - eye_y) / z at
level depth z, lateral offset within span z, so |p - eye| <= z sqrt(1 + span^2 + m^2)), the
drawn ground's slope is at least f(m) = m - c sqrt(1 + span^2 + m^2) and at most
g(m) = m + c sqrt(1 + span^2 + m^2). Both are increasing in m for c < 1, so the running maximum
of f over the slices is f of the running maximum: the cast horizon's values are sunk by f and
its ceilings (the highest ground before the near plane's reach) raised by g, after the cast,
in float64 (rounded toward "visible" for the 16.16 horizon). Distant coarse pieces sink the
horizon by at most P pixels' worth of slope, where one world-unit lowering for the whole map
(the largest E) would sink it near the eye by more than the eye's height above the ground.
The float32 rounding of the drawn vertices (2^-22 of the largest coordinate) sinks the ground
as a world-unit lowering in the cast.

A terrain with no-data samples (holes) hides nothing: the view passes through a hole.

Contract: with `sink` = c set for the frame being culled, a box is hidden only when the drawn
ground hides it (HorizonCaster's contract, errs visible). One caster per arithmetic.
"""
from __future__ import annotations

import numpy as np


class TerrainGround:
    """heightmap: the terrain; sink: this frame's c = P / lambda_b (module doc)."""

    def __init__(self, heightmap, bands: int = 120, step: float = 0.01):
        self.heightmap = heightmap
        self.bands, self.step = int(bands), float(step)
        self.sink = 0.0
        self._casters = {}

    def caster(self, arithmetic: str = "float64"):
        """The caster of a Culler's arithmetic mode: 16.16 integers on fixed16.16, float64
        otherwise (float32 rounding is covered by the cast's lowering)."""
        from .horizon import HorizonCaster

        arithmetic = "fixed16.16" if arithmetic == "fixed16.16" else "float64"
        if arithmetic not in self._casters:
            self._casters[arithmetic] = HorizonCaster(self.heightmap, self.bands, self.step,
                                                      arithmetic)
        return self._casters[arithmetic]

    def cast(self, camera, arithmetic: str = "float64"):
        """This frame's Horizon (or FixedHorizon) of the drawn ground (module doc)."""
        hm = self.heightmap
        if hm.valid is not None:
            # A hole is cut (alpha test): the ground-as-solid argument fails through it, and
            # the casters' mips know no holes, so a terrain with holes hides nothing.
            from .horizon import Horizon

            return Horizon.nothing(camera.eye)
        scale = max(hm.extent, float(np.abs(hm.bounds()[:, 1]).max()))
        horizon = self.caster(arithmetic).cast(camera, scale * 2.0 ** -22)
        c = float(self.sink)
        if c == 0.0:
            return horizon
        if not 0.0 <= c < 0.5:  # nan, inf or a piece with no bound: hide nothing
            from .horizon import SLOPE_LIMIT

            fixed = horizon.ceiling.dtype.kind == "i"
            horizon.ceiling = np.full_like(horizon.ceiling, SLOPE_LIMIT if fixed else np.inf)
            return horizon
        return sunk(horizon, c)


def sunk(horizon, c: float):
    """The horizon with values sunk by f and ceilings raised by g (module doc), in place."""
    from .horizon import ONE, SLOPE_LIMIT

    fixed = horizon.values.dtype.kind == "i"
    tans = np.asarray(horizon.tans, dtype=np.float64) / (ONE if fixed else 1.0)
    span2 = 1.0 + float(np.abs(tans).max()) ** 2
    # Slack for the float64 arithmetic here: relative 1e-12 of the slope's size.
    if fixed:
        nothing = -SLOPE_LIMIT - 1
        v = horizon.values.astype(np.float64) / ONE
        f = v - c * np.sqrt(span2 + v * v) - 1e-12 * (1 + np.abs(v))
        raw = np.clip(np.floor(f * ONE), nothing, SLOPE_LIMIT).astype(np.int64)
        horizon.values = np.where(horizon.values <= nothing, horizon.values, raw)
        w = horizon.ceiling.astype(np.float64) / ONE
        g = w + c * np.sqrt(span2 + w * w) + 1e-12 * (1 + np.abs(w))
        up = np.clip(np.ceil(g * ONE), nothing, SLOPE_LIMIT).astype(np.int64)
        horizon.ceiling = np.where(horizon.ceiling >= SLOPE_LIMIT, horizon.ceiling, up)
        return horizon
    v = horizon.values
    with np.errstate(invalid="ignore"):
        f = v - c * np.sqrt(span2 + v * v) - 1e-12 * (1 + np.abs(v))
        horizon.values = np.where(np.isfinite(v), f, v)
        w = horizon.ceiling
        g = w + c * np.sqrt(span2 + w * w) + 1e-12 * (1 + np.abs(w))
        horizon.ceiling = np.where(np.isfinite(w), g, w)
    return horizon

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

A terrain with no-data samples (holes, seed 002): the renderers cut them with the alpha test,
midway between a valid and a no-data vertex, so a drawn triangle with a no-data corner may be
open anywhere over its extent (a coarse LOD triangle far from the hole's samples too), while a
triangle whose corners are all valid is drawn whole. The scene hands the frame's `cut` boxes:
the cells under every drawn piece (tile, Röttger leaf, ROAM triangle) with a no-data vertex.
The cast's argument is that a hidden ray, above the drawn ground where the near plane cuts it
and below it at the blocking slice, crossed the drawn surface on the way; through a cut it can
pass below the ground without crossing it. So each band is walked beyond the near plane's
reach: at the first slice piece that meets a cut box and whose highest drawn ground (max-mip
raised by the float32 lowering and by g) is not below the horizon already reached there, the
band's horizon stops rising (a ray hidden by the earlier slices crossed drawn ground before the
cut; a ray that the later slices would hide may pass below the ground inside it). A piece the
horizon already covers (every ray not yet hidden passes above its highest drawn ground) cannot
let a ray under, and the band goes on. Cut boxes are marked on a grid of at most 256^2 blocks
(summed-area table, one lookup per piece), which only widens them. Without `cut` boxes for the
frame a terrain with holes hides nothing.

Contract: with `sink` = c and `cut` set for the frame being culled, a box is hidden only when
the drawn ground hides it (HorizonCaster's contract, errs visible). One caster per arithmetic.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from .horizon_mips import _highest_in

CUT_GRID = 256  # largest side of the per-frame grid of cut blocks


class TerrainGround:
    """heightmap: the terrain; sink: this frame's c = P / lambda_b (module doc)."""

    def __init__(self, heightmap, bands: int = 120, step: float = 0.01):
        self.heightmap = heightmap
        self.bands, self.step = int(bands), float(step)
        self.sink = 0.0
        self.cut = None  # this frame's (K, 4) int64 cell boxes [i0, i1, j0, j1] (module doc)
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
        if hm.valid is not None and self.cut is None:
            from .horizon import Horizon

            return Horizon.nothing(camera.eye)  # no drawn pieces known: holes anywhere
        scale = max(hm.extent, float(np.abs(hm.bounds()[:, 1]).max()))
        lower = scale * 2.0 ** -22
        caster = self.caster(arithmetic)
        horizon = caster.cast(camera, lower)
        c = float(self.sink)
        if not 0.0 <= c < 0.5:  # nan, inf or a piece with no bound: hide nothing
            from .horizon import SLOPE_LIMIT

            fixed = horizon.ceiling.dtype.kind == "i"
            horizon.ceiling = np.full_like(horizon.ceiling, SLOPE_LIMIT if fixed else np.inf)
            return horizon
        if c > 0.0:
            horizon = sunk(horizon, c)
        if hm.valid is not None and len(self.cut) and horizon.pieces != 0:
            stop_at_cuts(horizon, camera, caster, self.cut, lower, c)
        return horizon


@njit(cache=True)
def _mark_blocks(grid, boxes, block, cells):
    """grid[bi, bj] = 1 for every block of `block` cells a box (K, 4) [i0, i1, j0, j1] meets."""
    for n in range(boxes.shape[0]):
        i0, i1 = max(boxes[n, 0], 0), min(boxes[n, 1], cells - 1)
        j0, j1 = max(boxes[n, 2], 0), min(boxes[n, 3], cells - 1)
        for bi in range(i0 // block, i1 // block + 1):
            for bj in range(j0 // block, j1 // block + 1):
                grid[bi, bj] = 1


def cut_table(boxes, cells) -> tuple:
    """(summed-area table (G+1, G+1) int64 of the blocks the boxes meet, block side in
    cells), G <= CUT_GRID."""
    block = 1
    while -(-cells // block) > CUT_GRID:
        block *= 2
    side = -(-cells // block)
    grid = np.zeros((side, side), np.int64)
    _mark_blocks(grid, np.asarray(boxes, np.int64).reshape(-1, 4), block, cells)
    table = np.zeros((side + 1, side + 1), np.int64)
    table[1:, 1:] = grid.cumsum(0).cumsum(1)
    return table, block


@njit(cache=True, inline="always")
def _piece(eye, forward, right, t0, t1, z0, z1, spacing, cells):
    """Cells (i0, i1, j0, j1) under the piece of the band [t0, t1] between depths z0 and z1,
    widened by a cell and clipped to the map (i0 > i1 when off it)."""
    xmin, xmax, wmin, wmax = np.inf, -np.inf, np.inf, -np.inf
    for z in (z0, z1):
        for t in (t0, t1):
            x = eye[0] + forward[0] * z + right[0] * t * z
            w = eye[2] + forward[2] * z + right[2] * t * z
            xmin, xmax = min(xmin, x), max(xmax, x)
            wmin, wmax = min(wmin, w), max(wmax, w)
    return (max(int(np.floor(wmin / spacing)) - 1, 0),
            min(int(np.floor(wmax / spacing)) + 1, cells - 1),
            max(int(np.floor(xmin / spacing)) - 1, 0),
            min(int(np.floor(xmax / spacing)) + 1, cells - 1))


@njit(cache=True, inline="always")
def _meets_cut(table, block, i0, i1, j0, j1):
    """Whether the cells i0..i1 x j0..j1 (on the map) meet a marked block."""
    a0, a1, c0, c1 = i0 // block, i1 // block + 1, j0 // block, j1 // block + 1
    return table[a1, c1] - table[a0, c1] - table[a1, c0] + table[a0, c0] > 0


GROUP = 16  # slices whose joint piece is looked up first: most of a map has no cut


@njit(cache=True)
def _stops(values, eye, forward, right, tans, depths, zclip, table, block, spacing,
           high_flat, offsets, sizes, lower, c, span2, slack):
    """Per band the first slice k whose piece (beyond zclip, widened by a cell) meets a cut
    block and whose highest drawn ground slope g(h) is not below values[b, k - 1] by the slack
    (-1: none). values (B, S) float64 slopes (-inf: nothing), non-decreasing along a band.
    GROUP slices at a time are skipped when their joint piece (the band between the group's
    depths, a convex quadrilateral holding each slice's piece) meets no cut."""
    bands, slices = values.shape
    cells = sizes[0]
    out = np.full(bands, -1, np.int64)
    for b in range(bands):
        final = values[b, slices - 1]
        t0, t1 = tans[b], tans[b + 1]
        k = 0
        while k < slices and out[b] < 0:
            if k > 0 and values[b, k - 1] >= final:
                break  # the band no longer rises: stopping it changes nothing
            end = min(k + GROUP, slices)
            if depths[end] < zclip:
                k = end  # the ceiling keeps hidden rays above these pieces
                continue
            i0, i1, j0, j1 = _piece(eye, forward, right, t0, t1, depths[k], depths[end],
                                    spacing, cells)
            if i0 > i1 or j0 > j1 or not _meets_cut(table, block, i0, i1, j0, j1):
                k = end
                continue
            for q in range(k, end):
                prev = values[b, q - 1] if q > 0 else -np.inf
                if prev >= final:
                    break
                z0, z1 = depths[q], depths[q + 1]
                if z0 < zclip:
                    continue
                i0, i1, j0, j1 = _piece(eye, forward, right, t0, t1, z0, z1, spacing, cells)
                if i0 > i1 or j0 > j1 or not _meets_cut(table, block, i0, i1, j0, j1):
                    continue  # off the map (no ground, nothing cast) or no cut
                rise = _highest_in(high_flat, offsets, sizes, i0, i1, j0, j1, -np.inf) \
                    + lower - eye[1]
                h = rise / z0 if rise > 0 else rise / z1
                g = h + c * np.sqrt(span2 + h * h) + slack * (1.0 + abs(h))
                if not prev - slack * (1.0 + abs(prev)) > g:
                    out[b] = q
                    break
            k = end
    return out


def stop_at_cuts(horizon, camera, caster, boxes, lower: float, c: float):
    """Stop each band's horizon at its first open cut (module doc), in place."""
    from .horizon import ONE, SLOPE_LIMIT
    from .horizon_bands import level_bands

    fixed = horizon.values.dtype.kind == "i"
    scale = float(ONE) if fixed else 1.0
    values = horizon.values.astype(np.float64) / scale
    nothing = -SLOPE_LIMIT - 1
    if fixed:
        values[horizon.values <= nothing] = -np.inf
    tans = np.asarray(horizon.tans, np.float64) / scale
    depths = np.asarray(horizon.depths, np.float64) / scale
    # The caster's zclip (terrain/horizon.py): its far slices are those with z0 >= zclip.
    zclip = camera.near * float(level_bands(camera, caster.bands)[3]) * (1 + 1e-9)
    span2 = 1.0 + float(np.abs(tans).max()) ** 2
    table, block = cut_table(boxes, caster.sizes[0])
    stops = _stops(values, np.asarray(horizon.eye, np.float64) / scale,
                   np.asarray(horizon.forward, np.float64) / scale,
                   np.asarray(horizon.right, np.float64) / scale, tans, depths, zclip, table,
                   block, caster.heightmap.spacing, caster.high_flat, caster.offsets,
                   caster.sizes, float(lower), float(c), span2,
                   2.0 ** -12 if fixed else 1e-12)
    for b in np.flatnonzero(stops >= 0):
        k = int(stops[b])
        horizon.values[b, k:] = horizon.values[b, k - 1] if k > 0 else \
            (nothing if fixed else -np.inf)
    return horizon


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

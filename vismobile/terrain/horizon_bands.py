"""The level camera's bands for the horizon casts (terrain/horizon.py, horizon_cells.py): its
axes, the band edges across the frustum, and per band the frustum's slope range, which lets a
band's cast stop early; and bands_hide, the last step of every horizon test."""
from __future__ import annotations

import numpy as np
from numba import njit

# Raw 16.16 stand-ins for "no stop" (beyond any slope the fixed kernels compare).
NO_STOP_RAW = 1 << 62


@njit(cache=True)
def _corners_of(yaw, pitch, fov, aspect):
    """(4, 3) frustum corner directions at unit view depth, (sx, sy) = (-1, -1), (-1, 1),
    (1, -1), (1, 1) (Camera.axes' frame: angles in degrees)."""
    yaw, pitch = np.radians(yaw), np.radians(pitch)
    cy, sy, cp, sp = np.cos(yaw), np.sin(yaw), np.cos(pitch), np.sin(pitch)
    f = np.array([-sy * cp, sp, -cy * cp])
    r = np.array([cy, 0.0, -sy])
    u = np.array([r[1] * f[2] - r[2] * f[1], r[2] * f[0] - r[0] * f[2],
                  r[0] * f[1] - r[1] * f[0]])
    ty = np.tan(np.radians(fov) / 2)
    tx = ty * aspect
    out = np.empty((4, 3))
    n = 0
    for sx in (-1.0, 1.0):
        for sv in (-1.0, 1.0):
            out[n] = f + sx * tx * r + sv * ty * u
            n += 1
    return out


def _corners(camera) -> np.ndarray:
    return _corners_of(float(camera.yaw), float(camera.pitch), float(camera.fov),
                       float(camera.aspect))


@njit(cache=True, inline="always")
def _dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@njit(cache=True)
def _level(corners, yaw, bands):
    yaw = np.radians(yaw)
    forward = np.array([-np.sin(yaw), 0.0, -np.cos(yaw)])
    right = np.array([np.cos(yaw), 0.0, -np.sin(yaw)])
    span, deepest, clamp = 0.0, -np.inf, True
    for c in range(4):
        depth = _dot(corners[c], forward)
        deepest = max(deepest, depth)
        if depth > 1e-6:
            span = max(span, abs(_dot(corners[c], right) / depth))
        else:
            clamp = False
    span = span * 1.01 if clamp else 4.0
    return forward, right, np.linspace(-span, span, bands + 1), deepest, clamp


def level_bands(camera, bands: int):
    """The level camera's axes and its horizontal bands.

    Returns forward, right : (3,) float64 (y = 0, from the yaw); tans : (bands+1,) float64,
    the band edges as tan of the horizontal angle, spanning the frustum's corner directions
    with 1% to spare (+-4 when a corner looks sideways or back); deepest : float, the largest
    level depth of a frustum corner direction at unit view depth; and clamp : bool, True when
    every corner is in front of the eye, so the bands hold every frustum ray."""
    forward, right, tans, deepest, clamp = _level(_corners(camera), float(camera.yaw),
                                                  int(bands))
    return forward, right, tans, float(deepest), bool(clamp)


def frame_bands(camera, bands: int):
    """level_bands(camera, bands) and frustum_slopes over its bands in one numba call:
    (forward, right, tans, deepest, clamp, highs, lows)."""
    forward, right, tans, deepest, clamp, highs, lows = _frame(
        float(camera.yaw), float(camera.pitch), float(camera.fov), float(camera.aspect),
        int(bands))
    return forward, right, tans, float(deepest), bool(clamp), highs, lows


@njit(cache=True)
def _frame(yaw, pitch, fov, aspect, bands):
    corners = _corners_of(yaw, pitch, fov, aspect)
    forward, right, tans, deepest, clamp = _level(corners, yaw, bands)
    highs, lows = _slopes(corners, forward, right, tans)
    return forward, right, tans, deepest, clamp, highs, lows


def no_stops(bands: int) -> tuple:
    """(highs, lows) (bands,) float64 that stop no band: +inf and -inf."""
    return np.full(bands, np.inf), np.full(bands, -np.inf)


def frustum_slopes(camera, forward, right, tans) -> tuple:
    """(highs, lows) (B,) float64: per band of `tans` (B+1,), the highest and lowest slope
    y / z (z the level depth) of any frustum ray whose lateral tan t lies in the band.

    With every frustum corner in front of the level eye, a ray's (t, slope) is a projective
    image of its place on the view rectangle with a positive denominator, so the frustum maps
    onto the convex quadrilateral of the four corners' images; its part within a band is the
    convex polygon of the corners inside the band and its edges' crossings of the band's two
    edges, whose extreme slopes bound the band. (+inf, -inf) for a band it does not reach.
    With a corner not in front (a steep pitch) the frustum's rays in front of the eye lie in
    the cone of its corners in front and of the rays where its edges cross the level depth 0;
    when those crossings all point down (up), the corners in front bound every band's slopes
    from above (below). Only stops casts early, and a stop is always safe (_cast), so
    exactness here is for speed, not for conservativeness."""
    return _slopes(_corners(camera), np.asarray(forward, np.float64),
                   np.asarray(right, np.float64), np.asarray(tans, np.float64))


@njit(cache=True)
def _slopes(corners, forward, right, tans):
    bands = tans.shape[0] - 1
    highs, lows = np.full(bands, np.inf), np.full(bands, -np.inf)
    order = (0, 1, 3, 2)  # around the rectangle
    depth, lateral, up = np.empty(4), np.empty(4), np.empty(4)
    ahead = 0
    for n in range(4):
        c = corners[order[n]]
        depth[n], lateral[n], up[n] = _dot(c, forward), _dot(c, right), c[1]
        ahead += depth[n] > 1e-6
    if ahead == 0:
        return highs, lows
    if ahead < 4:
        # Slopes of the corners in front; the edges' crossings of depth 0 all down or all up.
        high, low, downs, ups = -np.inf, np.inf, 0, 0
        for n in range(4):
            if depth[n] > 1e-6:
                high, low = max(high, up[n] / depth[n]), min(low, up[n] / depth[n])
            m = (n + 1) % 4
            if (depth[n] > 0) != (depth[m] > 0):
                s = depth[n] / (depth[n] - depth[m])
                y = up[n] + s * (up[m] - up[n])
                downs += y < 0
                ups += y > 0
        if downs and not ups:
            highs[:] = high
        elif ups and not downs:
            lows[:] = low
        return highs, lows
    t, m = lateral / depth, up / depth
    top, bottom = np.full(bands, -np.inf), np.full(bands, np.inf)
    for n in range(4):
        b = min(max(np.searchsorted(tans, t[n], side="right") - 1, 0), bands - 1)
        top[b], bottom[b] = max(top[b], m[n]), min(bottom[b], m[n])
        k = (n + 1) % 4
        lo, hi = min(t[n], t[k]), max(t[n], t[k])
        if not hi > lo:
            continue  # a vertical edge: its corners are candidates already
        for e in range(bands + 1):
            if lo <= tans[e] <= hi:
                at = m[n] + (m[k] - m[n]) * (tans[e] - t[n]) / (t[k] - t[n])
                for side in (e - 1, e):  # a band edge bounds the bands on both sides
                    if 0 <= side < bands:
                        top[side], bottom[side] = max(top[side], at), min(bottom[side], at)
    for b in range(bands):
        if top[b] > -np.inf:
            highs[b], lows[b] = top[b], bottom[b]
    return highs, lows


def stops_raw(highs, lows) -> tuple:
    """The stops in 16.16 raw int64: highs rounded up, lows down; +-inf -> +-NO_STOP_RAW."""
    def raw(values, rounding, infinite):
        finite = np.isfinite(values)
        scaled = np.clip(np.where(finite, values, 0.0) * 65536.0, -2.0 ** 61, 2.0 ** 61)
        return np.where(finite, rounding(scaled), infinite).astype(np.int64)

    return raw(highs, np.ceil, NO_STOP_RAW), raw(lows, np.floor, -NO_STOP_RAW)


@njit(cache=True, inline="always")
def bands_hide(zmin, tmin, tmax, top, bottom, tans, depths, values, ceiling, bases, clamp):
    """True when a hull whose nearest depth is zmin, lateral slopes tmin..tmax and height slopes
    at most top and at least bottom lies behind the horizon: within the bands' fan (or clamp),
    and in every band it spans, at the last slice ending before zmin, the horizon is above top,
    the ceiling below bottom and (with bases) the base below bottom. The float and 16.16
    tests share it (in raw integers, top and bottom already rounded outward)."""
    bands = tans.shape[0] - 1
    if zmin <= depths[0] or tmax < tans[0] or tmin > tans[bands] \
            or (not clamp and (tmin < tans[0] or tmax > tans[bands])):
        return False
    # Last slice that ends before the hull's nearest depth.
    k = np.searchsorted(depths, zmin, side="right") - 2
    if k < 0:
        return False
    b0 = np.searchsorted(tans, tmin, side="right") - 1
    b1 = np.searchsorted(tans, tmax, side="left") - 1
    for b in range(max(b0, 0), min(b1, bands - 1) + 1):
        if not (values[b, k] > top and bottom > ceiling[b]) \
                or (bases.shape[0] > 0 and not bottom > bases[b, k]):
            return False
    return True

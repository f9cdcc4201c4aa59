"""Scan-conversion of grid triangles over the full-resolution samples (numba kernels).

A triangle of a tile at stride s has its corners on samples; every sample inside it (edges
included) gets the triangle's linear interpolation, with integer edge functions so the inside
test is exact. Used for tile errors (build time) and for the drawn surface (measurement).
"""
from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True, inline="always")
def _scan_rows(heights, b0, lo_row, hi_row, r0, c0, r1, c1, r2, c2, h0, h1, h2, out, mode):
    """Visit samples inside triangle (r_k, c_k) on rows lo_row..hi_row, heights' row 0 being
    sample row b0: mode 0 returns max |heights - interp|, mode 1 writes interp into out.
    Returns the max error (mode 0) or 0."""
    area = (r1 - r0) * (c2 - c0) - (c1 - c0) * (r2 - r0)
    if area == 0:
        return 0.0
    worst = 0.0
    for r in range(max(min(r0, r1, r2), lo_row), min(max(r0, r1, r2), hi_row) + 1):
        for c in range(min(c0, c1, c2), max(c0, c1, c2) + 1):
            w0 = (r2 - r1) * (c - c1) - (c2 - c1) * (r - r1)
            w1 = (r0 - r2) * (c - c2) - (c0 - c2) * (r - r2)
            w2 = (r1 - r0) * (c - c0) - (c1 - c0) * (r - r0)
            if area > 0:
                if w0 < 0 or w1 < 0 or w2 < 0:
                    continue
            elif w0 > 0 or w1 > 0 or w2 > 0:
                continue
            value = (w0 * h0 + w1 * h1 + w2 * h2) / area
            if mode == 0:
                e = abs(heights[r - b0, c] - value)
                if e > worst:
                    worst = e
            else:
                out[r - b0, c] = value
    return worst


@njit(cache=True)
def _scan(heights, r0, c0, r1, c1, r2, c2, h0, h1, h2, out, mode):
    """Visit samples inside triangle (r_k, c_k): mode 0 returns max |heights - interp|,
    mode 1 writes interp into out. Returns the max error (mode 0) or 0."""
    return _scan_rows(heights, 0, min(r0, r1, r2), max(r0, r1, r2), r0, c0, r1, c1, r2, c2,
                      h0, h1, h2, out, mode)


@njit(cache=True, inline="always")
def _grid_height(heights, r, c):
    """Height of the grid surface (cells cut along (i, j)-(i+1, j+1)) at real (row, col)."""
    n = heights.shape[0]
    i = min(int(np.floor(r)), n - 2)
    j = min(int(np.floor(c)), n - 2)
    fr, fc = r - i, c - j
    h00, h01, h10, h11 = heights[i, j], heights[i, j + 1], heights[i + 1, j], heights[i + 1, j + 1]
    if fc >= fr:
        return h00 + fc * (h01 - h00) + fr * (h11 - h01)
    return h00 + fr * (h10 - h00) + fc * (h11 - h10)


@njit(cache=True)
def _edge_error(heights, r0, c0, r1, c1):
    """Largest |grid surface - segment| along the segment between samples (r0, c0) and
    (r1, c1), where the grid surface along it bends: where it crosses a row, a column or a
    cell diagonal (t = k / |dr|, k / |dc|, k / |dc - dr|)."""
    h0, h1 = heights[r0, c0], heights[r1, c1]
    dr, dc = r1 - r0, c1 - c0
    worst = 0.0
    for span in (abs(dr), abs(dc), abs(dc - dr)):
        for k in range(1, span):
            t = k / span
            e = abs(_grid_height(heights, r0 + t * dr, c0 + t * dc) - (h0 + t * (h1 - h0)))
            worst = max(worst, e)
    return worst


@njit(cache=True)
def tile_statistics(heights, patch, stride, local):
    """Per tile of one level: (error, hmin, hmax), each (m, m) float64, m = (N-1)/(patch*stride).

    heights : (N, N) float64 full-resolution samples
    local   : (K, 3, 2) int64 (row, col) template corners in local grid units
    error is the largest vertical distance between the grid surface and any of the K
    triangles over the tile. Exact: the difference is linear on each piece where a template
    triangle meets a full-resolution triangle, so its maximum is at a sample inside or at a
    point where a template edge crosses a full-resolution edge. The second kind matters for
    templates with a reduced side, whose snapped edges run across the cells' diagonals (the
    samples alone missed up to 1.54 E there, issue 30).
    """
    span = patch * stride
    m = (heights.shape[0] - 1) // span
    error = np.zeros((m, m))
    hmin = np.zeros((m, m))
    hmax = np.zeros((m, m))
    dummy = np.zeros((1, 1))
    for ti in range(m):
        for tj in range(m):
            r_org, c_org = ti * span, tj * span
            lo, hi = heights[r_org, c_org], heights[r_org, c_org]
            for r in range(r_org, r_org + span + 1):
                for c in range(c_org, c_org + span + 1):
                    v = heights[r, c]
                    lo = min(lo, v)
                    hi = max(hi, v)
            hmin[ti, tj], hmax[ti, tj] = lo, hi
            worst = 0.0
            for k in range(local.shape[0]):
                r0 = r_org + local[k, 0, 0] * stride
                c0 = c_org + local[k, 0, 1] * stride
                r1 = r_org + local[k, 1, 0] * stride
                c1 = c_org + local[k, 1, 1] * stride
                r2 = r_org + local[k, 2, 0] * stride
                c2 = c_org + local[k, 2, 1] * stride
                e = _scan(heights, r0, c0, r1, c1, r2, c2, heights[r0, c0], heights[r1, c1],
                          heights[r2, c2], dummy, 0)
                e = max(e, _edge_error(heights, r0, c0, r1, c1),
                        _edge_error(heights, r1, c1, r2, c2), _edge_error(heights, r2, c2, r0, c0))
                worst = max(worst, e)
            error[ti, tj] = worst
    return error, hmin, hmax


@njit(cache=True)
def _lod_heights(heights, rows, cols, sides, tris, starts, out):
    for t in range(rows.shape[0]):
        s = sides[t]
        for k in range(starts[s], starts[s + 1]):
            a, b, c = tris[k, 0], tris[k, 1], tris[k, 2]
            r0, c0 = rows[t, a], cols[t, a]
            r1, c1 = rows[t, b], cols[t, b]
            r2, c2 = rows[t, c], cols[t, c]
            _scan(heights, r0, c0, r1, c1, r2, c2, heights[r0, c0], heights[r1, c1],
                  heights[r2, c2], out, 1)


def lod_heights(heights, rows, cols, sides, templates) -> np.ndarray:
    """(N, N) float64 drawn-surface height at every sample (NaN where no tile is drawn).

    rows, cols : (K, V) int64 sample coordinates of each drawn tile's local vertices
    sides      : (K,) int64 template index per tile; templates: list of (T, 3) int32
    """
    out = np.full(heights.shape, np.nan)
    starts = np.r_[0, np.cumsum([len(t) for t in templates])].astype(np.int64)
    tris = np.concatenate(templates).astype(np.int64)
    _lod_heights(heights, np.ascontiguousarray(rows), np.ascontiguousarray(cols),
                 np.asarray(sides, np.int64), tris, starts, out)
    return out


@njit(cache=True)
def _triangle_heights(heights, tris, out):
    n = heights.shape[0]
    for t in range(tris.shape[0]):
        r0, c0 = tris[t, 0] // n, tris[t, 0] % n
        r1, c1 = tris[t, 1] // n, tris[t, 1] % n
        r2, c2 = tris[t, 2] // n, tris[t, 2] % n
        _scan(heights, r0, c0, r1, c1, r2, c2, heights[r0, c0], heights[r1, c1],
              heights[r2, c2], out, 1)


def triangle_heights(heights, triangles) -> np.ndarray:
    """(N, N) float64 drawn-surface height at every sample of triangles given as sample ids
    (row * N + col), NaN where none is drawn."""
    out = np.full(heights.shape, np.nan)
    _triangle_heights(heights, np.ascontiguousarray(triangles, dtype=np.int64), out)
    return out


@njit(cache=True, inline="always")
def _band_height(band, b0, n, r, c):
    """_grid_height over a band of rows [b0, b0 + len): NaN when a row it needs is outside
    (the row below is not needed where r is a whole row: its weight is 0)."""
    i = min(int(np.floor(r)), n - 2)
    j = min(int(np.floor(c)), n - 2)
    fr, fc = r - i, c - j
    if i < b0 or i - b0 >= band.shape[0]:
        return np.nan
    h00, h01 = band[i - b0, j], band[i - b0, j + 1]
    if i + 1 - b0 < band.shape[0]:
        h10, h11 = band[i + 1 - b0, j], band[i + 1 - b0, j + 1]
    elif fr == 0.0:
        h10, h11 = h00, h01  # weighted by fr = 0 below: any finite value gives the same sum
    else:
        return np.nan
    if fc >= fr:
        return h00 + fc * (h01 - h00) + fr * (h11 - h01)
    return h00 + fr * (h10 - h00) + fc * (h11 - h10)


@njit(cache=True)
def band_statistics(band, b0, corners, corner_r0, stride, patch, local, ti_lo, ti_hi,
                    error, hmin, hmax):
    """tile_statistics of tile rows ti_lo..ti_hi of one level over a band of full-resolution
    rows (terrain/outofcore.py), accumulated into error, hmin, hmax ((m, m) float64, set to
    0, +inf, -inf before the first band): bands that overlap by one row and together cover
    each tile row give exactly tile_statistics' values (the same arithmetic at every sample
    and edge crossing; a crossing between rows i and i+1 is taken in the band holding both).

    band    : (B, N) float64 heights of rows b0 .. b0 + B - 1
    corners : float64 heights at rows corner_r0 + k * stride and columns j * stride (every
              template corner of the tile rows)
    """
    n = band.shape[1]
    b1 = b0 + band.shape[0] - 1
    span = patch * stride
    m = error.shape[1]
    rr = np.empty(3, np.int64)
    cc = np.empty(3, np.int64)
    hh = np.empty(3)
    for ti in range(ti_lo, ti_hi + 1):
        r_org = ti * span
        lo_row, hi_row = max(r_org, b0), min(r_org + span, b1)
        if lo_row > hi_row:
            continue
        for tj in range(m):
            c_org = tj * span
            lo, hi = hmin[ti, tj], hmax[ti, tj]
            for r in range(lo_row, hi_row + 1):
                for c in range(c_org, c_org + span + 1):
                    v = band[r - b0, c]
                    lo = min(lo, v)
                    hi = max(hi, v)
            hmin[ti, tj], hmax[ti, tj] = lo, hi
            worst = error[ti, tj]
            for k in range(local.shape[0]):
                for v in range(3):
                    rr[v] = r_org + local[k, v, 0] * stride
                    cc[v] = c_org + local[k, v, 1] * stride
                    hh[v] = corners[(rr[v] - corner_r0) // stride, cc[v] // stride]
                worst = max(worst, _scan_band(band, b0, lo_row, hi_row, rr, cc, hh))
                for v in range(3):
                    w = (v + 1) % 3
                    worst = max(worst, _edge_band(band, b0, n, rr[v], cc[v], rr[w], cc[w],
                                                  hh[v], hh[w]))
            error[ti, tj] = worst


@njit(cache=True)
def _scan_band(band, b0, lo_row, hi_row, rr, cc, hh):
    """_scan's mode 0 over the rows lo_row..hi_row of a band."""
    return _scan_rows(band, b0, lo_row, hi_row, rr[0], cc[0], rr[1], cc[1], rr[2], cc[2],
                      hh[0], hh[1], hh[2], band, 0)


@njit(cache=True)
def _edge_band(band, b0, n, r0, c0, r1, c1, h0, h1):
    """_edge_error over a band: the crossings whose rows the band holds."""
    dr, dc = r1 - r0, c1 - c0
    worst = 0.0
    for span in (abs(dr), abs(dc), abs(dc - dr)):
        for k in range(1, span):
            t = k / span
            g = _band_height(band, b0, n, r0 + t * dr, c0 + t * dc)
            if g == g:  # not NaN: the band holds it
                worst = max(worst, abs(g - (h0 + t * (h1 - h0))))
    return worst

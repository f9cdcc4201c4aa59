"""The tiled depth buffer's tile tables (numba, cached on disk): per tile of tw x th pixels the
largest and smallest depth bound and whether any pixel is covered (build_tiles), the tile
maxima's block level (tile_max_size: a test reads a block's maximum before its tiles'), and
the occluders' largest screen shift per tile with its range-maximum table (tile_shifts,
tile_shift_bound). buffer.py's tests read them.
"""
from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True, nogil=True, inline="always")
def _levels(n):
    """floor(log2(n)) + 1 for n >= 1: the sparse table's levels over n entries."""
    k = 1
    while (1 << k) <= n:
        k += 1
    return k


def shift_table_size(rows: int, cols: int) -> int:
    """Entries of tile_shifts' table for rows x cols tiles."""
    return _levels(rows) * _levels(cols) * rows * cols


# Tiles per block of the tile maxima's second level (columns, rows: 8 x 4-pixel tiles make
# 16 x 16-pixel blocks): a tested rectangle wholly behind a block's maximum skips its tiles.
BLOCK_COLS, BLOCK_ROWS = 2, 4


@njit(cache=True, nogil=True)
def tile_max_size(rows, cols):
    """Entries of a tile_max with its block level: rows x cols tiles, then per block of
    BLOCK_COLS x BLOCK_ROWS tiles (row-major, partial blocks at the edges) their maximum
    (build_tiles fills it, _behind reads it). A tile_max of rows x cols entries has none."""
    return rows * cols + (-(-rows // BLOCK_ROWS)) * (-(-cols // BLOCK_COLS))


@njit(cache=True, nogil=True)
def tile_shifts(tile_near, reach, tangent, rows, cols, out):
    """out: a 2D sparse table of the largest screen shift (x / z units) of an occluder point
    over each tile of tile_near (rows * cols,): reach / z (1 + tangent near / z + reach / z),
    z = near - reach, for reach = sqrt(3) move (inf when z <= 0, 0 over tiles no occluder
    meets); level (a, b) at ((a * levels(cols) + b) * rows + r) * cols + c holds the maximum
    over rows r..r+2^a-1 and columns c..c+2^b-1 (tile_shift_bound). Exact."""
    la, lb = _levels(rows), _levels(cols)
    for k in range(rows * cols):
        near = tile_near[k]
        s = 0.0
        if near < np.inf:
            z = near - reach
            s = reach / z * (1.0 + (tangent * near / z + reach / z)) if z > 0 else np.inf
        out[k] = s
    for a in range(la):
        for b in range(lb):
            if a == 0 and b == 0:
                continue
            base = (a * lb + b) * rows * cols
            if b > 0:  # from level (a, b - 1): two column halves
                src, step, rstep = (a * lb + b - 1) * rows * cols, 1 << (b - 1), 0
            else:      # from level (a - 1, 0): two row halves
                src, step, rstep = ((a - 1) * lb) * rows * cols, 0, 1 << (a - 1)
            for r in range(rows - (1 << a) + 1):
                for c in range(cols - (1 << b) + 1):
                    k = r * cols + c
                    out[base + k] = max(out[src + k], out[src + k + rstep * cols + step])


@njit(cache=True, nogil=True, inline="always")
def tile_shift_bound(c0, c1, r0, r1, table, rows, cols):
    """The largest per-tile value of tile_shifts' table over tiles c0..c1 x r0..r1 (inclusive,
    non-empty): four look-ups. Exact."""
    a, b = _levels(r1 - r0 + 1) - 1, _levels(c1 - c0 + 1) - 1
    base = (a * _levels(cols) + b) * rows * cols
    r2, c2 = r1 - (1 << a) + 1, c1 - (1 << b) + 1
    return max(max(table[base + r0 * cols + c0], table[base + r0 * cols + c2]),
               max(table[base + r2 * cols + c0], table[base + r2 * cols + c2]))


@njit(cache=True, nogil=True)
def build_tiles(depth, width, height, tw, th, tile_max, tile_any, tile_min):
    """Per tile of tw x th pixels: tile_max the largest depth bound (inf when any pixel is not
    covered), tile_any whether any pixel is covered, tile_min the smallest bound; with room
    for them (tile_max_size), the blocks' maxima after the tiles' (nan when a tile is). Exact."""
    cols = (width + tw - 1) // tw
    rows = (height + th - 1) // th
    for ty_ in range(rows):
        for tx_ in range(cols):
            m, low = -np.inf, np.inf
            for r in range(ty_ * th, min((ty_ + 1) * th, height)):
                for c in range(tx_ * tw, min((tx_ + 1) * tw, width)):
                    v = depth[r * width + c]
                    m = max(m, v)
                    low = min(low, v)
            tile_max[ty_ * cols + tx_] = m
            tile_any[ty_ * cols + tx_] = low < np.inf
            tile_min[ty_ * cols + tx_] = low
    if len(tile_max) >= tile_max_size(rows, cols):
        _block_maxima(tile_max, rows, cols)


@njit(cache=True, nogil=True)
def _block_maxima(tile_max, rows, cols):
    """tile_max's block level (tile_max_size) from its tiles' maxima: nan when one is nan (a
    block's maximum is never below a tile's, so a test it passes every tile passes)."""
    base, bcols = rows * cols, -(-cols // BLOCK_COLS)
    for by in range(-(-rows // BLOCK_ROWS)):
        for bx in range(bcols):
            m = -np.inf
            for ty_ in range(by * BLOCK_ROWS, min(by * BLOCK_ROWS + BLOCK_ROWS, rows)):
                for tx_ in range(bx * BLOCK_COLS, min(bx * BLOCK_COLS + BLOCK_COLS, cols)):
                    v = tile_max[ty_ * cols + tx_]
                    if v > m or v != v:
                        m = v
                    if m != m:
                        break
            tile_max[base + by * bcols + bx] = m

"""The min- and max-pyramids the horizon casts read (terrain/horizon.py, horizon_cells.py):
block minima and maxima of a map, packed flat for the numba kernels, and their range queries."""
from __future__ import annotations

import numpy as np
from numba import njit


def pyramid(cells, reduce) -> list:
    """[(2^(n-k))^2 float64 reductions over blocks of 2^k cells] of (2^n, 2^n) cells, k = 0..n
    (reduce: np.min or np.max)."""
    level = np.asarray(cells, dtype=np.float64)
    mips = [level]
    while level.shape[0] > 1:
        k = level.shape[0] // 2
        level = reduce(level.reshape(k, 2, k, 2), axis=(1, 3))
        mips.append(level)
    return mips


def min_mip(heights) -> list:
    """[(2^(n-k))^2 float64 minima over blocks of 2^k cells, samples on the block edge
    included] for k = 0..n."""
    h = np.asarray(heights, dtype=np.float64)
    return pyramid(np.minimum(np.minimum(h[:-1, :-1], h[1:, :-1]),
                              np.minimum(h[:-1, 1:], h[1:, 1:])), np.min)


def max_mip(heights) -> list:
    """min_mip with maxima: [(2^(n-k))^2 float64 maxima over blocks of 2^k cells]."""
    h = np.asarray(heights, dtype=np.float64)
    return pyramid(np.maximum(np.maximum(h[:-1, :-1], h[1:, :-1]),
                              np.maximum(h[:-1, 1:], h[1:, 1:])), np.max)


def max_mip_cells(cells) -> list:
    """[(2^(n-k))^2 maxima over blocks of 2^k cells] of a per-cell (2^n, 2^n) array."""
    return pyramid(cells, np.max)


def cell_gradients(heights, spacing: float) -> np.ndarray:
    """(n, n) float64: the steepest |grad h| over the four triangles of each cell (both
    diagonals, so it holds for the grid and for the 4-8 mesh)."""
    h = np.asarray(heights, dtype=np.float64)
    a, b, c, d = h[:-1, :-1], h[:-1, 1:], h[1:, :-1], h[1:, 1:]
    pairs = [(b - a, d - b), (d - c, c - a), (b - a, c - a), (d - c, d - b)]
    return np.max([np.hypot(gx, gz) for gx, gz in pairs], axis=0) / spacing


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


@njit(cache=True, inline="always")
def _highest_in(flat, offsets, sizes, i0, i1, j0, j1, start):
    """Highest height over the map cells of rows i0..i1, columns j0..j1 clipped to the map
    (max-mip; never below the true maximum); start when nothing of it is on the map."""
    cells = sizes[0]
    i0, j0 = max(i0, 0), max(j0, 0)
    i1, j1 = min(i1, cells - 1), min(j1, cells - 1)
    if i0 > i1 or j0 > j1:
        return start
    level = 0
    while (j1 >> level) - (j0 >> level) > 1 or (i1 >> level) - (i0 >> level) > 1:
        level += 1
    size = sizes[level]
    high = start
    for i in range(i0 >> level, (i1 >> level) + 1):
        for j in range(j0 >> level, (j1 >> level) + 1):
            high = max(high, flat[offsets[level] + i * size + j])
    return high

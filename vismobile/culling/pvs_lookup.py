"""The `pvs` stage's view-cell lookup: a uniform x-z bucket grid over the cells' boxes, so a frame
tests only the few cells in the buckets around the eye instead of every cell (W5's street cells:
3,055; partition/pvs_street.py).

Exact: `find` returns every cell whose box grown by pad holds the eye (the same cells as testing
them all), each once.
"""
from __future__ import annotations

import numpy as np
from numba import njit

MAX_BUCKETS = 1 << 16


def cell_index(cells) -> tuple:
    """(x0, z0, size, nx, nz, start (nx nz + 1,) int64, ids (R,) int64) of the boxes cells
    (V, 2, 3): bucket (i, k) covers x0 + i size .. + size, z0 + k size .. + size and lists the
    cells whose x-z box meets it (closed)."""
    cells = np.asarray(cells, dtype=np.float64).reshape(-1, 2, 3)
    lo, hi = cells[:, 0][:, [0, 2]], cells[:, 1][:, [0, 2]]
    low, high = lo.min(axis=0), hi.max(axis=0)
    span = np.maximum(high - low, 1e-9)
    size = max(float(np.median((hi - lo).max(axis=1))), 1e-9)
    while np.prod(np.ceil(span / size)) > MAX_BUCKETS:
        size *= 2.0
    n = np.maximum(np.ceil(span / size).astype(np.int64), 1)
    first = np.clip(np.floor((lo - low) / size).astype(np.int64), 0, n - 1)
    last = np.clip(np.floor((hi - low) / size).astype(np.int64), 0, n - 1)
    counts = np.prod(last - first + 1, axis=1)
    cell = np.repeat(np.arange(len(cells)), counts)
    offset = np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)
    width = (last - first + 1)[cell, 1]
    bucket = (first[cell, 0] + offset // width) * n[1] + first[cell, 1] + offset % width
    order = np.lexsort((cell, bucket))
    start = np.concatenate([[0], np.cumsum(np.bincount(bucket, minlength=int(n.prod())))])
    return (float(low[0]), float(low[1]), size, int(n[0]), int(n[1]), start.astype(np.int64),
            cell[order].astype(np.int64))


@njit(cache=True)
def find(cells, x0, z0, size, nx, nz, start, ids, eye, pad):
    """(found (K,) int64 ascending cells whose box grown by pad holds eye, tested: how many
    boxes were tested)."""
    out = np.empty(64, dtype=np.int64)
    n = 0
    tested = 0
    i0 = int(np.floor((eye[0] - pad - x0) / size))
    i1 = int(np.floor((eye[0] + pad - x0) / size))
    k0 = int(np.floor((eye[2] - pad - z0) / size))
    k1 = int(np.floor((eye[2] + pad - z0) / size))
    if i1 < 0 or k1 < 0 or i0 >= nx + 1 or k0 >= nz + 1:
        return out[:0], 0
    # clamped: a box on the grid's far side lies in its last bucket (its floor is n there)
    for i in range(min(max(i0, 0), nx - 1), max(min(i1, nx - 1), 0) + 1):
        for k in range(min(max(k0, 0), nz - 1), max(min(k1, nz - 1), 0) + 1):
            b = i * nz + k
            for r in range(start[b], start[b + 1]):
                c = ids[r]
                tested += 1
                inside = True
                for a in range(3):
                    if not (cells[c, 0, a] - pad <= eye[a] <= cells[c, 1, a] + pad):
                        inside = False
                if not inside:
                    continue
                seen = False
                for j in range(n):
                    if out[j] == c:
                        seen = True
                if seen:
                    continue
                if n == len(out):
                    grown = np.empty(2 * n, dtype=np.int64)
                    grown[:n] = out
                    out = grown
                out[n] = c
                n += 1
    return np.sort(out[:n]), tested

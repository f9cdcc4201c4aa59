"""Pires's display lists (seed 000, 2003) as cached index buffers per Röttger chunk.

Röttger's refinement runs every frame (Pires's "new algorithm" keeps its metric, so triangle
counts are Röttger's). The map is cut into chunks of 32x32 cells (the quadtree's blocks at
one level); a chunk's triangles are a uint16 index array over its own (33)^2 vertex grid, the
ES 1.1 form of a display list, kept across frames. Marking (Pires: a display list is rebuilt
when a node of its subtree changes its subdivision, or a neighbour's level changes one of its
skipped midpoints): a chunk's signature hashes its visible leaves and their skip bits, which
is exactly what its fans depend on; a chunk whose signature is unchanged reuses last frame's
array (no fan is emitted, nothing is copied or uploaded), a changed one is rebuilt. The
leaves of a chunk are contiguous in the depth-first leaf order, so the marking pass is one
scan of the leaves. Leaves coarser than a chunk (far away) are emitted every frame with
global sample ids.

`cache=False` rebuilds every visible chunk every frame: the same output, the baseline that
the cache is measured against (tools/bench_terrain.py --display-lists).
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
from numba import njit

from .roettger import Roettger, _emit


@njit(cache=True)
def _mark(leaf_rows, count, chunk_level, starts, ends, signatures, coarse):
    """Per chunk: its leaves' row range [starts, ends) (0, 0 when none is visible) and an
    FNV-1a hash of (leaf id, skip bits); coarse[k] marks leaves coarser than a chunk. Returns
    the number of coarse leaves."""
    chunks = 1 << chunk_level
    for c in range(chunks * chunks):
        starts[c] = 0
        ends[c] = 0
        signatures[c] = 0
    coarse_count = 0
    for row in range(count):
        l, bi, bj, sides = leaf_rows[row, 0], leaf_rows[row, 1], leaf_rows[row, 2], \
            leaf_rows[row, 3]
        if l < chunk_level:
            coarse[row] = True
            coarse_count += 1
            continue
        coarse[row] = False
        chunk = (bi >> (l - chunk_level)) * chunks + (bj >> (l - chunk_level))
        if ends[chunk] == 0:
            starts[chunk] = row
            signatures[chunk] = np.uint64(14695981039346656037)
        ends[chunk] = row + 1
        key = ((((l << 20) | bi) << 20 | bj) << 4) | sides
        signatures[chunk] = (signatures[chunk] ^ np.uint64(key)) * np.uint64(1099511628211)
    return coarse_count


@njit(cache=True)
def _emit_chunk(leaf_rows, start, end, cells, r0, c0, width, out):
    """Fans of leaves [start, end) of one chunk as (T, 3) uint16 local indices
    ((r - r0) * width + (c - c0)) into out; returns T."""
    count = 0
    ring_r = np.empty(8, np.int64)
    ring_c = np.empty(8, np.int64)
    for row in range(start, end):
        l, bi, bj, sides = leaf_rows[row, 0], leaf_rows[row, 1], leaf_rows[row, 2], \
            leaf_rows[row, 3]
        s = cells >> l
        br, bc = bi * s - r0, bj * s - c0
        half = s // 2
        k = 0
        ring_r[k], ring_c[k] = br, bc
        k += 1
        if not sides & 8:
            ring_r[k], ring_c[k] = br + half, bc
            k += 1
        ring_r[k], ring_c[k] = br + s, bc
        k += 1
        if not sides & 4:
            ring_r[k], ring_c[k] = br + s, bc + half
            k += 1
        ring_r[k], ring_c[k] = br + s, bc + s
        k += 1
        if not sides & 2:
            ring_r[k], ring_c[k] = br + half, bc + s
            k += 1
        ring_r[k], ring_c[k] = br, bc + s
        k += 1
        if not sides & 1:
            ring_r[k], ring_c[k] = br, bc + half
            k += 1
        centre = (br + half) * width + bc + half
        for t in range(k):
            u = (t + 1) % k
            out[count, 0] = centre
            out[count, 1] = ring_r[t] * width + ring_c[t]
            out[count, 2] = ring_r[u] * width + ring_c[u]
            count += 1
    return count


@dataclass
class ChunkFrame:
    """One frame of cached chunks.

    chunks   : (K,) int64 visible chunk ids (row-major over 2^chunk_level per side)
    indices  : list of K (T_k, 3) uint16 arrays, local to each chunk's vertex grid (the cache
               itself: do not modify)
    versions : (K,) int64 a chunk's array changes exactly when its version does
    coarse   : (C, 3) int64 sample ids of leaves coarser than a chunk
    rebuilt, reused : visible chunks emitted this frame / taken from the cache
    lod_ms   : refinement and leaves; build_ms: marking, emission and the coarse leaves
    triangles: int
    """

    chunks: np.ndarray
    indices: list
    versions: np.ndarray
    coarse: np.ndarray
    rebuilt: int
    reused: int
    lod_ms: float
    build_ms: float
    triangles: int


class DisplayLists:
    """Röttger with per-chunk cached index arrays (Pires's simple display lists)."""

    def __init__(self, roettger: Roettger, cache: bool = True):
        self.roettger = roettger
        self.cache_on = bool(cache)
        r = roettger
        self.chunk_level = r.chunk_level
        self.cells = r.heightmap.size - 1
        self.chunk_cells = self.cells >> self.chunk_level
        self.width = self.chunk_cells + 1
        chunks = 4 ** self.chunk_level
        self.starts = np.zeros(chunks, np.int64)
        self.ends = np.zeros(chunks, np.int64)
        self.signatures = np.zeros(chunks, np.uint64)
        self.cached_signature = np.zeros(chunks, np.uint64)
        self.version = np.zeros(chunks, np.int64)
        self.cache = [None] * chunks
        self.scratch = np.zeros((2 * self.chunk_cells * self.chunk_cells, 3), np.uint16)
        self.coarse_out = np.zeros((1 << 10, 3), np.int64)
        self.coarse = np.zeros(len(r.leaf_rows), np.bool_)
        self.no_signatures = np.zeros(chunks, np.uint64)

    def chunk_origin(self, chunk: int) -> tuple:
        """(row, col) of a chunk's first sample."""
        ci, cj = divmod(int(chunk), 1 << self.chunk_level)
        return ci * self.chunk_cells, cj * self.chunk_cells

    def update(self, camera, resolution, tau: float, cull: bool = True) -> ChunkFrame:
        r = self.roettger
        start = time.perf_counter()
        _, count = r.select(camera, resolution, tau, cull)
        mid = time.perf_counter()
        if len(self.coarse) < len(r.leaf_rows):
            self.coarse = np.zeros(len(r.leaf_rows), np.bool_)
        n_coarse = _mark(r.leaf_rows, count, self.chunk_level, self.starts, self.ends,
                         self.signatures, self.coarse)
        visible = np.flatnonzero(self.ends > 0)
        rebuilt = 0
        for chunk in visible:
            if self.cache_on and self.cache[chunk] is not None and \
                    self.cached_signature[chunk] == self.signatures[chunk]:
                continue
            r0, c0 = self.chunk_origin(chunk)
            t = _emit_chunk(r.leaf_rows, self.starts[chunk], self.ends[chunk], self.cells, r0,
                            c0, self.width, self.scratch)
            self.cache[chunk] = self.scratch[:t].copy()
            self.cached_signature[chunk] = self.signatures[chunk]
            self.version[chunk] += 1
            rebuilt += 1
        coarse = np.zeros((0, 3), np.int64)
        if n_coarse:
            rows = r.leaf_rows[:count][self.coarse[:count]]
            while True:
                t = _emit(r.heights, rows, len(rows), r.offsets, self.chunk_level,
                          self.coarse_out, self.no_signatures)
                if t >= 0:
                    break
                self.coarse_out = np.zeros((2 * len(self.coarse_out), 3), np.int64)
            coarse = self.coarse_out[:t].copy()
        indices = [self.cache[c] for c in visible]
        end = time.perf_counter()
        return ChunkFrame(visible, indices, self.version[visible].copy(), coarse, rebuilt,
                          len(visible) - rebuilt, (mid - start) * 1000, (end - mid) * 1000,
                          int(sum(len(i) for i in indices) + len(coarse)))

    def sample_triangles(self, frame: ChunkFrame) -> np.ndarray:
        """(T, 3) int64 global sample ids of a frame (for checks; not per-frame work)."""
        n = self.roettger.heightmap.size
        parts = [frame.coarse]
        for chunk, local in zip(frame.chunks, frame.indices):
            r0, c0 = self.chunk_origin(chunk)
            rr, cc = np.divmod(local.astype(np.int64), self.width)
            parts.append((rr + r0) * n + cc + c0)
        return np.concatenate(parts) if parts else np.zeros((0, 3), np.int64)

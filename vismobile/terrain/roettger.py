"""Röttger et al. 1998 quadtree continuous LOD, as Pires 2003 (seed 000) used it.

Blocks are squares of 3x3 vertices at their own scale; block (l, bi, bj) at level l spans
s = (N-1) / 2^l cells from (bi*s, bj*s). Per frame a block is refined while

    f = l1 / (d * C * max(c * d2, 1)) < 1

with l1 the L1 distance from the eye to the block centre, d the block's edge length, C the
minimum global resolution and c the desired global resolution. d2 is the block's roughness,
propagated upward with K = C / (2 (C - 1)) from the finer blocks inside and around it, which
keeps neighbouring leaves within one level of each other. One pixel knob tau sets c: the
roughness branch refines while dist < C * c * e with e = d * d2 a height error, i.e. while
lambda * e / dist > tau for c = lambda / (tau * C) (lambda with the off-axis bound of
tiles.pixel_scale).

Strict bound (issue 30). Röttger's d2 is the largest one-level height change over d; it is not
a bound of the fan's error against the full-resolution surface (errors add up over levels:
1.23 tau at samples on jacksboro, more on a Takagi-like map), and the L1 distance to the block
centre overshoots the distance to the block's nearest point. Here e = d * d2 is at least the
block's exact vertical error E: the largest |h - fan| over the block's samples for the fan with
every edge midpoint and for the fan with none (every fan triangle, skipped or not, is a 4-8
mesh triangle that the full-resolution 4-8 mesh refines, so the maximum is at a sample, and
each quarter's error is one of those two), nested so a block's E holds its descendants'; and
the roughness branch measures dist, the Euclidean distance to the block's box. The minimum
resolution branch (l1 < d C) stays Röttger's. Leaves of the finest level cannot refine, yet
skip a midpoint beside a coarser neighbour (at the frustum's edge, a culled block is such a
neighbour: the skipped midpoint lies outside the view while its triangle reaches the screen);
when the skip's error is over tau for that leaf, its neighbour is subdivided instead
(`quadtree.unreduce_finest`), then the tree is balanced again. Every drawn leaf is then
within tau pixels (measured by tools/terrain_check.py, independent of this argument).

Each leaf is drawn as a closed fan of up to 8 triangles around its centre; the midpoint of an
edge is skipped when the neighbour across it is coarser. A balancing pass after refinement
enforces the one-level rule explicitly (K makes it rare; the pass makes it certain).

Frame state lives in flat per-level arrays (no per-block objects): a block is subdivided in
frame F when stamp[block] == F, so nothing is cleared between frames. Chunks (blocks at a
fixed level, Pires's display lists as cached index ranges) carry a signature of their leaves;
a chunk whose signature is unchanged keeps last frame's triangles (counted as reused).
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
from numba import njit

from .heightmap import Heightmap
from .quadtree import ROETTGER, balance, leaves, level_offsets, refine, unreduce_finest
from .raster import _scan
from .tiles import pixel_scale

CHUNK_CELLS = 32  # chunk size in cells (a "display list"): at most 32^2 * 2 triangles


@njit(cache=True)
def fan_errors(heights, s):
    """(m, m) float64 per block of s cells: the largest |h - fan| over the block's samples,
    for the fan with all four edge midpoints and for the fan with none, whichever is larger
    (the largest error of any of its fans: each quarter is one of the two)."""
    mr, mc = (heights.shape[0] - 1) // s, (heights.shape[1] - 1) // s  # a band of rows too
    half = s // 2
    out = np.zeros((mr, mc))
    ring_r = np.empty(9, np.int64)
    ring_c = np.empty(9, np.int64)
    dummy = np.zeros((1, 1))
    for bi in range(mr):
        for bj in range(mc):
            r0, c0 = bi * s, bj * s
            rc, cc = r0 + half, c0 + half
            k = 0
            for dr, dc in ((0, 0), (half, 0), (s, 0), (s, half), (s, s), (half, s), (0, s),
                           (0, half), (0, 0)):
                ring_r[k], ring_c[k] = r0 + dr, c0 + dc
                k += 1
            worst = 0.0
            for step in (1, 2):  # 1: every midpoint; 2: corners only
                for t in range(0, 8, step):
                    ra, ca = ring_r[t], ring_c[t]
                    rb, cb = ring_r[t + step], ring_c[t + step]
                    e = _scan(heights, rc, cc, ra, ca, rb, cb, heights[rc, cc],
                              heights[ra, ca], heights[rb, cb], dummy, 0)
                    worst = max(worst, e)
            out[bi, bj] = worst
    return out


def block_horizontal(valid, s: int, spacing: float) -> np.ndarray:
    """(m, m) float64 seed 002's horizontal error (tiles.horizontal_error's Table 4.1) of each
    block of s cells: over its fan's edges A-C-B, the four sides (corner, midpoint, corner) and
    the two diagonals through the centre; hsize = s / 2 spacings (diagonals sqrt(2) times)."""
    h = s // 2
    hsize = h * spacing

    def value(a, c, b, scale):
        return np.where(a != b, 0.5 * scale, np.where(a != c, scale, 0.0))

    v = valid
    corner = v[::s, ::s]
    top = value(corner[:-1, :-1], v[0:-1:s, h::s], corner[:-1, 1:], hsize)
    bottom = value(corner[1:, :-1], v[s::s, h::s], corner[1:, 1:], hsize)
    left = value(corner[:-1, :-1], v[h::s, 0:-1:s], corner[1:, :-1], hsize)
    right = value(corner[:-1, 1:], v[h::s, s::s], corner[1:, 1:], hsize)
    centre = v[h::s, h::s]
    diagonal = np.sqrt(2.0) * hsize
    one = value(corner[:-1, :-1], centre, corner[1:, 1:], diagonal)
    two = value(corner[:-1, 1:], centre, corner[1:, :-1], diagonal)
    return np.maximum.reduce([top, bottom, left, right, one, two])


def roughness(heightmap: Heightmap, C: float) -> tuple:
    """(d2, hmin, hmax, centre heights, levels): flat float64 per block, d2 K-propagated.

    d2 of a block = max(E / d, K * max(d2 of the 4x4 finer blocks over and around it)), E the
    block's nested exact fan error (fan_errors; module doc). On the finest level d2 = E / d is
    the error of skipping midpoints (its full fan is exact), used by unreduce_finest only.
    """
    h = heightmap.heights.astype(np.float64)
    cells = heightmap.size - 1
    levels = cells.bit_length() - 2  # finest blocks are 2 cells wide
    offsets = level_offsets(levels)
    d2 = np.zeros(offsets[-1])
    hmin = np.zeros(offsets[-1])
    hmax = np.zeros(offsets[-1])
    centres = np.zeros(offsets[-1])
    state = None
    for level in range(levels, -1, -1):
        s = cells >> level
        state = roughness_level(h, heightmap.valid, heightmap.spacing, C, s,
                                fan_errors(h, s), state)
        _, local, lo, hi, centre = state
        d2[offsets[level]:offsets[level + 1]] = local.ravel()
        hmin[offsets[level]:offsets[level + 1]] = lo.ravel()
        hmax[offsets[level]:offsets[level + 1]] = hi.ravel()
        centres[offsets[level]:offsets[level + 1]] = centre.ravel()
    return d2, hmin, hmax, centres, levels


def roughness_level(h, valid, spacing, C, s, exact, finer=None) -> tuple:
    """One level of roughness: (nested E, d2, hmin, hmax, centre heights), each (m_r, m_c) over
    the blocks of s cells of h ((R, C) float64 heights whose first row starts a block; a band
    of rows in terrain/outofcore.py), given exact = fan_errors(h, s) and finer = this function's
    result one level finer (None at the finest level). The band's edge blocks see no
    neighbour beyond it, as the map's border blocks do. h may be None above the finest level
    (the centre heights then come back None)."""
    K = C / (2.0 * (C - 1.0))
    half = s // 2
    if valid is not None:  # seed 002's holes: E = length(E_h, E_v)
        exact = np.hypot(exact, block_horizontal(valid, s, spacing))
    mr, mc = exact.shape
    if finer is not None:
        exact = np.maximum(exact, finer[0].reshape(mr, 2, mc, 2).max(axis=(1, 3)))
    local = exact / (s * spacing)
    if finer is not None:
        padded = np.pad(finer[1], 1)
        window = np.lib.stride_tricks.sliding_window_view(padded, (4, 4))[::2, ::2]
        local = np.maximum(local, K * window.max(axis=(-1, -2)))
        lo = finer[2].reshape(mr, 2, mc, 2).min(axis=(1, 3))
        hi = finer[3].reshape(mr, 2, mc, 2).max(axis=(1, 3))
    else:
        windows = np.lib.stride_tricks.sliding_window_view(h, (s + 1, s + 1))[::s, ::s]
        lo, hi = windows.min(axis=(-1, -2)), windows.max(axis=(-1, -2))
    centre = None if h is None else h[half::s, half::s][:mr, :mc]  # None: the caller's
    return exact, local, lo, hi, centre


@njit(cache=True)
def _emit(heights, leaf_rows, leaf_count, offsets, chunk_level, out, signatures):
    """Fans of the visible leaves (rows level, bi, bj, sides from quadtree.leaves), in order.
    out: (capacity, 3) int64 sample ids. signatures[chunk] gets an FNV-1a hash of the chunk's
    leaves and skips (0 = empty). Returns the triangle count, or -1 if out is too small."""
    n = heights.shape[0]
    cells = n - 1
    count = 0
    ring_r = np.empty(8, np.int64)
    ring_c = np.empty(8, np.int64)
    chunks = 1 << chunk_level
    for chunk in range(chunks * chunks):
        signatures[chunk] = 0
    for row in range(leaf_count):
        l, bi, bj, sides = (leaf_rows[row, 0], leaf_rows[row, 1], leaf_rows[row, 2],
                            leaf_rows[row, 3])
        index = offsets[l] + bi * (1 << l) + bj
        s = cells >> l
        r0, c0 = bi * s, bj * s
        half = s // 2
        # Skip an edge midpoint when the same-level neighbour across it does not exist.
        skip_top, skip_right = (sides & 1) != 0, (sides & 2) != 0
        skip_bottom, skip_left = (sides & 4) != 0, (sides & 8) != 0
        k = 0
        ring_r[k], ring_c[k] = r0, c0
        k += 1
        if not skip_left:
            ring_r[k], ring_c[k] = r0 + half, c0
            k += 1
        ring_r[k], ring_c[k] = r0 + s, c0
        k += 1
        if not skip_bottom:
            ring_r[k], ring_c[k] = r0 + s, c0 + half
            k += 1
        ring_r[k], ring_c[k] = r0 + s, c0 + s
        k += 1
        if not skip_right:
            ring_r[k], ring_c[k] = r0 + half, c0 + s
            k += 1
        ring_r[k], ring_c[k] = r0, c0 + s
        k += 1
        if not skip_top:
            ring_r[k], ring_c[k] = r0, c0 + half
            k += 1
        if count + k > out.shape[0]:
            return -1
        centre = (r0 + half) * n + c0 + half
        for t in range(k):
            u = (t + 1) % k
            out[count, 0] = centre
            out[count, 1] = ring_r[t] * n + ring_c[t]
            out[count, 2] = ring_r[u] * n + ring_c[u]
            count += 1
        # Chunk signature: the leaf's id and its skip bits.
        if l >= chunk_level:
            ci, cj = bi >> (l - chunk_level), bj >> (l - chunk_level)
        else:  # a leaf coarser than a chunk: charge it to its first chunk
            ci, cj = bi << (chunk_level - l), bj << (chunk_level - l)
        chunk = ci * chunks + cj
        key = (index << 4) | sides
        hsh = signatures[chunk] if signatures[chunk] != 0 else np.uint64(14695981039346656037)
        hsh = (hsh ^ np.uint64(key)) * np.uint64(1099511628211)
        signatures[chunk] = hsh
    return count


@dataclass
class RoettgerFrame:
    """One frame's mesh and work.

    triangles   : (T, 3) int64 sample ids (row * N + col), counter-clockwise from +y
    tested      : blocks whose refinement criterion ran
    subdivided  : blocks subdivided after balancing
    lod_ms      : refinement + balancing + fan emission wall time
    chunks_changed, chunks_reused : chunks whose triangles changed / were kept from last frame
    """

    triangles: np.ndarray
    tested: int
    subdivided: int
    lod_ms: float
    chunks_changed: int
    chunks_reused: int


class Roettger:
    """Per-frame Röttger CLOD of one heightmap with one pixel knob.

    C : minimum global resolution (Pires used 10 and 20); c follows from tau (module doc).
    """

    def __init__(self, heightmap: Heightmap, C: float = 8.0):
        if not C > 1:
            raise ValueError("C must be > 1")
        self.heightmap = heightmap
        self.C = float(C)
        start = time.perf_counter()
        self.d2, self.hmin, self.hmax, self.centres, self.levels = roughness(heightmap, self.C)
        self.build_seconds = time.perf_counter() - start
        self.offsets = level_offsets(self.levels)
        # Finest blocks (2 cells): d2 = E / d with E the error of their fans' skips.
        self.skip_error = np.zeros(self.offsets[-1])
        self.skip_error[self.offsets[self.levels]:] = \
            self.d2[self.offsets[self.levels]:] * (2 * heightmap.spacing)
        self.heights = heightmap.heights
        self.stamp = np.zeros(self.offsets[-1], np.int64)
        self.lists = np.zeros(self.offsets[-1], np.int64)
        self.counts = np.zeros(self.levels + 1, np.int64)
        self.frame = 0
        cells = heightmap.size - 1
        self.chunk_level = max(0, min(self.levels, (cells // CHUNK_CELLS).bit_length() - 1))
        self.signatures = np.zeros(4 ** self.chunk_level, np.uint64)
        self.previous = None
        self.leaf_rows = np.zeros((1 << 14, 4), np.int64)
        self.leaf_count = 0  # leaves of the last select (rows of leaf_rows)
        self.out = np.zeros((1 << 16, 3), np.int64)

    def c_for(self, tau: float, lam_bound: float) -> float:
        """Pires's desired global resolution c for a tolerance of tau pixels."""
        return lam_bound / (tau * self.C)

    def update(self, camera, resolution, tau: float, cull: bool = True,
               full: bool = False) -> RoettgerFrame:
        """Refine for this camera and emit the leaves' fans (full: every block to the finest
        level, the method's own full-resolution mesh)."""
        start = time.perf_counter()
        tested, leaf_count = self.select(camera, resolution, tau, cull, full)
        while True:
            count = _emit(self.heights, self.leaf_rows, leaf_count, self.offsets,
                          self.chunk_level, self.out, self.signatures)
            if count >= 0:
                break
            self.out = np.zeros((2 * len(self.out), 3), np.int64)
        lod_ms = (time.perf_counter() - start) * 1000.0
        changed = reused = 0
        if self.previous is not None:
            same = self.signatures == self.previous
            live = (self.signatures != 0) | (self.previous != 0)
            changed, reused = int((live & ~same).sum()), int((live & same).sum())
        self.previous = self.signatures.copy()
        return RoettgerFrame(self.out[:count].copy(), int(tested), int(self.counts.sum()),
                             lod_ms, changed, reused)

    def select(self, camera, resolution, tau: float, cull: bool = True,
               full: bool = False) -> tuple:
        """Refine and balance for this camera; the visible leaves go to self.leaf_rows (rows
        level, bi, bj, sides, depth-first, so each chunk's leaves are contiguous). Returns
        (blocks tested, leaf count)."""
        _, lam = pixel_scale(camera, resolution)
        c = self.c_for(tau, lam)
        C = 1e300 if full else self.C
        self.frame += 1
        planes = camera.frustum_planes()
        tested = refine(self.heightmap.size - 1, self.heightmap.spacing, self.centres, self.d2,
                        self.hmin, self.hmax, self.offsets, self.levels, self.stamp, self.frame,
                        camera.eye, planes, ROETTGER, C, c, cull, self.lists, self.counts)
        if not full and self.levels > 0:
            if unreduce_finest(self.heightmap.size - 1, self.heightmap.spacing, self.levels,
                       self.offsets, self.stamp, self.frame, self.lists, self.counts,
                       self.skip_error, self.hmin, self.hmax, camera.eye, planes, lam,
                       float(tau), cull):
                balance(self.offsets, self.levels, self.stamp, self.frame, self.lists,
                        self.counts)
        while True:
            leaf_count, _ = leaves(self.heightmap.size - 1, self.heightmap.spacing, self.hmin,
                                   self.hmax, self.offsets, self.levels, self.stamp, self.frame,
                                   planes, cull, self.leaf_rows)
            if leaf_count >= 0:
                break
            self.leaf_rows = np.zeros((2 * len(self.leaf_rows), 4), np.int64)
        self.leaf_count = leaf_count
        return tested, leaf_count

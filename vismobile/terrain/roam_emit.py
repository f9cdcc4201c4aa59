"""ROAM's emission by cached blocks (incremental ROAM, issue 30).

A leaf triangle belongs to the split diamond it halves (its first vertex); diamonds are
grouped in square blocks of B x B samples by their split vertex. Each block keeps its
triangles (uncut by the frustum) and the box of their vertices; a frame re-emits only the
blocks whose triangles may have changed, those holding a diamond that split or merged this
frame or one of its two parents (a parent's triangle on that side is replaced), and draws
the blocks whose box meets the frustum. Re-emitting a block reads its diamonds from the sorted
split list by one binary search per row. So the emission follows the motion, like the queues;
the price is that partly visible blocks send their triangles outside the frustum too.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from ..geometry.planes import classify_boxes
from .bintree import _geometry


@njit(cache=True)
def _emit_block(heights, n, split, alive, alive_count, r0, r1, c0, c1, spacing, out, box):
    """Triangles (sample ids, counter-clockwise from +y) of the split diamonds whose vertex
    lies in rows [r0, r1) and columns [c0, c1), into out; box[:] = (x0, y0, z0, x1, y1, z1) of
    their vertices. Returns the count (-1: out too small)."""
    N = heights.shape[0]
    g = np.empty((4, 2), np.int64)
    count = 0
    box[0] = box[1] = box[2] = np.inf
    box[3] = box[4] = box[5] = -np.inf
    for r in range(r0, r1):
        lo = np.searchsorted(alive[:alive_count], r * N + c0)
        hi = np.searchsorted(alive[:alive_count], r * N + c1)
        for i in range(lo, hi):
            v = alive[i]
            rv, cv = v // N, v % N
            h, sq = _geometry(rv, cv, n, g)
            virtual = (not sq) and h == 1
            for k in range(2):
                if g[k, 0] < 0:
                    continue
                for e in range(2, 4):
                    if not virtual:
                        m = ((g[k, 0] + g[e, 0]) // 2) * N + (g[k, 1] + g[e, 1]) // 2
                        if split[m]:
                            continue
                    if count == out.shape[0]:
                        return -1
                    ar, ac, er, ec = g[k, 0], g[k, 1], g[e, 0], g[e, 1]
                    cross = (ar - rv) * (ec - cv) - (ac - cv) * (er - rv)
                    out[count, 0] = v
                    if cross > 0:
                        out[count, 1], out[count, 2] = ar * N + ac, er * N + ec
                    else:
                        out[count, 1], out[count, 2] = er * N + ec, ar * N + ac
                    for q in range(3):
                        s = out[count, q]
                        x, z, y = (s % N) * spacing, (s // N) * spacing, heights[s // N, s % N]
                        box[0], box[1], box[2] = min(box[0], x), min(box[1], y), min(box[2], z)
                        box[3], box[4], box[5] = max(box[3], x), max(box[4], y), max(box[5], z)
                    count += 1
    return count


@njit(cache=True)
def _emit_blocks(heights, n, split, alive, alive_count, blocks, block, per_side, spacing, out,
                 offsets, boxes):
    """_emit_block for each of blocks (K,): triangles into out[offsets[k]:offsets[k + 1]],
    boxes (K, 6). Returns the total, or -1 when out is too small."""
    N = heights.shape[0]
    total = 0
    offsets[0] = 0
    box = np.empty(6)
    for k in range(blocks.shape[0]):
        bi, bj = blocks[k] // per_side, blocks[k] % per_side
        r0, c0 = bi * block, bj * block
        r1 = N if bi == per_side - 1 else r0 + block
        c1 = N if bj == per_side - 1 else c0 + block
        t = _emit_block(heights, n, split, alive, alive_count, r0, r1, c0, c1, spacing,
                        out[total:], box)
        if t < 0:
            return -1
        total += t
        offsets[k + 1] = total
        for q in range(6):
            boxes[k, q] = box[q] if t else 0.0
    return total


@njit(cache=True)
def _dirty(changed, count, n, N, block, per_side, flags):
    """flags[b] = True for the blocks of each changed diamond and of its parents."""
    g = np.empty((4, 2), np.int64)
    for i in range(count):
        v = changed[i]
        r, c = v // N, v % N
        flags[min(r // block, per_side - 1) * per_side + min(c // block, per_side - 1)] = True
        _geometry(r, c, n, g)
        for k in range(2):
            if g[k, 0] >= 0:
                b = min(g[k, 0] // block, per_side - 1) * per_side + \
                    min(g[k, 1] // block, per_side - 1)
                flags[b] = True


class BlockEmitter:
    """Cached per-block triangles of one Roam mesh."""

    def __init__(self, heights, n: int, spacing: float, block: int = 32):
        self.heights = heights
        self.n = n
        self.N = heights.shape[0]
        S = self.N - 1
        self.block = min(block, S)
        self.per_side = S // self.block
        count = self.per_side ** 2
        self.tris = [np.zeros((0, 3), np.int64)] * count
        self.counts = np.zeros(count, np.int64)
        self.boxes = np.zeros((count, 2, 3))
        self.flags = np.ones(count, np.bool_)
        self.spacing = spacing
        self.out = np.zeros((1 << 16, 3), np.int64)
        self.rebuilt = 0

    def invalidate(self):
        self.flags[:] = True

    def mark(self, changed, count):
        _dirty(changed, count, self.n, self.N, self.block, self.per_side, self.flags)

    def emit(self, split, alive, alive_count, planes, cull) -> np.ndarray:
        """(T, 3) int64 triangles of the blocks whose box meets the frustum (all with cull
        False), re-emitting the dirty ones first."""
        dirty = np.flatnonzero(self.flags)
        offsets = np.zeros(len(dirty) + 1, np.int64)
        boxes = np.zeros((len(dirty), 6))
        while True:
            total = _emit_blocks(self.heights, self.n, split, alive, alive_count, dirty,
                                 self.block, self.per_side, self.spacing, self.out, offsets,
                                 boxes)
            if total >= 0:
                break
            self.out = np.zeros((2 * len(self.out), 3), np.int64)
        for k, b in enumerate(dirty.tolist()):
            self.tris[b] = self.out[offsets[k]:offsets[k + 1]].copy()
        self.counts[dirty] = np.diff(offsets)
        self.boxes[dirty] = boxes.reshape(-1, 2, 3)
        self.flags[:] = False
        self.rebuilt = len(dirty)
        live = np.flatnonzero(self.counts)
        if cull and len(live):
            live = live[~classify_boxes(self.boxes[live], planes)[0]]
        parts = [self.tris[b] for b in live.tolist()]
        return np.concatenate(parts) if parts else np.zeros((0, 3), np.int64)

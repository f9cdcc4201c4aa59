"""The distinct gather: sorted unique triangle ids of a frame's draw nodes, from (word, mask)
pairs built once per tree, and per-level lists that let a node accepted whole read each of its
triangles once instead of once per leaf that references it.

Per frame (numba, cached on disk) the ids go into a two-level bitmap: one bit per triangle, and
one summary bit per 64-bit word of it, so that only the summary words touched are listed and
sorted (T / 4096 at most, a few hundred in practice) and read back in order, with the words and
the ids under them; both levels are cleared as they are read. Nothing of size T is cleared or
scanned per frame.

The references are not read one by one: a leaf's ids falling in one 64-id word of the bitmap
are stored as one pair (word, mask) and marked with one OR (the 20 M world's 26.9 M references
make 2.0 M pairs; the tiled W2 at octree 8, 26.4 M make 12.3 M).

Leaves share triangles (an octree leaf references every triangle overlapping it): in the tiled
W2 at octree depth 8, 26.4 M references name 5.0 M triangles, and a node accepted whole near the
root reads 5x more references than it holds triangles. `first_depths` gives each reference the
depth of the highest ancestor of its leaf in whose subtree it is its triangle's first reference;
the references of depth <= c list each triangle of every depth-c subtree once, and as pairs per
depth-c node (its ids sorted) they take fewer words than its leaves' pairs. A node at depth d
reads the pairs of the finest such list kept at a level c >= d, or of all its references when
none is kept (`Groups`).
"""
from __future__ import annotations

import sys

import numpy as np
from numba import njit

from .prefetch import prefetch

_ONE = np.uint64(1)
_FULL = np.uint64(0xFFFFFFFFFFFFFFFF)
_M1 = np.uint64(0x5555555555555555)
_M2 = np.uint64(0x3333333333333333)
_M4 = np.uint64(0x0F0F0F0F0F0F0F0F)
_H01 = np.uint64(0x0101010101010101)
# De Bruijn sequence for the index of a word's lowest set bit (no count-trailing-zeros in numba).
_DEBRUIJN = np.uint64(0x03F79D71B4CB0A89)
_BIT_INDEX = np.zeros(64, dtype=np.int64)
_BIT_INDEX[((np.uint64(1) << np.arange(64, dtype=np.uint64)) * _DEBRUIJN) >> np.uint64(58)] = \
    np.arange(64)

# A level's list is kept when it holds at most this share of the references of the next finer
# list kept (or of tri_refs), and while all kept lists together hold at most MAX_COARSE times
# tri_refs' references (their pairs are fewer still).
KEEP_RATIO = 0.75
MAX_COARSE = 1.5
# Segments of at most this many ids are sorted before pairing (level_groups).
SORT_LIMIT = 1 << 16


@njit(cache=True, nogil=True, inline="always")
def _popcount(x):
    x = x - ((x >> _ONE) & _M1)
    x = (x & _M2) + ((x >> np.uint64(2)) & _M2)
    x = (x + (x >> np.uint64(4))) & _M4
    return np.int64((x * _H01) >> np.uint64(56))


@njit(cache=True, nogil=True)
def mark_nodes(words, masks, span, nodes, bits, summary, tops, ranges):
    """Mark the triangle ids of the nodes' subtrees in the two-level bitmap; returns the summary
    words listed in tops. Exact: an id is marked iff a node's pairs hold it.

    words, masks : (G,) uint32 / uint64 pairs;  span : (N, 2) node n reads pairs
    span[n, 0]:span[n, 1]
    (Groups). A frame's nodes are scattered in memory: their spans are read first, in a loop
    of independent loads (the misses overlap; 25% less time at 5.0M), then their pairs.
    bits : (T // 64 + 1,) uint64;  summary, tops : (T // 4096 + 1,) uint64 / int64 scratch;
    bits and summary all zero on entry (extract_marked clears them); ranges : (>= len(nodes),
    2) int64 scratch
    """
    for k in range(len(nodes)):
        node = nodes[k]
        ranges[k, 0] = span[node, 0]
        ranges[k, 1] = span[node, 1]
    ntops = 0
    ahead = 4  # spans whose first pairs are asked for before they are read
    for k in range(min(ahead, len(nodes))):
        prefetch(words, ranges[k, 0])
        prefetch(masks, ranges[k, 0])
    for k in range(len(nodes)):
        if k + ahead < len(nodes):
            prefetch(words, ranges[k + ahead, 0])
            prefetch(masks, ranges[k + ahead, 0])
        for g in range(ranges[k, 0], ranges[k, 1]):
            w = np.int64(words[g])
            old = bits[w]
            if old == 0:  # first ids of their word: list its summary word when new
                s = w >> 6
                above = summary[s]
                if above == 0:
                    tops[ntops] = s
                    ntops += 1
                summary[s] = above | (_ONE << np.uint64(w & 63))
            bits[w] = old | masks[g]
    return ntops


@njit(cache=True, nogil=True)
def count_marked(bits, summary, tops, ntops):
    """Number of ids marked (one popcount per touched word); sorts tops[:ntops] for
    extract_marked. Cost follows the words touched."""
    tops[:ntops].sort()
    total = 0
    for k in range(ntops):
        s = tops[k]
        y = summary[s]
        while y:
            low = y & (~y + _ONE)
            y ^= low
            total += _popcount(bits[(s << 6) + _BIT_INDEX[(low * _DEBRUIJN) >> np.uint64(58)]])
    return total


@njit(cache=True, nogil=True)
def extract_marked(bits, summary, tops, ntops, out):
    """Write the marked ids ascending into out (>= count_marked ids; tops sorted by it) and
    clear both bitmap levels; returns the runs of consecutive ids among them (draw batches)."""
    count = 0
    runs = 0
    following = np.int64(-1)  # the id that would continue the current run
    for k in range(ntops):
        s = tops[k]
        y = summary[s]
        summary[s] = 0
        while y:
            low = y & (~y + _ONE)
            y ^= low
            w = (s << 6) + _BIT_INDEX[(low * _DEBRUIJN) >> np.uint64(58)]
            x = bits[w]
            bits[w] = 0
            base = w << 6
            if x == _FULL:  # dense runs are common: whole rooms and objects in view
                if base != following:
                    runs += 1
                for b in range(64):
                    out[count + b] = base + b
                count += 64
                following = base + 64
                continue
            while x:
                bit = x & (~x + _ONE)
                x ^= bit
                t = base + _BIT_INDEX[(bit * _DEBRUIJN) >> np.uint64(58)]
                if t != following:
                    runs += 1
                out[count] = t
                count += 1
                following = t + 1
    return runs


class Bitmap:
    """The two-level bitmap's scratch for T triangles, allocated once per tree and reused, and
    the frames' id arrays.

    An id array is a view of a pooled buffer; a buffer is reused once no view of it is alive
    (the caller dropped last frame's result), so a frame's ids land on memory already paged in
    instead of a fresh allocation (at 2 M ids, faulting 16 MB in cost as much as writing it).
    """

    POOL = 2

    def __init__(self, triangle_count: int):
        words = triangle_count // 64 + 1
        self.bits = np.zeros(words, dtype=np.uint64)
        self.summary = np.zeros(words // 64 + 1, dtype=np.uint64)
        self.tops = np.empty(words // 64 + 1, dtype=np.int64)
        self.ranges = np.empty((64, 2), dtype=np.int64)
        self.pool = []

    def node_ranges(self, count: int) -> np.ndarray:
        """(>= count, 2) int64 scratch for mark_nodes, grown as needed."""
        if len(self.ranges) < count:
            self.ranges = np.empty((2 * count, 2), dtype=np.int64)
        return self.ranges

    def output(self, size: int) -> np.ndarray:
        """(size,) int64 uninitialised, a view of a pooled buffer when one is free."""
        for k, buffer in enumerate(self.pool):
            # References: the pool, `buffer`, getrefcount's argument; a live view adds one.
            if sys.getrefcount(buffer) <= 3:
                if len(buffer) < size:
                    buffer = self.pool[k] = np.empty(size + size // 4, dtype=np.int64)
                return buffer[:size]
        buffer = np.empty(size + size // 4, dtype=np.int64)
        if len(self.pool) < self.POOL:
            self.pool.append(buffer)
        return buffer[:size]


# ---- built once per tree -------------------------------------------------------------------
@njit(cache=True, nogil=True)
def first_depths(tri_refs, leaves, parent, depth, ref_start, ref_end, last):
    """(R,) uint8 per reference: the depth (capped at 255) of the highest ancestor of its leaf
    (or the leaf) in whose subtree it is the first reference of its triangle. Exact below 255.

    leaves : non-empty leaves in ascending ref_start;  parent, depth : (N,) int64 (root -1, 0)
    last   : (T,) int scratch, all -1 on entry (left holding each triangle's last reference)
    """
    fd = np.empty(len(tri_refs), dtype=np.uint8)
    chain = np.empty(depth.max() + 2 if len(depth) else 1, dtype=np.int64)
    for k in range(len(leaves)):
        leaf = leaves[k]
        top = 0
        a = leaf
        while a >= 0:  # chain[top - 1] is the root, chain[0] the leaf
            chain[top] = ref_start[a]
            top += 1
            a = parent[a]
        d_leaf = depth[leaf]
        for r in range(ref_start[leaf], ref_end[leaf]):
            t = tri_refs[r]
            previous = last[t]
            last[t] = r
            j = top - 1
            while j > 0 and chain[j] <= previous:
                j -= 1
            d = d_leaf - j  # chain[j] is the ancestor j levels above the leaf
            fd[r] = min(d, 255)
    return fd


@njit(cache=True, nogil=True)
def level_groups(tri_refs, fd, level, seg_starts, words, masks):
    """Pairs (word, mask) of the references with fd <= level, segment by segment: a segment's
    ids, sorted, make one pair per 64-id word they fall in. Fills words and masks when they are
    not empty (else only counts); returns (S + 1,) int64 offsets of each segment's first pair
    (segment i: tri_refs[seg_starts[i]:seg_starts[i + 1]], ascending starts) and of the end."""
    fill = len(words) > 0
    nseg = len(seg_starts)
    offsets = np.empty(nseg + 1, dtype=np.int64)
    longest = 0
    for k in range(nseg):
        stop = seg_starts[k + 1] if k + 1 < nseg else len(tri_refs)
        longest = max(longest, stop - seg_starts[k])
    ids = np.empty(longest, dtype=np.int64)
    count = 0
    for k in range(nseg):
        offsets[k] = count
        stop = seg_starts[k + 1] if k + 1 < nseg else len(tri_refs)
        n = 0
        ascending = True
        for r in range(seg_starts[k], stop):
            if fd[r] <= level:
                ids[n] = tri_refs[r]
                ascending = ascending and (n == 0 or ids[n] > ids[n - 1])
                n += 1
        chosen = ids[:n]
        # A level's segment lists its leaves' first references leaf by leaf: sorted, its ids
        # take fewer words. Long segments (shallow levels, rarely accepted whole) stay as
        # they are: sorting them would cost seconds at 20 M references.
        if not ascending and n <= SORT_LIMIT:
            chosen.sort()  # in place
        current = np.int64(-1)
        for i in range(n):
            t = chosen[i]
            w = t >> 6
            if w != current:
                if fill:
                    words[count] = w
                    masks[count] = 0
                count += 1
                current = w
            if fill:
                masks[count - 1] |= _ONE << np.uint64(t & 63)
    offsets[nseg] = count
    return offsets


def choose_levels(counts, leaf_refs) -> list:
    """Levels to keep, deepest first, from counts[c] = references of fd <= c (c below the
    deepest leaf): each at most KEEP_RATIO of the next finer kept (tri_refs first), all together
    at most MAX_COARSE * leaf_refs references."""
    kept, finer, total = [], leaf_refs, 0
    for c in range(len(counts) - 1, -1, -1):
        if counts[c] <= KEEP_RATIO * finer and total + counts[c] <= MAX_COARSE * leaf_refs:
            kept.append(c)
            finer = counts[c]
            total += counts[c]
    return kept


class Groups:
    """The pairs every node reads (see the module docstring).

    words, masks : (G,) uint32 / uint64 the pairs of all references (tri_refs, leaf by leaf),
                   then of each kept level's list (12 bytes a pair: at 20 M triangles and
                   octree 7, 16.5 M pairs)
    span         : (N, 2) node n reads pairs span[n, 0]:span[n, 1] (start, end: its columns):
                   its kept level's when its depth is at most a kept level, else its
                   references'
    levels       : kept levels, deepest first
    """

    ALL = 255  # first depths are at most 255: the list of every reference

    def __init__(self, tree):
        p = tree.partition
        refs = tree.tri_refs
        n = tree.node_count
        self.levels = []
        self._columns(np.zeros(0, dtype=np.uint32), np.zeros(0, dtype=np.uint64),
                      np.zeros((n, 2), dtype=np.int32))
        if n == 0 or len(refs) == 0:
            return
        level_start = np.asarray(p.level_start, dtype=np.int64)
        depth = np.repeat(np.arange(len(level_start) - 1, dtype=np.int64), np.diff(level_start))
        parent = np.full(n, -1, dtype=np.int64)
        inner = np.flatnonzero(tree.child_count > 0)
        parent[np.repeat(tree.first_child[inner], tree.child_count[inner])
               + _ranks(tree.child_count[inner])] = np.repeat(inner, tree.child_count[inner])
        leaves = tree.leaf_order[tree.nonempty[tree.leaf_order]]
        index = np.int32 if len(refs) < 2 ** 31 else np.int64
        last = np.full(tree.world.triangle_count, -1, dtype=index)
        fd = first_depths(refs, leaves, parent, depth, tree.ref_start, tree.ref_end, last)
        del last
        deepest = int(depth[leaves].max())
        counts = np.cumsum(np.bincount(fd, minlength=256))[:min(deepest, self.ALL)]
        self.levels = choose_levels(counts, len(refs))
        leaf = tree.child_count == 0
        lists = [self.ALL] + self.levels
        # A list's segments: its level's nodes and the leaves above it (all leaves for ALL).
        cuts = [np.sort(tree.ref_start[(depth == c) | (leaf & (depth < c))]) for c in lists]
        none = np.zeros(0, dtype=np.int32)
        sizes = [int(level_groups(refs, fd, c, cut, none, none)[-1])
                 for c, cut in zip(lists, cuts)]
        index = np.int32 if sum(sizes) < 2 ** 31 else np.int64
        self._columns(np.empty(sum(sizes), dtype=np.uint32), np.empty(sum(sizes), dtype=np.uint64),
                      np.empty((n, 2), dtype=index))
        base = 0
        for c, cut, size in zip(lists, cuts, sizes):  # all references, then the deepest kept
            offsets = base + level_groups(refs, fd, c, cut, self.words[base:], self.masks[base:])
            upto = n if c == self.ALL else int(level_start[c + 1])  # shallower overwrite
            # a node's segments are those starting inside its range (empty ones add nothing)
            self.start[:upto] = offsets[np.searchsorted(cut, tree.ref_start[:upto], "left")]
            self.end[:upto] = offsets[np.searchsorted(cut, tree.ref_end[:upto], "left")]
            base += size

    def _columns(self, words, masks, span) -> None:
        self.words, self.masks, self.span = words, masks, span
        self.start, self.end = span[:, 0], span[:, 1]


def _ranks(counts) -> np.ndarray:
    """0..k-1 for each count k, concatenated."""
    total = int(counts.sum())
    starts = np.repeat(np.cumsum(counts) - counts, counts)
    return np.arange(total, dtype=np.int64) - starts

"""The PVS's pattern bits, arithmetic-coded (pvs_codec.py holds the layout and the checks).

Pattern k is a row of V bits (bit v: view cell v's set holds the pattern's triangles). Rows are
coded in order, each bit with an adaptive binary range coder (LZMA's, 12-bit probabilities)
whose probability is chosen by a context of bits already known to both sides:

    the row's own bits at up to 3 earlier cells next to v (`parents`: largest shared face
    first), and, when the row has references, each reference row's bits at v and at two of
    those cells (the second reference's: W5 -3.6%, W6 -3.1%, W1 +0.4%).

A row's references are the two most similar earlier rows within WINDOW (`references`, chosen
by the encoder, stored as offsets by pvs_codec.py): neighbouring cells see much the same, and
so do neighbouring triangles, so a bit mostly repeats its neighbours' and its references'.
Measured on W5's 3,055 street cells (1,945 patterns): 154 KB against 197 KB for the packed
bits under lzma and 305 KB under zlib (docs/partition.md). Tried and not kept: two adaptation
rates mixed, per-row and per-cell disagreement states in the context (each 1-5% larger).

The decoder is bounded: it writes exactly K x V bits, reads at most the stream's bytes (a read
past the end is an error, not a zero), and each coded bit costs at least MIN_BITS of the
stream (probabilities stay within [15, 4081] / 4096), so K x V <= len(stream) x 8 / MIN_BITS for
any stream the encoder wrote: pvs_codec.py refuses a larger claim before decoding.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

PROB_BITS = 12
SHIFT = 4  # adaptation rate: W5, W1 and W6 measured 4 best of 4-6
TOP = 1 << 24
PARENTS = 3  # earlier neighbour cells in a bit's context
CELL_WINDOW = 1024  # parents are sought among this many earlier cells
WINDOW = 2048  # references are sought among this many earlier rows
CONTEXTS = 1 << 10
# the least a coded bit costs, in bits of the stream: -log2(4081 / 4096)
MIN_BITS = -math.log2(((1 << PROB_BITS) - 15) / (1 << PROB_BITS))


NEIGHBOURS = 8  # earlier face neighbours kept per cell for the groups' parents


@njit(cache=True)
def neighbours(boxes, window, slots):
    """((V, slots) int64, (V, slots) float64): for each cell the earlier cells (within `window`
    before it) whose closed box meets its own over an area (a shared face or more), largest
    area first, lower index on ties, and those areas; -1 and 0 where fewer exist. boxes
    (V, 2, 3) float64, decoded exactly."""
    count = boxes.shape[0]
    out = np.full((count, slots), -1, dtype=np.int64)
    score = np.zeros((count, slots), dtype=np.float64)
    lap = np.empty(3, dtype=np.float64)
    for v in range(count):
        n = 0
        for u in range(max(0, v - window), v):
            meets = True
            for a in range(3):
                lap[a] = min(boxes[u, 1, a], boxes[v, 1, a]) - max(boxes[u, 0, a], boxes[v, 0, a])
                if lap[a] < 0.0:
                    meets = False
            if not meets:
                continue
            lap.sort()
            s = lap[2] * lap[1]
            if s <= 0.0:
                continue
            # insert by descending score (u ascends, so an equal score keeps the lower index)
            j = 0
            while j < n and score[v, j] >= s:
                j += 1
            if j == slots:
                continue
            for i in range(min(n, slots - 1), j, -1):
                score[v, i] = score[v, i - 1]
                out[v, i] = out[v, i - 1]
            score[v, j] = s
            out[v, j] = u
            n = min(n + 1, slots)
    return out, score


def group_parents(near, area, group, groups: int) -> np.ndarray:
    """(G, PARENTS) int64: for each column group (cells sharing one set, pvs_codec.py) the
    earlier groups it meets most, by the summed areas of its cells' faces shared with theirs
    (`neighbours`' pairs, either way round), largest first, lower index on ties; -1 where fewer
    exist. With one cell per group (group = arange(V)) these are `parents`."""
    near = np.asarray(near, dtype=np.int64)
    cells, slots = near.shape
    v = np.repeat(np.arange(cells, dtype=np.int64), slots)
    u = near.ravel()
    keep = u >= 0
    gu, gv, a = group[u[keep]], group[v[keep]], np.asarray(area).ravel()[keep]
    apart = gu != gv
    hi = np.maximum(gu, gv)[apart]
    lo = np.minimum(gu, gv)[apart]
    out = np.full((groups, PARENTS), -1, dtype=np.int64)
    if not len(hi):
        return out
    keys, inverse = np.unique(hi * groups + lo, return_inverse=True)
    sums = np.bincount(np.asarray(inverse).ravel(), weights=a[apart])
    hi, lo = keys // groups, keys % groups
    order = np.lexsort((lo, -sums, hi))
    hi, lo = hi[order], lo[order]
    rank = np.arange(len(hi)) - np.searchsorted(hi, hi)  # place within its group
    take = rank < PARENTS
    out[hi[take], rank[take]] = lo[take]
    return out


def parents(boxes, window) -> np.ndarray:
    """(V, PARENTS) int64 for each cell the earlier cells (within `window` before it) whose
    closed box meets its own over an area (a shared face or more), largest area first, lower
    index on ties; -1 where fewer exist (group_parents with a group per cell)."""
    near, area = neighbours(np.ascontiguousarray(boxes, dtype=np.float64), window, PARENTS)
    count = len(near)
    return group_parents(near, area, np.arange(count, dtype=np.int64), count)


@njit(cache=True)
def _popcount(x):
    x = x - ((x >> np.uint64(1)) & np.uint64(0x5555555555555555))
    x = (x & np.uint64(0x3333333333333333)) + ((x >> np.uint64(2)) & np.uint64(0x3333333333333333))
    x = (x + (x >> np.uint64(4))) & np.uint64(0x0F0F0F0F0F0F0F0F)
    return (x * np.uint64(0x0101010101010101)) >> np.uint64(56)


@njit(cache=True)
def _references(words, window):
    count, width = words.shape
    out = np.zeros((count, 2), dtype=np.int64)  # offsets back, 0: none
    for k in range(1, count):
        best1 = best2 = 1 << 62
        for j in range(k - 1, max(0, k - window) - 1, -1):  # nearest first: ties keep it
            d = 0
            for w in range(width):
                d += _popcount(words[k, w] ^ words[j, w])
                if d >= best2:
                    break
            if d < best1:
                best2 = best1
                out[k, 1] = out[k, 0]
                best1 = d
                out[k, 0] = k - j
            elif d < best2:
                best2 = d
                out[k, 1] = k - j
    return out


def references(patterns, window=WINDOW) -> np.ndarray:
    """(K, 2) int64 offsets back to each row's two nearest earlier rows (Hamming distance,
    within window; nearer offset on ties), 0 where there is none."""
    patterns = np.asarray(patterns, dtype=np.uint8)
    pad = (-patterns.shape[1]) % 8
    words = np.ascontiguousarray(np.pad(patterns, ((0, 0), (0, pad)))).view(np.uint64)
    return _references(words, window)


@njit(inline="always")
def _unpack(rows, k, out):
    """Row k's bits into out[:cells] (one byte each; out[cells], the missing parent, stays 0)."""
    for v in range(len(out) - 1):
        out[v] = (rows[k, v >> 3] >> (7 - (v & 7))) & 1


@njit(inline="always")
def _context(own, first, second, v, par, referred):
    """The context of bit v: own (this row so far), first and second (the references' bits,
    zeros without them) unpacked, par with -1 replaced by the zero slot at the end."""
    p0, p1 = par[v, 0], par[v, 1]
    c = 4 * own[p0] + 2 * own[p1] + own[par[v, 2]]
    if not referred:
        return c
    c = 8 * c + 4 * first[v] + 2 * first[p0] + first[p1]
    c = 8 * c + 4 * second[v] + 2 * second[p0] + second[p1]
    return 2 * c + 1


@njit(cache=True)
def _row_refs(rows, k, refs, first, second):
    """Unpack row k's references into first and second (zeros where none); True if any."""
    if refs[k, 0] == 0:
        return False
    _unpack(rows, k - refs[k, 0], first)
    if refs[k, 1] > 0:
        _unpack(rows, k - refs[k, 1], second)
    else:
        second[:] = 0
    return True


@njit(inline="always")
def _shift_low(low, cache, pending, out, n):
    """LZMA's shift_low: emit the cached byte, and the 0xFF bytes pending behind it, once no
    carry can reach them; (low, cache, pending, out, n), out grown when full."""
    if low < 0xFF000000 or low >= 0x100000000:
        carry = low >> 32
        byte = cache
        while pending > 0:
            if n == len(out):
                grown = np.empty(2 * n, dtype=np.uint8)
                grown[:n] = out
                out = grown
            out[n] = (byte + carry) & 0xFF
            n += 1
            byte = 0xFF
            pending -= 1
        cache = (low >> 24) & 0xFF
    return (low & 0x00FFFFFF) << 8, cache, pending + 1, out, n


@njit(cache=True)
def _encode(rows, cells, refs, par):
    out = np.empty(1024, dtype=np.uint8)
    n = 0
    prob = np.full(CONTEXTS, 1 << (PROB_BITS - 1), dtype=np.int64)
    low = 0
    span = 0xFFFFFFFF
    cache = 0
    pending = 1
    own = np.zeros(cells + 1, dtype=np.int64)
    first = np.zeros(cells + 1, dtype=np.int64)
    second = np.zeros(cells + 1, dtype=np.int64)
    for k in range(rows.shape[0]):
        referred = _row_refs(rows, k, refs, first, second)
        _unpack(rows, k, own)
        for v in range(cells):
            c = _context(own, first, second, v, par, referred)
            bound = (span >> PROB_BITS) * prob[c]
            if own[v] == 0:
                span = bound
                prob[c] += ((1 << PROB_BITS) - prob[c]) >> SHIFT
            else:
                low += bound
                span -= bound
                prob[c] -= prob[c] >> SHIFT
            while span < TOP:
                span = (span << 8) & 0xFFFFFFFF
                low, cache, pending, out, n = _shift_low(low, cache, pending, out, n)
    for _ in range(5):  # flush
        low, cache, pending, out, n = _shift_low(low, cache, pending, out, n)
    return out[:n]


@njit(cache=True)
def _decode(stream, count, cells, refs, par):
    """(rows (count, ceil(cells / 8)) uint8, bytes read, or -1 when the stream ran out)."""
    rows = np.zeros((count, (cells + 7) >> 3), dtype=np.uint8)
    prob = np.full(CONTEXTS, 1 << (PROB_BITS - 1), dtype=np.int64)
    if len(stream) < 5:
        return rows, -1
    code = 0
    for i in range(1, 5):  # the first byte is the encoder's initial cache, always 0
        code = (code << 8) | stream[i]
    pos = 5
    span = 0xFFFFFFFF
    own = np.zeros(cells + 1, dtype=np.int64)
    first = np.zeros(cells + 1, dtype=np.int64)
    second = np.zeros(cells + 1, dtype=np.int64)
    for k in range(count):
        referred = _row_refs(rows, k, refs, first, second)
        for v in range(cells):
            c = _context(own, first, second, v, par, referred)
            bound = (span >> PROB_BITS) * prob[c]
            if code < bound:
                span = bound
                prob[c] += ((1 << PROB_BITS) - prob[c]) >> SHIFT
                own[v] = 0
            else:
                code -= bound
                span -= bound
                prob[c] -= prob[c] >> SHIFT
                own[v] = 1
                rows[k, v >> 3] |= np.uint8(1 << (7 - (v & 7)))
            while span < TOP:
                if pos >= len(stream):
                    return rows, -1
                span = (span << 8) & 0xFFFFFFFF
                code = ((code << 8) | stream[pos]) & 0xFFFFFFFF
                pos += 1
    return rows, pos


def _slots(par, cells) -> np.ndarray:
    """par (V, PARENTS) with a missing parent (-1) pointing at the zero slot `cells`."""
    par = np.asarray(par, dtype=np.int64)
    return np.ascontiguousarray(np.where(par < 0, cells, par))


def encode_rows(rows, cells: int, refs, par) -> np.ndarray:
    """(N,) uint8 range-coded stream of rows (K, ceil(cells / 8)) uint8 packed bits."""
    return _encode(np.ascontiguousarray(rows, dtype=np.uint8), int(cells),
                   np.ascontiguousarray(refs, dtype=np.int64), _slots(par, cells)).copy()


def decode_rows(stream, count: int, cells: int, refs, par) -> np.ndarray:
    """rows (count, ceil(cells / 8)) uint8 of a stream encode_rows wrote; ValueError when the
    stream ends early, holds bytes past its end, or does not start as the encoder's does."""
    stream = np.ascontiguousarray(stream, dtype=np.uint8)
    if len(stream) and stream[0] != 0:
        raise ValueError("the pattern stream does not start with the coder's zero byte")
    rows, used = _decode(stream, int(count), int(cells),
                         np.ascontiguousarray(refs, dtype=np.int64), _slots(par, cells))
    if used < 0:
        raise ValueError("the pattern stream ends before its patterns do")
    if used != len(stream):
        raise ValueError("the pattern stream holds bytes after its patterns")
    return rows

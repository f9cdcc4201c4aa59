"""`pvs` with `vfc` in one compiled call: the frustum walk skips the subtrees holding no
triangle of the eye's set, the distinct gather marks what the accepted nodes hold, and the
set's bits clear what it leaves out, word by word (culling/pvs.py hands this on when vfc is
the only node stage after it: Culler._fuse).

The walk visits a subset of the nodes vfc visits from the root, and each word the gather
touched costs one AND, so a frame costs no more than vfc's walk and gather plus the lookup;
nothing in it follows the world's size. What it sends is exactly what the staged path sends
(pvs's topmost nodes, vfc's walk from them, the gather and the per-triangle filter): the
triangles of the set in the leaves the frustum does not reject. A node's box holds its
children's (partition/tight.py), so a leaf is rejected from the root exactly when it is from
any of its ancestors; a subtree accepted whole may hold leaves outside the set, and the bits
take their triangles out.
"""
from __future__ import annotations

import numpy as np
from numba import njit, types
from numba.experimental import structref

from .gather import _ONE, _popcount, count_marked, extract_marked, mark_nodes
from .kernels import frustum_walk
from .pvs_lookup import find


def keep_bits(keep) -> np.ndarray:
    """(T // 64 + 1,) uint64: bit t & 63 of word t >> 6 set when keep[t] (the bitmap's layout,
    gather.py)."""
    keep = np.asarray(keep, dtype=bool)
    words = np.zeros((len(keep) // 64 + 1) * 64, dtype=bool)
    words[:len(keep)] = keep
    return np.packbits(words, bitorder="little").view("<u8").astype(np.uint64)


@njit(cache=True, nogil=True)
def mask_marked(bits, summary, tops, ntops, kept):
    """AND each marked word of the two-level bitmap with kept (same layout); a word left empty
    leaves its summary bit. Returns how many ids were marked before (the triangles the set
    tested)."""
    before = 0
    for k in range(ntops):
        s = tops[k]
        y = summary[s]
        left = y
        while y:
            low = y & (~y + _ONE)
            y ^= low
            w = (s << 6) + _popcount(low - _ONE)
            x = bits[w]
            before += _popcount(x)
            x &= kept[w]
            bits[w] = x
            if x == 0:
                left ^= low
        summary[s] = left
    return before


@njit(cache=True, nogil=True)
def walk_gather(box, links, size, whole_below, inner, inner_links, covering, planes, tol,
                out, stack_node, stack_set, stack_mask, allow, words, masks, span, bits,
                summary, tops, ranges, kept):
    """One frame of pvs+vfc: (ids (S,) int64 ascending, runs, accepted nodes, visited, plane
    tests, culled, straddling, covered, ids tested by the set).

    planes : (1, P, 4) float64 the frustum's; allow : (N,) bool nodes whose subtree holds a
    triangle of the set, or None (every node); kept : (T // 64 + 1,) uint64 the set's bits
    (keep_bits), or None (the whole world). The rest: kernels.frustum_walk's and
    gather.mark_nodes' arguments (Tree's records, scratch and bitmap). Accepted nodes are
    out[:accepted]."""
    roots = np.zeros(1, dtype=np.int64)
    count, visited, tests, culled, straddling, covered = frustum_walk(
        box, links, size, whole_below, inner, inner_links, covering, roots, roots, planes, tol,
        out, stack_node, stack_set, stack_mask, allow)
    ntops = mark_nodes(words, masks, span, out[:count], bits, summary, tops, ranges)
    tested = 0
    if kept is not None:
        tested = mask_marked(bits, summary, tops, ntops, kept)
    total = count_marked(bits, summary, tops, ntops)
    ids = np.empty(total, dtype=np.int64)
    runs = extract_marked(bits, summary, tops, ntops, ids)
    return ids, runs, count, visited, tests, culled, straddling, covered, tested


@structref.register
class FrameTablesType(types.StructRef):
    """numba's type of FrameTables (fields typed as given, literals widened)."""

    def preprocess_fields(self, fields):
        return tuple((name, types.unliteral(kind)) for name, kind in fields)


class FrameTables(structref.StructRefProxy):
    """What locate_walk_gather reads that stays the same from frame to frame (TABLE_FIELDS:
    the view cells and their buckets, the tree's records, vfc's options, the gather's pairs
    and bitmap, the stage's scratch and counters) in one numba structref: the call unboxes one
    pointer instead of some twenty-five arrays (as occlusion_chain.ChainTables)."""


TABLE_FIELDS = ("cells", "x0", "z0", "size", "nx", "nz", "start", "index", "box", "links",
                "size_of", "whole_below", "inner", "inner_links", "covering", "tol", "scratch",
                "words", "masks", "span", "bits", "summary", "tops", "ranges", "counts",
                "face_coords", "face_start", "slot_key", "slot_allow", "slot_kept", "found")
structref.define_constructor(FrameTables, FrameTablesType, TABLE_FIELDS)
structref.define_boxing(FrameTablesType, FrameTables)


@njit(cache=True)
def pack_tables(fields):
    """FrameTables of the TABLE_FIELDS values, in that order."""
    return FrameTables(*fields)


@njit(cache=True, nogil=True)
def near_plane(coords, start, eye, reach):
    """Whether eye (3,) lies within reach of a plane of coords: per axis a, the sorted (F_a,)
    float64 coordinates coords[start[a]:start[a + 1]] (culling/pvs.py packed_planes).

    A wall closing a cell face lies in the face's plane; from an eye in that plane it is
    edge-on and draws nothing, and a line running in the plane slips through the creases it
    shares with slabs and lintels, which the walk from the face's cells took as closed (W2, eye
    (19.18, 1.55, 8.1)). Such eyes fall back, or take the face sets of a bake that walked the
    planes. Errs toward True: every cell's faces are taken, not only the eye's cells'."""
    for a in range(3):
        lo, hi = start[a], start[a + 1]
        i = lo + np.searchsorted(coords[lo:hi], eye[a])
        if i > lo and abs(coords[i - 1] - eye[a]) <= reach:
            return True
        if i < hi and abs(coords[i] - eye[a]) <= reach:
            return True
    return False


# a slot's key row (FrameTables.slot_key): cells taken, drop_back, face sets, everything, then
# the cells (ascending); 0 cells: an empty slot
KEY_CELLS = 4


@njit(cache=True, nogil=True)
def find_slot(key, found, drop, face):
    """The row of key (S, KEY_CELLS + C) int64 made for the cells found with drop_back drop
    and face sets face, or -1."""
    n = len(found)
    if n > key.shape[1] - KEY_CELLS:
        return -1
    for s in range(key.shape[0]):
        if key[s, 0] != n or key[s, 1] != drop or key[s, 2] != face:
            continue
        same = True
        for k in range(n):
            if key[s, KEY_CELLS + k] != found[k]:
                same = False
                break
        if same:
            return s
    return -1


@njit(cache=True, nogil=True)
def locate_walk_gather(t, x, y, z, pad, face_reach, drop, planes, gather=True):
    """The eye (x, y, z)'s view cells (pvs_lookup.find in t's cells, grown by pad) and whether
    it lies within face_reach of a face plane the bake walked (near_plane over t.face_coords;
    face_reach < 0: never), and, when a slot holds the set made for them (find_slot: the
    cells, drop_back drop, the face sets; its allow and kept bits in t.slot_allow[slot],
    t.slot_kept[slot], or the whole world), walk_gather's frame over t (FrameTables); without
    gather, its walk only (a node stage follows: it gathers and filters the accepted nodes).
    Returns ids (S,) int64 (empty on a miss, when nothing is walked, and without gather; one
    array: a tuple's boxing costs the call a microsecond more); t.counts (>= 12,) int64
    receives the boxes tested, then walk_gather's runs, accepted, visited, plane tests,
    culled, straddling, covered and masked (runs and masked 0 without gather), the slot (-1:
    a miss), the face test's answer and K, the cells found, in t.found[:K]; t.scratch
    (4, >= N + 1) int64 is the walk's out and stacks (accepted nodes are
    scratch[0, :accepted])."""
    eye = np.empty(3, dtype=np.float64)
    eye[0], eye[1], eye[2] = x, y, z
    found, tested = find(t.cells, t.x0, t.z0, t.size, t.nx, t.nz, t.start, t.index, eye, pad)
    face = face_reach >= 0.0 and near_plane(t.face_coords, t.face_start, eye, face_reach)
    counts, scratch = t.counts, t.scratch
    counts[0] = tested
    t.found[:len(found)] = found
    slot = find_slot(t.slot_key, found, drop, face) if len(found) else -1
    counts[9], counts[10], counts[11] = slot, face, len(found)
    if slot < 0:
        return np.empty(0, dtype=np.int64)
    if not gather:
        counts[1] = counts[8] = 0
        roots = np.zeros(1, dtype=np.int64)
        if t.slot_key[slot, 3]:
            counts[2], counts[3], counts[4], counts[5], counts[6], counts[7] = frustum_walk(
                t.box, t.links, t.size_of, t.whole_below, t.inner, t.inner_links, t.covering,
                roots, roots, planes, t.tol, scratch[0], scratch[1], scratch[2], scratch[3],
                None)
        else:
            counts[2], counts[3], counts[4], counts[5], counts[6], counts[7] = frustum_walk(
                t.box, t.links, t.size_of, t.whole_below, t.inner, t.inner_links, t.covering,
                roots, roots, planes, t.tol, scratch[0], scratch[1], scratch[2], scratch[3],
                t.slot_allow[slot])
        return np.empty(0, dtype=np.int64)
    if t.slot_key[slot, 3]:  # the cells see the whole world: vfc's walk and gather
        ids, counts[1], counts[2], counts[3], counts[4], counts[5], counts[6], counts[7], \
            counts[8] = walk_gather(t.box, t.links, t.size_of, t.whole_below, t.inner,
                                    t.inner_links, t.covering, planes, t.tol, scratch[0],
                                    scratch[1], scratch[2], scratch[3], None, t.words,
                                    t.masks, t.span, t.bits, t.summary, t.tops, t.ranges, None)
    else:
        ids, counts[1], counts[2], counts[3], counts[4], counts[5], counts[6], counts[7], \
            counts[8] = walk_gather(t.box, t.links, t.size_of, t.whole_below, t.inner,
                                    t.inner_links, t.covering, planes, t.tol, scratch[0],
                                    scratch[1], scratch[2], scratch[3], t.slot_allow[slot],
                                    t.words, t.masks, t.span, t.bits, t.summary, t.tops,
                                    t.ranges, t.slot_kept[slot])
    return ids

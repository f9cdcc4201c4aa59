"""A PVS coarsened to a size budget (`pvs=conservative` bakes with budget=DEFAULT_BUDGET: at
most a quarter of the world's OBJ bytes, issue 29's target; `budget=F` another share,
`budget=none` the exact sets), as shipping bakes trade data size against accuracy.

Coarsening only ever adds triangles to a cell's set, so a coarsened PVS stays conservative
(a superset of a conservative set is conservative): it merges neighbouring view cells, and
every cell of a merged group takes the union of the group's sets. The codec then codes the
group's set once (pvs_codec.py: cells with one set share a column), so a merge removes a
column of K pattern bits, and the patterns themselves get fewer (rows equal over the groups).

The merges are greedy: at each step the two face-neighbouring groups whose union adds the
fewest triangles facing them (one that faces away from a whole cell is culled with the back
faces at run time), weighted by how likely an eye is in each (its cells' volumes raised to
POWER, as a share; merge_order), merge. The budget fixes how many merges: about the fewest whose encoded PVS
fits (within V / SLACK merges; found by interpolation and bisection in turn on the merge
count, each probe an encode of the groups' columns, so the bytes are exact). Measured on the
thesis worlds (docs/partition.md, "A size budget"), merging cells costs less sent per byte
saved than setting rarely-differing bits (a majority of neighbours) and about the same as
merging triangle patterns.

Before merging, free bits are filled (fill_back): a triangle facing away from a whole cell
grown by pvs_back is left out by the stage when back faces are culled (culling/pvs.py, when
the eye's reach fits in pvs_back; else tbfc culls it for every eye in the grown cell), so
adding it to that cell's set costs nothing sent with back-face culling, and any superset
stays conservative. Each triangle copies those bits from the earlier triangle whose cells
match its own best (its other bits kept), so patterns repeat
and the coder's references fit better: W5's exact PVS 1.303x -> 1.102x the OBJ, W6's 0.665x ->
0.590x, with the same triangles sent by pvs+vfc+tbfc (pvs+vfc, without back faces culled,
sends the added ones when vfc keeps them).

The bytes counted are the PVS's sections as the .vmp stores them (store.stored_bytes of each
stored extra) plus HEADER for their entries; the OBJ's bytes are World.obj_bytes (the file
the world was read from, else what World.to_obj writes).
"""
from __future__ import annotations

import math
import time

import numpy as np
from numba import njit

from . import pvs_coder
from .pvs_codec import DERIVED, encode, encode_columns

FACE_KEYS = ("pvs_face_shape", "pvs_face_pack")  # the face sets' sections (pvs_planes.py)

# budget= : a share of the OBJ's bytes in (0, BUDGET_MAX] (commands/options.py STRUCTURE
# mirrors it; tests/test_cli_options.py checks they agree), or EXACT's words (no coarsening)
BUDGET_MAX = 64.0
# a conservative bake's share when budget= is not given (issue 29: PVS bytes <= 0.25x the OBJ)
DEFAULT_BUDGET = 0.25
EXACT = ("none", "off")
NEIGHBOURS = 16  # earlier face neighbours per cell taken as merge candidates
FILL_WINDOW = 2048  # earlier triangles a triangle's free bits may be copied from (fill_back)
# how likely an eye is in a cell, for the merges' cost: its volume to this power. 2: a cell
# twice as wide (the open street's 8 m cells against the 4 m ones lining buildings) is more
# than twice as likely, as cameras keep clear of walls (docs/partition.md: W5, W6 at 0.25x
# meet 0.7x sent on their paths, 1-1.4% more sent than power 1 from cameras spread by volume)
POWER = 2.0
SLACK = 256  # the merge count is found to within V / SLACK of the fewest that fit
# the .vmp's section entries and padding for the PVS's extras, counted with their bytes:
# HEADER for up to SECTIONS stored sections (measured: 1,176 bytes beyond store.stored_bytes
# on W5, 5 sections), SECTION more for each beyond (W1 repaired with its face sets, 8
# sections: 1,909 measured; HEADER alone let its default bake take 0.251x the OBJ)
HEADER = 1536
SECTIONS = 5
SECTION = 256


def budget_option(value):
    """The budget= option as a share of the OBJ's bytes, or None for the exact sets: not given
    (None) -> DEFAULT_BUDGET; "none" or "off" (any case) -> None; else a finite number in
    (0, BUDGET_MAX]. ValueError in one line otherwise."""
    if value is None:
        return DEFAULT_BUDGET
    if isinstance(value, str) and value.strip().lower() in EXACT:
        return None
    try:
        number = float(value)
    except (TypeError, ValueError):
        number = math.nan
    if isinstance(value, bool) or not (0.0 < number <= BUDGET_MAX):
        raise ValueError(f"budget={value}: expected a share of the OBJ's bytes in "
                         f"(0, {BUDGET_MAX:g}] (e.g. budget=0.25), or budget=none for the "
                         "exact sets")
    return number


def budget_param(value):
    """What a partition's params record of budget= (the .vmp header, the structure text): the
    share, or "none" for the exact sets (budget_option)."""
    share = budget_option(value)
    return "none" if share is None else share


@njit(cache=True)
def _gain(sets, front, g, h):
    """Triangles of set h not in set g that face some point of g's cells (rows of bitsets)."""
    total = 0
    for w in range(sets.shape[1]):
        total += pvs_coder._popcount(sets[h, w] & ~sets[g, w] & front[g, w])
    return total


@njit(cache=True)
def _merge_order(sets, front, chance, edges):
    """(M, 2) int64 the greedy merges (kept group, merged group, by their lowest cells) and
    (M,) float64 what each added (chance-weighted triangles facing the group). sets and front
    (V, W) uint64 triangle bitsets (modified: groups' unions), chance (V,) float64 (modified),
    edges (E, 2) int64 face-neighbouring cells."""
    count = sets.shape[0]
    a, b = edges[:, 0].copy(), edges[:, 1].copy()
    cost = np.empty(len(a), dtype=np.float64)
    for e in range(len(a)):
        cost[e] = chance[a[e]] * _gain(sets, front, a[e], b[e]) \
            + chance[b[e]] * _gain(sets, front, b[e], a[e])
    merges = np.empty((max(count - 1, 0), 2), dtype=np.int64)
    added = np.empty(max(count - 1, 0), dtype=np.float64)
    m = 0
    while True:
        best = -1
        for e in range(len(a)):
            if a[e] != b[e] and (best < 0 or cost[e] < cost[best]):
                best = e
        if best < 0:
            break
        g, h = min(a[best], b[best]), max(a[best], b[best])
        merges[m, 0], merges[m, 1], added[m] = g, h, cost[best]
        m += 1
        sets[g] |= sets[h]
        front[g] |= front[h]
        chance[g] += chance[h]
        for e in range(len(a)):
            if a[e] == h:
                a[e] = g
            if b[e] == h:
                b[e] = g
        for e in range(len(a)):
            if a[e] != b[e] and (a[e] == g or b[e] == g):
                cost[e] = chance[a[e]] * _gain(sets, front, a[e], b[e]) \
                    + chance[b[e]] * _gain(sets, front, b[e], a[e])
    return merges[:m], added[:m]


def _bitsets(bits) -> np.ndarray:
    """(R, ceil(C / 64)) uint64 of (R, C) bool rows."""
    words = (bits.shape[1] + 63) // 64
    packed = np.packbits(np.pad(bits, ((0, 0), (0, 64 * words - bits.shape[1]))), axis=1,
                         bitorder="little")
    return np.ascontiguousarray(packed).view("<u8").astype(np.uint64).reshape(len(bits), words)


def facing(boxes, corners) -> np.ndarray:
    """(V, ceil(T / 64)) uint64 bitsets: the triangles whose plane has some point of the cell
    in front (a triangle facing away from a whole cell costs nothing sent there: back-face
    culling drops it), a few cells at a time."""
    corners = np.asarray(corners, dtype=np.float64)
    normal = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    offset = np.einsum("ij,ij->i", normal, corners[:, 0])
    centre, half = boxes.mean(axis=1), 0.5 * (boxes[:, 1] - boxes[:, 0])
    step = max(1, (1 << 22) // max(len(corners), 1))
    return np.concatenate([_bitsets(centre[c:c + step] @ normal.T
                                    + half[c:c + step] @ np.abs(normal).T >= offset[None, :])
                           for c in range(0, len(boxes), step)])


@njit(cache=True)
def _fill(rows, free, window):
    """rows with free bits filled: rows (T, W) uint64 each triangle's cells, free (T, W) uint64
    the bits that may be set. In triangle order, each triangle takes the free bits of the
    earlier (filled) row within `window` that differs least from it on the bits that are not
    free or are set (nearest first on ties); set bits stay set."""
    count, width = rows.shape
    out = rows.copy()
    for t in range(1, count):
        best, near = 1 << 62, -1
        for j in range(t - 1, max(0, t - window) - 1, -1):
            d = 0
            for w in range(width):
                d += pvs_coder._popcount(((out[j, w] ^ rows[t, w]) & ~free[t, w])
                                         | (rows[t, w] & ~out[j, w]))
                if d >= best:
                    break
            if d < best:
                best, near = d, j
                if d == 0:
                    break
        if near >= 0:
            for w in range(width):
                out[t, w] = rows[t, w] | (out[near, w] & free[t, w])
    return out


def fill_back(boxes, masks, corners, back, window=FILL_WINDOW) -> np.ndarray:
    """(V, T) bool: the sets masks (V, T) bool with free bits filled (module docstring): a
    triangle whose plane has the whole cell grown by `back` (pvs_back) behind it may join the
    cell's set; each triangle copies such bits from its nearest earlier triangle (_fill). A
    superset of masks, equal to it wherever a triangle faces some point of the grown cell.
    (The stage's own test, pvs_back.region_backfacing, also allows for the device's rounding:
    what it keeps of the few added within that margin, tbfc culls per eye.)"""
    boxes = np.asarray(boxes, dtype=np.float64)
    cells = len(boxes)
    masks = np.asarray(masks, dtype=bool).reshape(cells, -1)
    triangles = masks.shape[1]
    if not triangles or cells < 2:
        return masks.copy()
    grown = boxes.copy()
    grown[:, 0] -= back
    grown[:, 1] += back
    front = np.unpackbits(facing(grown, corners).view(np.uint8), axis=1, count=triangles,
                          bitorder="little").astype(bool)  # (V, T)
    out = _fill(_bitsets(masks.T), _bitsets(~front.T), window)
    filled = np.unpackbits(out.view(np.uint8), axis=1, count=cells, bitorder="little")
    return filled.T.astype(bool)


def merge_order(boxes, masks, corners=None, power=POWER) -> tuple:
    """((M, 2) int64 merges, (M,) float64 added) of the view cells (boxes (V, 2, 3)) with the
    sets masks (V, T) bool: the greedy order, cheapest first (a merge's cost: the triangles
    each group gains that face it, by the corners (T, 3, 3); None: all, times the group's
    share of the cells' volume, each cell's raised to `power`: how likely an eye is there)."""
    boxes = np.ascontiguousarray(boxes, dtype=np.float64)
    cells = len(boxes)
    masks = np.asarray(masks, dtype=bool).reshape(cells, -1)
    sets = _bitsets(masks)
    front = facing(boxes, corners) if corners is not None and masks.shape[1] \
        else np.full_like(sets, np.uint64(0xFFFFFFFFFFFFFFFF))
    volume = np.prod(np.maximum(boxes[:, 1] - boxes[:, 0], 0.0), axis=1)
    chance = np.maximum(volume, 1e-12 * max(volume.max(initial=0.0), 1e-300))
    chance = (chance / chance.max()) ** power
    chance = chance / chance.sum()
    near, _ = pvs_coder.neighbours(boxes, pvs_coder.CELL_WINDOW, NEIGHBOURS)
    v = np.repeat(np.arange(cells), near.shape[1])
    keep = near.ravel() >= 0
    edges = np.ascontiguousarray(np.stack([near.ravel()[keep], v[keep]], axis=1))
    return _merge_order(sets, front, chance.copy(), edges.astype(np.int64))


def groups_after(cells: int, merges, count: int) -> np.ndarray:
    """(V,) int64 each cell's group (its lowest cell) after the first `count` merges."""
    root = np.arange(cells, dtype=np.int64)
    for g, h in merges[:count]:
        root[root == h] = g  # h is a group's lowest cell: its members point at it
    return root


def merged_columns(cell_bits, ids, weight, root) -> tuple:
    """(group (V,) int64 numbered by first cells, columns (T, ceil(G / 8)) uint8 each
    triangle's groups (pvs_codec.encode_columns), sizes (G,) triangles in each group's set):
    every cell of a group (root: its lowest cell, groups_after) takes the union of their sets.
    cell_bits (V, ceil(K / 8)) uint8 each cell's patterns, packed; weight (K,) triangles per
    pattern."""
    firsts, group = np.unique(root, return_inverse=True)  # the lowest cells ascend
    group = np.asarray(group, dtype=np.int64).ravel()
    order = np.argsort(group, kind="stable")
    starts = np.flatnonzero(np.r_[True, np.diff(group[order]) != 0])
    union = np.bitwise_or.reduceat(cell_bits[order], starts, axis=0)
    bits = np.unpackbits(union, axis=1, count=len(weight))  # (G, K)
    columns = np.packbits(bits.T, axis=1)[np.asarray(ids, dtype=np.int64)]
    return group, columns, bits @ weight


def stored_size(extras) -> int:
    """Bytes the PVS adds to a .vmp, as the budget counts them: its sections
    (store.stored_bytes) plus HEADER and SECTION per section past SECTIONS for their
    entries."""
    from .store import stored_bytes

    stored = [v for k, v in extras.items() if k not in DERIVED]
    return HEADER + SECTION * max(0, len(stored) - SECTIONS) \
        + int(sum(stored_bytes(v) for v in stored))


def collapsed_faces(boxes, masks, faces) -> dict:
    """FACE_KEYS of one face set shared by every cell: the union of the cells' face sets
    (faces (V, T) bool) less the triangles every cell's set holds (masks (V, T) bool, or any
    superset of each). Each cell's set with it then holds its set with its own face set: the
    face sets only grow, so it stays conservative."""
    union = np.asarray(faces, dtype=bool).any(axis=0) & ~np.asarray(masks, dtype=bool).all(axis=0)
    coded = encode_columns(boxes, np.zeros(len(boxes), dtype=np.int64),
                           np.packbits(union[:, None], axis=1))
    return dict(zip(FACE_KEYS, (coded["pvs_shape"], coded["pvs_pack"])))


def fit(boxes, masks, budget_bytes, others=None, corners=None, power=POWER,
        fill=True, faces=None) -> tuple:
    """(encoded extras, report): the sets coarsened by about the fewest greedy merges
    (merge_order; within V / SLACK) whose encoding, with the others extras beside it, takes at
    most budget_bytes (None: exact).

    boxes  : (V, 2, 3) float64 view cells; masks: V (T,) bool conservative sets
    corners: (T, 3, 3) float64 the triangles (a merge's cost counts only those facing the
             cells, merge_order); None: every triangle counts
    power  : the cells' volumes are raised to it to weigh merges (merge_order; 1: an eye
             anywhere in the cells alike; POWER: the open cells more, docs/partition.md)
    others : the PVS's other extras (their bytes count); with corners and a pvs_back among
             them (and fill), free bits are filled before merging (fill_back)
    faces  : optional (V, T) bool the cells' face sets (pvs_planes.py), whose exact coding is
             others' FACE_KEYS: when the exact PVS does not fit they are the first to go
             coarse, collapsed to one set (collapsed_faces: only eyes within a device's rounding
             of a walked face plane take them, so the bytes go to the sets every eye takes);
             the extras returned then hold FACE_KEYS too
    report : dict(budget, before, after bytes; faces: the face sets' bytes before and after,
             faces_collapsed: whether they were; filled: bytes after fill_back, when it ran;
             cells, groups; merges; mean_set before and after (volume-weighted share of the
             triangles stored, filled ones too); met (bool); unreachable: True when even every
             merge would not fit, and the exact sets are returned; seconds)
    """
    began = time.perf_counter()
    others = dict(others or {})
    exact = encode(boxes, masks)
    before = stored_size({**exact, **others})
    cells = len(boxes)
    masks = np.asarray(masks, dtype=bool).reshape(cells, -1)
    face = {k: others.pop(k) for k in FACE_KEYS if k in others}
    face_bytes = stored_size(face) - HEADER if face else 0
    volume = np.prod(np.maximum(boxes[:, 1] - boxes[:, 0], 0.0), axis=1)
    share = volume / volume.sum() if volume.sum() > 0 else np.full(cells, 1.0 / cells)
    triangles = max(masks.shape[1], 1)
    mean_before = float(share @ masks.sum(axis=1)) / triangles
    report = {"budget": budget_bytes, "before": before, "after": before, "cells": cells,
              "groups": int(exact["pvs_shape"][9]), "merges": 0, "mean_set_before": mean_before,
              "mean_set_after": mean_before, "met": budget_bytes is None or before <= budget_bytes,
              "faces": [face_bytes, face_bytes], "faces_collapsed": False}
    if report["met"]:
        report["seconds"] = time.perf_counter() - began
        return {**exact, **face}, report
    kept = {**exact, **face}  # the exact sets, returned when no merging can fit
    if faces is not None and face:  # the face sets first: one set for every cell
        face = collapsed_faces(boxes, masks, faces)
        report["faces"][1], report["faces_collapsed"] = stored_size(face) - HEADER, True
        size = stored_size({**exact, **face, **others})
        if size <= budget_bytes:
            report.update(after=size, met=True, seconds=time.perf_counter() - began)
            return {**exact, **face}, report
    others = {**others, **face}  # counted beside the sets from here on
    from .pvs_codec import decode_all, _CACHE

    back = others.get("pvs_back")
    if fill and corners is not None and back is not None:  # free bits first: no more sent
        masks = fill_back(boxes, masks, corners, float(np.asarray(back).ravel()[0]))
        exact = encode(boxes, masks)
        size = stored_size({**exact, **others})
        report["filled"] = size
        if size <= budget_bytes:
            report.update(after=size, groups=int(exact["pvs_shape"][9]), met=True,
                          mean_set_after=float(share @ masks.sum(axis=1)) / triangles,
                          seconds=time.perf_counter() - began)
            return {**exact, **face}, report

    _, patterns, ids = decode_all(exact, masks.shape[1])
    ids = np.asarray(ids, dtype=np.int64)
    cell_bits = np.packbits(np.unpackbits(patterns, axis=1, count=cells).T, axis=1)
    weight = np.bincount(ids, minlength=len(patterns)).astype(np.int64)
    merges, _ = merge_order(boxes, masks, corners, power)
    probes = {}

    def probe(count):
        if count not in probes:
            group, columns, _ = merged_columns(cell_bits, ids, weight,
                                               groups_after(cells, merges, count))
            extras = encode_columns(boxes, group, columns)
            probes[count] = (stored_size({**extras, **others}), extras)
        return probes[count]

    probes[0] = (stored_size({**exact, **others}), exact)  # filled, face sets collapsed
    low, high = 0, len(merges)  # low does not fit; find about the fewest merges that fit
    if probe(high)[0] > budget_bytes:
        # out of reach (the cells' boxes alone take more: W4's 4,560 BSP leaves): merging
        # everything would send the whole world and still not fit, so the exact sets stay
        _CACHE.clear()
        report.update(after=before, faces=[face_bytes, face_bytes], faces_collapsed=False,
                      unreachable=True, seconds=time.perf_counter() - began)
        return kept, report
    close = max(1, cells // SLACK)
    for step in range(64):
        if high - low <= close:
            break
        if step % 2 == 0:  # bytes fall about linearly with the merges: interpolate
            over, under = probes[low][0] - budget_bytes, budget_bytes - probes[high][0]
            middle = low + int(round((high - low) * over / max(over + under, 1e-9)))
            middle = min(max(middle, low + 1), high - 1)
        else:  # and halve, so that the bracket closes whatever the curve
            middle = (low + high) // 2
        if probe(middle)[0] <= budget_bytes:
            high = middle
        else:
            low = middle
    count = high
    size, extras = probe(count)  # fits: probe(high) did and high only moves to what fits
    group, _, sizes = merged_columns(cell_bits, ids, weight, groups_after(cells, merges, count))
    _CACHE.clear()
    report.update(after=size, groups=int(extras["pvs_shape"][9]), merges=int(count),
                  mean_set_after=float(share @ sizes[group]) / triangles,
                  met=True, seconds=time.perf_counter() - began)
    return {**extras, **face}, report


def describe(report) -> str:
    """One line of what a budget did (the partition command's pvs line)."""
    kb = lambda n: f"{n / 1024:,.1f} KB"  # noqa: E731
    if report.get("budget") is None:
        return f"none: the exact sets, {kb(report['before'])}"
    filled = f" (free bits filled {kb(report['filled'])})" \
        if "filled" in report and not report.get("unreachable") else ""
    if report.get("faces_collapsed"):
        filled = (f" (face sets {kb(report['faces'][0])} -> one set "
                  f"{kb(report['faces'][1])})") + filled
    head = (f"budget {kb(report['budget'])}: {kb(report['before'])}{filled} -> "
            f"{kb(report['after'])}, "
            f"{report['cells']:,} cells in {report['groups']:,} sets, mean set "
            f"{report['mean_set_before']:.1%} -> {report['mean_set_after']:.1%} (by volume)")
    if report["met"]:
        return head
    # fit misses a budget only when even every merge would (report["unreachable"])
    return head + " - not met: every cell merged would still be larger, so the exact sets stay"

"""The PVS's stored form: the view cells' boxes on their coordinate tables, each triangle's
pattern of view cells, and the distinct patterns arithmetic-coded (pvs.py bakes the sets,
culling/pvs.py reads them, pvs_coder.py codes the bits).

A triangle's pattern is the set of view cells whose sets hold it. Neighbouring cells see much
the same, so a world of T triangles has fewer distinct patterns (W2: 102,547 triangles, about
7,000 patterns): the cells' sets are K pattern bitsets plus one pattern id per triangle, the
patterns numbered in the order triangles first use them. Cells with the same set (a coarsened
PVS, pvs_coarsen.py, merges groups of cells) share one column: the patterns hold G bits, one
per column group, numbered in the order of their first cells.

    pvs_shape (10,) int64 LAYOUT, V cells, K patterns, T triangles, bytes per pattern id (1, 2
                          or 4), nx, ny, nz coordinates in the tables, S bytes of the side
                          stream, G column groups (layout 2: 9 values, G = V)
    pvs_pack  (N,) uint8  the side stream (S bytes, lzma: SIDE_FILTERS), then the patterns'
                          range-coded bits (pvs_coder.py, K x G bits)

The side stream inflates to: the x, y and z tables (nx + ny + nz float64, each strictly
ascending: every distinct coordinate of the cells' boxes), each cell's low corner as indices
into them (3 x V uint32, all x first) and its size in table steps (3 x V uint32), each cell's
group (V uint32: 0 opens the next group, c > 0 names the group c before the next one; layout
2 has none), each pattern's two references as offsets back (2 x K uint32, 0: none), and the T
pattern ids as differences from the previous triangle's (modulo 2^(8 x the id's bytes):
mostly 0 or 1). A box is read back as the very floats baked (no rounding: the stage's
conservative contract rests on the exact boxes). The street cells' 3,055 boxes take about
1.5 KB instead of 73 KB as float32; W6's ids 2.3 KB instead of 9.5 KB as ids.

decode() checks everything a loaded file could get wrong (the layout, sizes, a stream longer
or shorter than declared, tables not ascending, an index, a group or a reference out of
range, ids past K) and inflates at most the declared bytes: V is at most MAX_CELLS, K x G at
most what the pack's bytes can code (pvs_coder.MIN_BITS), and the patterns spread over the
cells at most MAX_PATTERN_BYTES, so memory stays bounded on a hostile file. A cell's set is
then one gather, cell_mask (T,) from the (K,) bits of its column.
"""
from __future__ import annotations

import lzma
import zlib

import numpy as np

from numba import njit

from . import pvs_coder

LAYOUT = 3  # 2: a column per cell (read as one group per cell); 1: zlib'd bitsets (refused)
ID_BYTES = (1, 2, 4)
MAX_CELLS = 1 << 20
MAX_PATTERN_BYTES = 1 << 28  # the decoded patterns over the cells (K x ceil(V / 8) bytes)
SIDE_FILTERS = [{"id": lzma.FILTER_LZMA2, "preset": 9 | lzma.PRESET_EXTREME,
                 "dict_size": 1 << 20}]  # decoding allocates at most the dictionary
_CACHE = {}  # decoded streams, so the load's check and the stage inflate once
_CACHE_SIZE = 4


def encode(boxes, masks) -> dict:
    """{'pvs_shape', 'pvs_pack'} of per-cell sets (cells with the same set share a column).

    boxes : (V, 2, 3) float64 view-cell boxes, lo <= hi, finite
    masks : iterable of V (T,) bool arrays, one per view cell, in cell order
    """
    boxes = np.ascontiguousarray(boxes, dtype=np.float64).reshape(-1, 2, 3)
    cells = len(boxes)
    if not 1 <= cells <= MAX_CELLS or not np.isfinite(boxes).all() \
            or np.any(boxes[:, 0] > boxes[:, 1]):
        raise ValueError(f"expected 1 to {MAX_CELLS} finite view-cell boxes")
    masks = [np.asarray(m, dtype=bool) for m in masks]
    if len(masks) != cells:
        raise ValueError(f"expected {cells} cell masks")
    group, unique = column_groups(masks)
    return encode_columns(boxes, group, _columns([masks[c] for c in unique], len(unique)))


def encode_columns(boxes, group, columns) -> dict:
    """encode's result from the column groups: group (V,) int64 each cell's, numbered in the
    order of their first cells (0, then at most one more than any before), and columns
    (T, ceil(G / 8)) uint8 each triangle's groups, packed (numpy.packbits order)."""
    boxes = np.ascontiguousarray(boxes, dtype=np.float64).reshape(-1, 2, 3)
    cells, groups = len(boxes), int(group.max()) + 1
    triangles, width = columns.shape
    if triangles:
        rows = np.ascontiguousarray(columns).view(np.dtype((np.void, width))).ravel()
        _, first, inverse = np.unique(rows, return_index=True, return_inverse=True)
        order = np.argsort(first)  # patterns numbered in the order triangles first use them
        rank = np.empty(len(order), dtype=np.int64)
        rank[order] = np.arange(len(order))
        ids = rank[np.asarray(inverse).ravel()]
        patterns = np.ascontiguousarray(columns[first[order]])
    else:
        patterns, ids = np.zeros((0, width), np.uint8), np.zeros(0, np.int64)
    size = next(b for b in ID_BYTES if len(patterns) <= 1 << (8 * b))
    tables = [np.unique(boxes[:, :, a]) for a in range(3)]
    low = np.stack([np.searchsorted(tables[a], boxes[:, 0, a]) for a in range(3)])
    high = np.stack([np.searchsorted(tables[a], boxes[:, 1, a]) for a in range(3)])
    refs = pvs_coder.references(patterns)
    side = b"".join([*(t.astype("<f8").tobytes() for t in tables),
                     low.astype("<u4").tobytes(), (high - low).astype("<u4").tobytes(),
                     _group_codes(group).astype("<u4").tobytes(),
                     refs.T.astype("<u4").tobytes(),
                     (np.diff(ids, prepend=0) % (1 << 8 * size)).astype(f"<u{size}").tobytes()])
    packed = lzma.compress(side, format=lzma.FORMAT_RAW, filters=SIDE_FILTERS)
    bits = pvs_coder.encode_rows(patterns, groups, refs, _parents(boxes, group, groups))
    shape = [LAYOUT, cells, len(patterns), triangles, size, *(len(t) for t in tables),
             len(packed), groups]
    return {"pvs_shape": np.array(shape, dtype=np.int64),
            "pvs_pack": np.concatenate([np.frombuffer(packed, np.uint8), bits])}


def column_groups(masks) -> tuple:
    """(group (V,) int64, first (G,) int64): cells with equal sets share a group, numbered in
    the order of their first cells; first[g] is group g's first cell."""
    packed = np.stack([np.packbits(m) for m in masks])
    if not packed.shape[1]:  # no triangles: every set is the empty one
        return np.zeros(len(masks), dtype=np.int64), np.zeros(1, dtype=np.int64)
    rows = np.ascontiguousarray(packed).view(np.dtype((np.void, packed.shape[1]))).ravel()
    _, first, inverse = np.unique(rows, return_index=True, return_inverse=True)
    order = np.argsort(first)
    rank = np.empty(len(order), dtype=np.int64)
    rank[order] = np.arange(len(order))
    return rank[np.asarray(inverse).ravel()], first[order]


def _group_codes(group) -> np.ndarray:
    """(V,) the stored form of a group map numbered by first cells: 0 for a cell that opens a
    new group, else how many groups back from the next new one its group is (all 0 when every
    cell has its own set)."""
    opened = np.maximum.accumulate(group) + 1  # groups open after each cell
    before = np.concatenate([[0], opened[:-1]])
    return before - group


@njit(cache=True)
def _groups_of(codes):
    """(group (V,) int64, G), or G = -1 when a code names no open group (_group_codes)."""
    group = np.empty(len(codes), dtype=np.int64)
    opened = 0
    for v in range(len(codes)):
        c = np.int64(codes[v])
        if c == 0:
            group[v] = opened
            opened += 1
        elif c > opened:
            return group, -1
        else:
            group[v] = opened - c
    return group, opened


def _parents(boxes, group, groups) -> np.ndarray:
    """The coder's parents of each column group (pvs_coder.group_parents)."""
    near, area = pvs_coder.neighbours(boxes, pvs_coder.CELL_WINDOW, pvs_coder.NEIGHBOURS)
    return pvs_coder.group_parents(near, area, np.asarray(group, dtype=np.int64), groups)


def _columns(masks, cells) -> np.ndarray:
    """(T, ceil(V / 8)) uint8: each triangle's cells, packed (numpy.packbits order)."""
    group, packed = [], []
    for mask in masks:
        group.append(np.asarray(mask, dtype=bool))
        if len(group) == 8:
            packed.append(np.packbits(np.stack(group), axis=0)[0])
            group = []
    if group:
        packed.append(np.packbits(np.stack(group), axis=0)[0])
    if len(packed) != (cells + 7) // 8:
        raise ValueError(f"expected {cells} cell masks")
    return np.stack(packed, axis=1)


def cell_count(extras) -> int:
    """V, the view cells a (checked) PVS holds, from pvs_shape alone."""
    return int(np.asarray(extras["pvs_shape"])[1])


def cell_boxes(extras, triangles: int) -> np.ndarray:
    """(V, 2, 3) float64 view-cell boxes of a PVS (decode_all)."""
    return decode_all(extras, triangles)[0]


def decode(extras, cells: int, triangles: int) -> tuple:
    """(patterns (K, ceil(V / 8)) uint8, ids (T,) unsigned) of the stored sets of `cells` view
    cells (decode_all); ValueError as decode_all's, or when the PVS holds other than `cells`."""
    boxes, patterns, ids = decode_all(extras, triangles)
    if len(boxes) != cells:
        raise ValueError(f"the PVS holds {len(boxes)} view cells, not {cells}")
    return patterns, ids


def decode_all(extras, triangles: int) -> tuple:
    """(boxes (V, 2, 3) float64, patterns (K, ceil(V / 8)) uint8, ids (T,) unsigned) of the
    stored sets, read-only (decoded once per stream and kept); ValueError when the layout, a
    size, the streams, a table, an index, a reference or an id is wrong."""
    if "pvs_shape" not in extras or "pvs_pack" not in extras:
        raise ValueError("pvs_shape or pvs_pack missing")
    shape, pack = np.asarray(extras["pvs_shape"]), np.asarray(extras["pvs_pack"])
    if pack.ndim != 1 or pack.dtype != np.uint8:
        raise ValueError("pvs_pack must be bytes")
    if shape.ndim != 1 or shape.dtype.kind not in "iu":
        raise ValueError("pvs_shape must be integers")
    key = (shape.tobytes(), len(pack), zlib.crc32(pack.tobytes()), int(triangles))
    hit = _CACHE.get(key)
    if hit is None:
        hit = _decode(shape, pack, int(triangles))
        for array in hit:
            array.setflags(write=False)
        if len(_CACHE) >= _CACHE_SIZE:
            _CACHE.pop(next(iter(_CACHE)))
        _CACHE[key] = hit
    return hit


def _decode(shape, pack, triangles) -> tuple:
    if len(shape) < 1 or int(shape[0]) not in (2, LAYOUT) \
            or len(shape) != (9 if int(shape[0]) == 2 else 10):
        raise ValueError(f"the PVS is stored in another layout than {LAYOUT}: bake it again")
    _, cells, count, stored, size, nx, ny, nz, side_bytes = (int(v) for v in shape[:9])
    grouped = int(shape[0]) == LAYOUT  # layout 2: a column per cell, no group map
    groups = int(shape[9]) if grouped else cells
    if stored != triangles:
        raise ValueError(f"pvs_shape holds {stored} triangles, the world {triangles}")
    if not 1 <= cells <= MAX_CELLS or not 1 <= groups <= cells:
        raise ValueError(f"pvs_shape's view cells must be 1 to {MAX_CELLS}, its columns 1 to "
                         "the cells")
    if size not in ID_BYTES or count < (1 if triangles else 0) or count > max(triangles, 1) \
            or count > 1 << (8 * size):
        raise ValueError("pvs_shape's pattern count or id size is out of range")
    if not all(1 <= n <= 2 * cells for n in (nx, ny, nz)):
        raise ValueError("pvs_shape's coordinate tables must hold 1 to 2 V values")
    if not 0 <= side_bytes <= len(pack):
        raise ValueError("pvs_shape's side stream is longer than pvs_pack")
    stream = pack[side_bytes:]
    if count * groups > (8 * len(stream) + 64) / pvs_coder.MIN_BITS:
        raise ValueError("pvs_pack is too short to code the patterns pvs_shape declares")
    if count * ((cells + 7) // 8) > MAX_PATTERN_BYTES:
        raise ValueError(f"pvs_shape's patterns over its cells exceed {MAX_PATTERN_BYTES:,} "
                         "bytes")
    tables_at = 8 * (nx + ny + nz)
    groups_at = tables_at + 24 * cells
    refs_at = groups_at + 4 * cells * grouped
    ids_at = refs_at + 8 * count
    expected = ids_at + size * triangles
    inflate = lzma.LZMADecompressor(format=lzma.FORMAT_RAW, filters=SIDE_FILTERS)
    try:
        side = inflate.decompress(pack[:side_bytes].tobytes(), expected + 1)
    except lzma.LZMAError as error:
        raise ValueError(f"pvs_pack's side stream does not inflate ({error})") from None
    if len(side) != expected or not inflate.eof or inflate.unused_data:
        raise ValueError(f"pvs_pack's side stream inflates to other than the {expected} "
                         "bytes declared (or holds bytes after its end)")
    flat = np.frombuffer(side, dtype="<f8", count=nx + ny + nz)
    tables = np.split(flat, [nx, nx + ny])
    if not np.isfinite(flat).all() or any(np.any(np.diff(t) <= 0) for t in tables):
        raise ValueError("pvs_pack's coordinate tables must be finite and ascending")
    corners = np.frombuffer(side, dtype="<u4", count=6 * cells, offset=tables_at)
    low, step = corners[:3 * cells].reshape(3, cells), corners[3 * cells:].reshape(3, cells)
    high = low.astype(np.int64) + step
    if any(np.any(high[a] >= n) for a, n in enumerate((nx, ny, nz))):
        raise ValueError("pvs_pack's cell corners lie past their coordinate tables")
    boxes = np.empty((cells, 2, 3), dtype=np.float64)
    for a in range(3):
        boxes[:, 0, a], boxes[:, 1, a] = tables[a][low[a]], tables[a][high[a]]
    if grouped:
        group, opened = _groups_of(np.frombuffer(side, dtype="<u4", count=cells,
                                                 offset=groups_at))
        if opened != groups:
            raise ValueError(f"pvs_pack's cells name other than the {groups} column groups "
                             "pvs_shape declares")
    else:
        group = np.arange(cells, dtype=np.int64)
    refs = np.frombuffer(side, dtype="<u4", count=2 * count, offset=refs_at)
    refs = refs.reshape(2, count).T.astype(np.int64)
    if count and np.any(refs > np.arange(count)[:, None]):
        raise ValueError("pvs_pack's patterns refer to patterns before the first")
    ids = np.cumsum(np.frombuffer(side, dtype=f"<u{size}", count=triangles, offset=ids_at),
                    dtype=np.int64) % (1 << 8 * size)
    if len(ids) and ids.max() >= count:
        raise ValueError("pvs_pack names a pattern outside pvs_shape's count")
    ids = ids.astype(f"<u{size}")
    rows = pvs_coder.decode_rows(stream, count, groups, refs, _parents(boxes, group, groups))
    return boxes, _spread(rows, group, groups), ids


def _spread(rows, group, groups) -> np.ndarray:
    """(K, ceil(V / 8)) uint8 patterns over the cells from (K, ceil(G / 8)) over the column
    groups (each cell takes its group's column), in blocks of rows to bound the scratch."""
    cells = len(group)
    if groups == cells and np.array_equal(group, np.arange(cells)):
        return rows
    out = np.empty((len(rows), (cells + 7) // 8), dtype=np.uint8)
    step = max(1, (1 << 24) // max(cells, 1))
    for first in range(0, len(rows), step):
        bits = np.unpackbits(rows[first:first + step], axis=1, count=groups)
        out[first:first + step] = np.packbits(bits[:, group], axis=1)
    return out


def cell_bits(patterns, cell: int) -> np.ndarray:
    """(K,) bool: which patterns hold the view cell."""
    return (patterns[:, cell >> 3] >> (7 - (cell & 7))) & 1 == 1


def cell_mask(patterns, ids, cell: int) -> np.ndarray:
    """(T,) bool: the view cell's set (one gather of its column)."""
    return cell_bits(patterns, cell)[ids]


def cell_sizes(patterns, ids, cells: int) -> np.ndarray:
    """(V,) int64 triangles in each view cell's set."""
    weight = np.bincount(ids, minlength=len(patterns))
    bits = np.unpackbits(patterns, axis=1, count=cells).astype(np.int64)
    return weight @ bits if len(patterns) else np.zeros(cells, dtype=np.int64)


DERIVED = ("pvs_cells",)  # extras the .vmp does not hold: derived_extras rebuilds them


def derived_extras(extras, triangles: int) -> dict:
    """{'pvs_cells': (V, 2, 3) float64 boxes} of a loaded PVS of this layout, which the .vmp
    stores in pvs_pack (partition/store.py drops DERIVED on writing and calls this on
    loading); {} without one or in another layout (check_pvs refuses that in one line)."""
    shape = np.asarray(extras.get("pvs_shape", ()))
    if "pvs_pack" not in extras or "pvs_cells" in extras or shape.ndim != 1 \
            or len(shape) < 1 or shape[0] not in (2, LAYOUT):
        return {}
    return {"pvs_cells": cell_boxes(extras, triangles).copy()}

"""The PVS's stored form: the view cells' boxes on their coordinate tables, each triangle's
pattern of view cells, and the distinct patterns arithmetic-coded (pvs.py bakes the sets,
culling/pvs.py reads them, pvs_coder.py codes the bits).

A triangle's pattern is the set of view cells whose sets hold it. Neighbouring cells see much
the same, so a world of T triangles has fewer distinct patterns (W2: 102,547 triangles, about
7,000 patterns): the cells' sets are K pattern bitsets of V bits plus one pattern id per
triangle, the patterns numbered in the order triangles first use them.

    pvs_shape (9,) int64  LAYOUT, V cells, K patterns, T triangles, bytes per pattern id (1, 2
                          or 4), nx, ny, nz coordinates in the tables, S bytes of the side stream
    pvs_pack  (N,) uint8  the side stream (S bytes, lzma: SIDE_FILTERS), then the patterns'
                          range-coded bits (pvs_coder.py)

The side stream inflates to: the x, y and z tables (nx + ny + nz float64, each strictly
ascending: every distinct coordinate of the cells' boxes), each cell's low corner as indices
into them (3 x V uint32, all x first) and its size in table steps (3 x V uint32), each
pattern's two references as offsets back (2 x K uint32, 0: none), and the T pattern ids as
differences from the previous triangle's (modulo 2^(8 x the id's bytes): mostly 0 or 1). A box is
read back as the very floats baked (no rounding: the stage's conservative contract rests on
the exact boxes). The street cells' 3,055 boxes take about 1.5 KB instead of 73 KB as float32;
W6's ids 2.3 KB instead of 9.5 KB as ids.

decode() checks everything a loaded file could get wrong (the layout, sizes, a stream longer
or shorter than declared, tables not ascending, an index or a reference out of range, ids
past K) and inflates at most the declared bytes: V is at most MAX_CELLS, and K x V at most
what the pack's bytes can code (pvs_coder.MIN_BITS), so memory stays bounded on a hostile file.
A cell's set is then one gather, cell_mask (T,) from the (K,) bits of its column.
"""
from __future__ import annotations

import lzma
import zlib

import numpy as np

from . import pvs_coder

LAYOUT = 2  # 1: zlib'd bitsets with float boxes in pvs_cells (refused: bake again)
ID_BYTES = (1, 2, 4)
MAX_CELLS = 1 << 20
SIDE_FILTERS = [{"id": lzma.FILTER_LZMA2, "preset": 9 | lzma.PRESET_EXTREME,
                 "dict_size": 1 << 20}]  # decoding allocates at most the dictionary
_CACHE = {}  # decoded streams, so the load's check and the stage inflate once
_CACHE_SIZE = 4


def encode(boxes, masks) -> dict:
    """{'pvs_shape', 'pvs_pack'} of per-cell sets.

    boxes : (V, 2, 3) float64 view-cell boxes, lo <= hi, finite
    masks : iterable of V (T,) bool arrays, one per view cell, in cell order
    """
    boxes = np.ascontiguousarray(boxes, dtype=np.float64).reshape(-1, 2, 3)
    cells = len(boxes)
    if not 1 <= cells <= MAX_CELLS or not np.isfinite(boxes).all() \
            or np.any(boxes[:, 0] > boxes[:, 1]):
        raise ValueError(f"expected 1 to {MAX_CELLS} finite view-cell boxes")
    columns = _columns(masks, cells)
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
                     refs.T.astype("<u4").tobytes(),
                     (np.diff(ids, prepend=0) % (1 << 8 * size)).astype(f"<u{size}").tobytes()])
    packed = lzma.compress(side, format=lzma.FORMAT_RAW, filters=SIDE_FILTERS)
    bits = pvs_coder.encode_rows(patterns, cells, refs,
                                 pvs_coder.parents(boxes, pvs_coder.CELL_WINDOW))
    shape = [LAYOUT, cells, len(patterns), triangles, size, *(len(t) for t in tables),
             len(packed)]
    return {"pvs_shape": np.array(shape, dtype=np.int64),
            "pvs_pack": np.concatenate([np.frombuffer(packed, np.uint8), bits])}


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
    if len(shape) != 9 or int(shape[0]) != LAYOUT:
        raise ValueError(f"the PVS is stored in another layout than {LAYOUT}: bake it again")
    _, cells, count, stored, size, nx, ny, nz, side_bytes = (int(v) for v in shape)
    if stored != triangles:
        raise ValueError(f"pvs_shape holds {stored} triangles, the world {triangles}")
    if not 1 <= cells <= MAX_CELLS:
        raise ValueError(f"pvs_shape's view cells must be 1 to {MAX_CELLS}")
    if size not in ID_BYTES or count < (1 if triangles else 0) or count > max(triangles, 1) \
            or count > 1 << (8 * size):
        raise ValueError("pvs_shape's pattern count or id size is out of range")
    if not all(1 <= n <= 2 * cells for n in (nx, ny, nz)):
        raise ValueError("pvs_shape's coordinate tables must hold 1 to 2 V values")
    if not 0 <= side_bytes <= len(pack):
        raise ValueError("pvs_shape's side stream is longer than pvs_pack")
    stream = pack[side_bytes:]
    if count * cells > (8 * len(stream) + 64) / pvs_coder.MIN_BITS:
        raise ValueError("pvs_pack is too short to code the patterns pvs_shape declares")
    tables_at = 8 * (nx + ny + nz)
    refs_at = tables_at + 24 * cells
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
    refs = np.frombuffer(side, dtype="<u4", count=2 * count, offset=refs_at)
    refs = refs.reshape(2, count).T.astype(np.int64)
    if count and np.any(refs > np.arange(count)[:, None]):
        raise ValueError("pvs_pack's patterns refer to patterns before the first")
    ids = np.cumsum(np.frombuffer(side, dtype=f"<u{size}", count=triangles, offset=ids_at),
                    dtype=np.int64) % (1 << 8 * size)
    if len(ids) and ids.max() >= count:
        raise ValueError("pvs_pack names a pattern outside pvs_shape's count")
    ids = ids.astype(f"<u{size}")
    patterns = pvs_coder.decode_rows(stream, count, cells, refs,
                                     pvs_coder.parents(boxes, pvs_coder.CELL_WINDOW))
    return boxes, patterns, ids


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
            or len(shape) < 1 or shape[0] != LAYOUT:
        return {}
    return {"pvs_cells": cell_boxes(extras, triangles).copy()}

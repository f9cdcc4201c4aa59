"""The PVS's stored form: each triangle's pattern of view cells, the distinct patterns as
bitsets, zlib-compressed (pvs.py bakes the sets, culling/pvs.py reads them).

A triangle's pattern is the set of view cells whose sets hold it. Neighbouring cells see much
the same, so a world of T triangles has few distinct patterns (W2: 102,547 triangles, about
7,000 patterns): the cells' sets are K pattern bitsets of V bits plus one pattern id per
triangle, and zlib takes the rest (ids of neighbouring triangles repeat, bitsets share runs).

    pvs_shape (3,) int64  K patterns, T triangles, bytes per pattern id (1, 2 or 4)
    pvs_pack  (N,) uint8  zlib stream of K x ceil(V / 8) pattern bytes (numpy.packbits order:
                          bit c of a pattern, cell c's set holds its triangles), then T
                          little-endian pattern ids

decode() checks everything a loaded file could get wrong (sizes, a stream longer or shorter
than declared, ids past K) and inflates at most the declared bytes: bounded memory on a
hostile file. A cell's set is then one gather, cell_mask (T,) from the (K,) bits of its column.
"""
from __future__ import annotations

import zlib

import numpy as np

ID_BYTES = (1, 2, 4)
LEVEL = 9  # zlib's best: the bake is offline, inflating costs the same


def encode(masks, cells: int) -> dict:
    """{'pvs_shape', 'pvs_pack'} of per-cell sets.

    masks : iterable of `cells` (T,) bool arrays, one per view cell, in cell order
    """
    group = []
    packed = []
    for mask in masks:
        group.append(np.asarray(mask, dtype=bool))
        if len(group) == 8:
            packed.append(np.packbits(np.stack(group), axis=0)[0])
            group = []
    if group:
        packed.append(np.packbits(np.stack(group), axis=0)[0])
    if len(packed) != (cells + 7) // 8:
        raise ValueError(f"expected {cells} cell masks")
    triangles = len(packed[0]) if packed else 0
    columns = (np.stack(packed, axis=1) if packed else np.zeros((0, 0), np.uint8))
    width = columns.shape[1]
    if triangles:
        rows = np.ascontiguousarray(columns).view(np.dtype((np.void, width))).ravel()
        unique, ids = np.unique(rows, return_inverse=True)
        patterns = np.frombuffer(unique.tobytes(), dtype=np.uint8).reshape(-1, width)
    else:
        patterns, ids = np.zeros((0, width), np.uint8), np.zeros(0, np.int64)
    size = next(b for b in ID_BYTES if len(patterns) <= 1 << (8 * b))
    data = patterns.tobytes() + np.asarray(ids).ravel().astype(f"<u{size}").tobytes()
    return {"pvs_shape": np.array([len(patterns), triangles, size], dtype=np.int64),
            "pvs_pack": np.frombuffer(zlib.compress(data, LEVEL), dtype=np.uint8).copy()}


def decode(extras, cells: int, triangles: int) -> tuple:
    """(patterns (K, ceil(V / 8)) uint8, ids (T,) unsigned) of the stored sets; ValueError when
    the shape, the stream or an id is wrong (inflates at most the declared size + 1 byte)."""
    shape = np.asarray(extras["pvs_shape"])
    if shape.shape != (3,) or shape.dtype.kind not in "iu":
        raise ValueError("pvs_shape must be three integers")
    count, stored, size = (int(v) for v in shape)
    if stored != triangles:
        raise ValueError(f"pvs_shape holds {stored} triangles, the world {triangles}")
    width = (cells + 7) // 8
    if size not in ID_BYTES or count < (1 if triangles else 0) or count > max(triangles, 1) \
            or count > 1 << (8 * size):
        raise ValueError("pvs_shape's pattern count or id size is out of range")
    expected = count * width + triangles * size
    pack = np.asarray(extras["pvs_pack"])
    if pack.ndim != 1 or pack.dtype != np.uint8:
        raise ValueError("pvs_pack must be bytes")
    inflate = zlib.decompressobj()
    try:
        data = inflate.decompress(pack.tobytes(), expected + 1)
    except zlib.error as error:
        raise ValueError(f"pvs_pack does not inflate ({error})") from None
    if len(data) != expected or not inflate.eof or inflate.unconsumed_tail \
            or inflate.unused_data:
        raise ValueError(f"pvs_pack inflates to other than the {expected} bytes declared "
                         "(or holds bytes after its stream)")
    patterns = np.frombuffer(data, dtype=np.uint8, count=count * width).reshape(count, width)
    ids = np.frombuffer(data, dtype=f"<u{size}", offset=count * width)
    if len(ids) and ids.max() >= count:
        raise ValueError("pvs_pack names a pattern past pvs_shape's count")
    if width * 8 > cells and len(patterns) and np.any(
            patterns[:, -1] & np.uint8((1 << (width * 8 - cells)) - 1)):
        raise ValueError("pvs_pack's patterns hold cells past the view cells")
    return patterns, ids


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

"""Per-frame uint16 index batches: the culled triangle ids split into batches of <= 65,535 vertices.

Batch b holds triangles b*B .. (b+1)*B - 1 (B = profile.batch_triangles) and its own vertex
buffer of 3B corners, so every index is local to the batch and fits in 16 bits.
"""
from __future__ import annotations

import numpy as np


def batch_count(triangle_count: int, batch_triangles: int) -> int:
    """Number of draw batches of at most batch_triangles triangles (ceiling division)."""
    return -(-int(triangle_count) // int(batch_triangles))


def batch_indices(triangles, triangle_count: int, batch_triangles: int):
    """Index data for the given triangles.

    triangles       : (K,) int, sorted unique triangle ids (unsorted input is sorted here)
    triangle_count  : T, ids must lie in [0, T)
    batch_triangles : B, with 3B <= 65,535
    Returns (indices (3K,) uint16, starts (nb + 1,) int64): batch b draws
    indices[3 starts[b] : 3 starts[b+1]], each < 3B <= 65,535, relative to its own buffer.
    """
    if 3 * batch_triangles > 65535:
        raise ValueError(f"{batch_triangles} triangles per batch need more than 65,535 vertices")
    ids = np.asarray(triangles, dtype=np.int64).ravel()
    if len(ids) > 1 and not np.all(ids[1:] > ids[:-1]):
        ids = np.unique(ids)
    if len(ids) and (ids[0] < 0 or ids[-1] >= triangle_count):
        raise ValueError(f"triangle ids must lie in [0, {triangle_count})")
    nb = batch_count(triangle_count, batch_triangles)
    starts = np.searchsorted(ids, np.arange(nb + 1, dtype=np.int64) * batch_triangles)
    local = ids % batch_triangles
    indices = (3 * local[:, None] + np.arange(3)).astype(np.uint16).ravel()
    return indices, starts

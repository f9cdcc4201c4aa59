"""The outdoor PVS's view-cell squares (pvs_street.py's street cells, pvs_fly.py's fly-over
layers): convex x-z polygons against squares, quadtree squares split near footprints, and the
Morton order that lets neighbouring cells share runs in the stored sets."""
from __future__ import annotations

import numpy as np


def polygon_table(polys) -> tuple:
    """(N, H, 2) the convex polygons padded by repeating their last corner, and (N, 2, 2)
    their x-z boxes, for near()."""
    size = max((len(p) for p in polys), default=1)
    table = np.zeros((len(polys), size, 2))
    for k, p in enumerate(polys):
        table[k, :len(p)] = p
        table[k, len(p):] = p[-1]
    return table, np.stack([table.min(axis=1), table.max(axis=1)], axis=1)


def near(lo, hi, table, pad) -> np.ndarray:
    """(B, N) bool: the x-z squares lo, hi (B, 2) grown by pad may meet each convex polygon of
    polygon_table (a separating-axis test on the boxes' axes and the polygons' edge normals;
    a repeated corner's empty edge separates nothing)."""
    polys, box = table
    lo = np.asarray(lo, dtype=np.float64).reshape(-1, 2) - pad
    hi = np.asarray(hi, dtype=np.float64).reshape(-1, 2) + pad
    out = ((box[None, :, 0] <= hi[:, None]) & (box[None, :, 1] >= lo[:, None])).all(axis=2)
    b, k = np.nonzero(out)
    if not len(b):
        return out
    p = polys[k]
    edge = np.roll(p, -1, axis=1) - p
    normal = np.stack([edge[..., 1], -edge[..., 0]], axis=2)  # outward (right of a -> b)
    centre, half = ((lo + hi) / 2)[b], ((hi - lo) / 2)[b]
    reach_ = np.abs(normal) @ half[:, :, None]
    side = (normal @ centre[:, :, None])[..., 0] - np.einsum("kij,kij->ki", normal, p)
    out[b, k] = ~(side > reach_[..., 0]).any(axis=1)
    return out


def inside(lo, hi, polys) -> np.ndarray:
    """(B,) bool: the x-z square lo, hi (B, 2) lies wholly inside some polygon of polys (a
    list of counter-clockwise convex (H, 2))."""
    lo, hi = np.asarray(lo).reshape(-1, 2), np.asarray(hi).reshape(-1, 2)
    corners = np.stack([lo, np.column_stack([hi[:, 0], lo[:, 1]]), hi,
                        np.column_stack([lo[:, 0], hi[:, 1]])], axis=1)  # (B, 4, 2)
    out = np.zeros(len(lo), dtype=bool)
    for p in polys:
        edge = np.roll(p, -1, axis=0) - p
        inward = np.column_stack([-edge[:, 1], edge[:, 0]])
        side = corners @ inward.T - np.einsum("ij,ij->i", inward, p)  # (B, 4, H)
        out |= (side > 0).all(axis=(1, 2))
    return out


def square_cells(world, split, drop, pad, y0, y1, cell, least) -> np.ndarray:
    """(V, 2, 3) float64 boxes y0..y1 over the world's x-z extent: squares of side cell, split
    in four while they come within pad of a polygon of split, down to least; a least square
    wholly inside a polygon of drop left out; in Morton order (on a lattice of least)."""
    low, high = world.extent
    size = high[[0, 2]] - low[[0, 2]]
    counts = np.maximum(np.ceil(size / cell).astype(int), 1)
    i, k = np.meshgrid(np.arange(counts[0]), np.arange(counts[1]), indexing="ij")
    corner = low[[0, 2]] + np.column_stack([i.ravel(), k.ravel()]) * cell
    table = polygon_table(split)
    keep = []
    while len(corner):
        lo, hi = corner, np.minimum(corner + cell, high[[0, 2]])
        close = near(lo, hi, table, pad).any(axis=1) if len(split) else \
            np.zeros(len(lo), dtype=bool)
        if cell > least * 1.0001:
            keep.append((lo[~close], hi[~close]))
            half = cell / 2
            split_ = corner[close]
            corner = np.concatenate([split_ + np.array([a, b]) * half for a in (0, 1)
                                     for b in (0, 1)])
            corner = corner[(corner < high[[0, 2]]).all(axis=1)]
            cell = half
            continue
        out = inside(lo, hi, drop) if len(drop) else np.zeros(len(lo), dtype=bool)
        keep.append((lo[~out], hi[~out]))
        break
    lo = np.concatenate([k[0] for k in keep])
    hi = np.concatenate([k[1] for k in keep])
    boxes = np.stack([np.column_stack([lo[:, 0], np.full(len(lo), y0), lo[:, 1]]),
                      np.column_stack([hi[:, 0], np.full(len(lo), y1), hi[:, 1]])], axis=1)
    return boxes[np.argsort(morton(boxes[:, 0, [0, 2]], low[[0, 2]], least), kind="stable")]


def morton(corners, low, step) -> np.ndarray:
    """(V,) int64 Morton (Z-order) keys of x-z corners on a lattice of step from low: cells
    close in the plane get close ranks, so a triangle's cell pattern has long runs (zlib: 17%
    smaller on W5 than rows of z)."""
    q = np.floor((np.asarray(corners) - low) / step + 0.5).astype(np.int64)
    key = np.zeros(len(q), dtype=np.int64)
    for b in range(20):
        key |= ((q[:, 0] >> b) & 1) << (2 * b) | ((q[:, 1] >> b) & 1) << (2 * b + 1)
    return key

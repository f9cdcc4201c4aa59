"""Screen projection and a conservative low-resolution depth buffer (occluders shrunk, never
grown), with a max/min pyramid for rectangle queries, after Greene's hierarchical Z-buffer and
Intel's Masked Occlusion Culling (Hasselgren et al. 2016).

Camera space here: x right, y up, z = depth along the view direction (positive in front).
NDC: u = x / (z tx), v = y / (z ty) with tx, ty the tangents of the half fields of view;
pixel (i, j) of a W x H buffer covers u in [-1 + 2i/W, -1 + 2(i+1)/W], likewise v with j and H.
"""
from __future__ import annotations

import numpy as np

from .boxes import box_corners

EDGE_SLACK = 1e-9   # relative slack on edge functions: pixels on a triangle edge stay uncovered
DEPTH_SLACK = 1e-9  # relative slack on depths: occluders pushed back, boxes pulled forward


def to_camera(points, eye, rotation) -> np.ndarray:
    """(..., 3) float64 camera-space coordinates of world points.

    points : (..., 3) float64;  eye : (3,);  rotation : (3, 3) rows right, up, forward
    """
    return (np.asarray(points, dtype=np.float64) - eye) @ np.asarray(rotation).T


def clip_near(triangles, near: float, with_source: bool = False):
    """(K', 3, 3) float64 pieces of camera-space triangles with depth >= near (Sutherland-Hodgman,
    fan-split quads); exact: the pieces cover exactly the part of each triangle in front.

    triangles   : (K, 3, 3) float64 camera-space corners
    with_source : also return (K',) int64 the index of each piece's triangle
    """
    tri = np.asarray(triangles, dtype=np.float64).reshape(-1, 3, 3)
    if not len(tri):
        return (tri, np.zeros(0, dtype=np.int64)) if with_source else tri
    z = tri[:, :, 2]
    inside = z >= near
    nxt = np.roll(tri, -1, axis=1)
    crossing = inside != np.roll(inside, -1, axis=1)
    # Cut every edge from its nearer endpoint, so an edge shared by two triangles is cut at
    # bit-identical points from both sides (fused occluders cancel shared edges by value).
    first = z <= nxt[..., 2]
    a = np.where(first[..., None], tri, nxt)
    b = np.where(first[..., None], nxt, tri)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(crossing, (near - a[..., 2]) / (b[..., 2] - a[..., 2]), 0.0)
    cut = a + t[..., None] * (b - a)
    cut[..., 2] = np.where(crossing, near, cut[..., 2])
    # Slots 2i (vertex i) and 2i+1 (edge i's crossing), compacted to the front of each row.
    slots = np.stack([tri, cut], axis=2).reshape(-1, 6, 3)
    valid = np.stack([inside, crossing], axis=2).reshape(-1, 6)
    order = np.argsort(~valid, axis=1, kind="stable")[:, :4]
    poly = np.take_along_axis(slots, order[..., None], axis=1)  # (K, 4, 3)
    count = valid.sum(axis=1)
    pieces = np.concatenate([poly[count >= 3][:, [0, 1, 2]], poly[count == 4][:, [0, 2, 3]]])
    if with_source:
        source = np.concatenate([np.flatnonzero(count >= 3), np.flatnonzero(count == 4)])
        return pieces, source
    return pieces


def occluder_depth(triangles, width: int, height: int, tx: float, ty: float,
                   chunk: int = 32) -> np.ndarray:
    """(H, W) float64 depth buffer: for each pixel, the smallest over triangles covering the whole
    pixel of that triangle's largest depth over the pixel; inf where no triangle covers it.

    Errs toward "not covered" and "farther": a pixel counts only when its four corners are inside
    the triangle by a relative margin EDGE_SLACK (shrunk, never grown), and the depth written is
    the maximum of the triangle's plane over the pixel (1/z is affine in NDC, so it is taken at a
    corner) times (1 + DEPTH_SLACK).
    triangles : (K, 3, 3) float64 camera-space corners, every depth > 0 (clip_near them first)
    """
    tri = np.asarray(triangles, dtype=np.float64).reshape(-1, 3, 3)
    buffer = np.full((height, width), np.inf)
    us = -1.0 + 2.0 * np.arange(width + 1) / width
    vs = -1.0 + 2.0 * np.arange(height + 1) / height
    for begin in range(0, len(tri), chunk):
        part = tri[begin:begin + chunk]
        z = part[:, :, 2]
        u, v = part[:, :, 0] / (z * tx), part[:, :, 1] / (z * ty)  # (k, 3)
        area = (u[:, 1] - u[:, 0]) * (v[:, 2] - v[:, 0]) - (u[:, 2] - u[:, 0]) * (v[:, 1] - v[:, 0])
        keep = np.abs(area) > 1e-12
        if not keep.any():
            continue
        part, u, v, area = part[keep], u[keep], v[keep], area[keep]
        flip = area < 0  # make every triangle counter-clockwise in NDC
        u[flip] = u[flip][:, [0, 2, 1]]
        v[flip] = v[flip][:, [0, 2, 1]]
        # Edge p -> q: E(u, v) = a u + b v + c >= 0 inside.
        pu, pv, qu, qv = u, v, np.roll(u, -1, axis=1), np.roll(v, -1, axis=1)
        a, b = -(qv - pv), qu - pu
        c = -(a * pu + b * pv)
        margin = EDGE_SLACK * (np.abs(a) + np.abs(b) + np.abs(c))
        edge = (a[:, :, None, None] * us[None, None, None, :]
                + b[:, :, None, None] * vs[None, None, :, None]
                + (c - margin)[:, :, None, None])  # (k, 3, H+1, W+1)
        corner_in = (edge >= 0.0).all(axis=1)
        covered = (corner_in[:, :-1, :-1] & corner_in[:, 1:, :-1]
                   & corner_in[:, :-1, 1:] & corner_in[:, 1:, 1:])
        if not covered.any():
            continue
        # Camera-space plane n.X = d; on the ray through (u, v), 1/z = (n.(u tx, v ty, 1)) / d.
        n = np.cross(part[:, 1] - part[:, 0], part[:, 2] - part[:, 0])
        d = np.einsum("ij,ij->i", n, part[:, 0])
        inv = ((n[:, 0] * tx / d)[:, None, None] * us[None, None, :]
               + (n[:, 1] * ty / d)[:, None, None] * vs[None, :, None]
               + (n[:, 2] / d)[:, None, None])  # (k, H+1, W+1)
        low = np.minimum(np.minimum(inv[:, :-1, :-1], inv[:, 1:, :-1]),
                         np.minimum(inv[:, :-1, 1:], inv[:, 1:, 1:]))
        with np.errstate(divide="ignore"):
            depth = np.where(covered & (low > 0), (1.0 + DEPTH_SLACK) / low, np.inf)
        np.minimum(buffer, depth.min(axis=0), out=buffer)
    return buffer


def pyramid(buffer, reduce) -> tuple:
    """Flattened reduction pyramid of an (H, W) buffer: (values (M,), offsets (L,), widths (L,)).

    Level 0 is the buffer; level l+1 reduces 2x2 texels of level l with `reduce` (np.maximum or
    np.minimum), padding odd sizes with +inf for max (never hides) and with the edge for min.
    """
    levels = [np.asarray(buffer, dtype=np.float64)]
    while levels[-1].shape != (1, 1):
        top = levels[-1]
        h, w = top.shape
        pad = ((0, h % 2), (0, w % 2))
        if reduce is np.maximum:
            top = np.pad(top, pad, constant_values=np.inf)
        else:
            top = np.pad(top, pad, mode="edge")
        levels.append(reduce(reduce(top[0::2, 0::2], top[1::2, 0::2]),
                             reduce(top[0::2, 1::2], top[1::2, 1::2])))
    sizes = np.array([lv.size for lv in levels])
    offsets = np.concatenate([[0], np.cumsum(sizes)[:-1]])
    widths = np.array([lv.shape[1] for lv in levels])
    return np.concatenate([lv.ravel() for lv in levels]), offsets, widths


def rect_query(pyr, x0, x1, y0, y1, reduce=np.max) -> np.ndarray:
    """(B,) float64 reduction of the pyramid over a superset of each inclusive pixel rectangle:
    the coarsest level where the rectangle spans at most 2 x 2 texels, then those 4 texels.

    Errs outward: for a max pyramid the answer is >= the rectangle's true max (conservative for
    occlusion), for a min pyramid <= the true min.
    pyr : from pyramid();  x0, x1, y0, y1 : (B,) int64 with x0 <= x1, y0 <= y1, inside the buffer
    reduce : np.max for a max pyramid, np.min for a min pyramid
    """
    values, offsets, widths = pyr
    span = np.maximum(x1 - x0, y1 - y0) + 1
    level = np.ceil(np.log2(span)).astype(np.int64)
    level = np.minimum(level, len(offsets) - 1)
    ax0, ax1, ay0, ay1 = x0 >> level, x1 >> level, y0 >> level, y1 >> level
    base, w = offsets[level], widths[level]
    picks = values[np.stack([base + ay0 * w + ax0, base + ay0 * w + ax1,
                             base + ay1 * w + ax0, base + ay1 * w + ax1])]
    return reduce(picks, axis=0)


def box_rects(boxes, eye, rotation, near: float, tx: float, ty: float,
              width: int, height: int) -> tuple:
    """Conservative screen rectangles of boxes: (x0, x1, y0, y1 (B,) int64 inclusive pixels,
    zmin (B,) float64 nearest depth, testable (B,) bool).

    Errs large: the rectangle bounds the projection of all 8 corners, grown by 1e-6 of a pixel;
    a box is not testable when any corner is nearer than `near` or its rectangle is off screen.
    boxes : (B, 2, 3) float64;  rotation : (3, 3) rows right, up, forward
    """
    cam = to_camera(box_corners(boxes), eye, rotation)  # (B, 8, 3)
    z = cam[..., 2]
    zmin = z.min(axis=1)
    testable = zmin >= near
    zsafe = np.where(testable[:, None], z, 1.0)
    u, v = cam[..., 0] / (zsafe * tx), cam[..., 1] / (zsafe * ty)
    x0 = np.floor((u.min(axis=1) + 1.0) * 0.5 * width - 1e-6)
    x1 = np.floor((u.max(axis=1) + 1.0) * 0.5 * width + 1e-6)
    y0 = np.floor((v.min(axis=1) + 1.0) * 0.5 * height - 1e-6)
    y1 = np.floor((v.max(axis=1) + 1.0) * 0.5 * height + 1e-6)
    testable &= (x1 >= 0) & (x0 <= width - 1) & (y1 >= 0) & (y0 <= height - 1)
    x0, x1 = np.clip(x0, 0, width - 1), np.clip(x1, 0, width - 1)
    y0, y1 = np.clip(y0, 0, height - 1), np.clip(y1, 0, height - 1)
    return (x0.astype(np.int64), x1.astype(np.int64), y0.astype(np.int64), y1.astype(np.int64),
            zmin * (1.0 - DEPTH_SLACK), testable)


def fused_occluder_depth(triangles, groups, width: int, height: int, tx: float,
                         ty: float) -> np.ndarray:
    """(H, W) float64 depth buffer of coplanar groups of triangles rasterised as unions, so the
    edges they share leave no uncovered cracks; inf where no group covers a pixel.

    Errs toward "not covered" and "farther". Within a group, edges that occur an even number of
    times (by exact endpoint value) are dropped; the parity of the remaining edges' crossings is
    then odd exactly on points covered an odd number of times, and constant across any pixel no
    remaining edge touches. A pixel counts when its 4 corners are odd and no remaining edge's
    line passes within EDGE_SLACK of the pixel inside the edge's bounding box: the whole pixel
    is then inside the union. Depth: the largest over the pixel of any member's plane, times
    (1 + DEPTH_SLACK).
    triangles : (K, 3, 3) float64 camera-space corners, every depth > 0 (clip_near them first)
    groups    : (K,) int64 group label; triangles of one group must be coplanar
    """
    tri = np.asarray(triangles, dtype=np.float64).reshape(-1, 3, 3)
    groups = np.asarray(groups)
    buffer = np.full((height, width), np.inf)
    us = -1.0 + 2.0 * np.arange(width + 1) / width
    vs = -1.0 + 2.0 * np.arange(height + 1) / height
    pix_u = np.arange(width)
    pix_v = np.arange(height)
    for label in np.unique(groups):  # a few occluder groups per frame
        part = tri[groups == label]
        # Edges by exact endpoint value, sorted so a shared edge has one key from both sides.
        p, q = part, np.roll(part, -1, axis=1)
        ends = np.stack([p.reshape(-1, 3), q.reshape(-1, 3)], axis=1)  # (E, 2, 3)
        flip = _lex_greater(ends[:, 0], ends[:, 1])
        canon = np.where(flip[:, None, None], ends[:, ::-1], ends)
        _, inverse, counts = np.unique(canon.reshape(-1, 6), axis=0, return_inverse=True,
                                       return_counts=True)
        edges = canon[(counts[inverse.ravel()] % 2) == 1]
        if not len(edges):
            continue
        z = edges[..., 2]
        eu, ev = edges[..., 0] / (z * tx), edges[..., 1] / (z * ty)  # (E, 2)
        # Parity of crossings of a ray toward +u from every pixel corner.
        pv, qv, pu, qu = ev[:, 0, None, None], ev[:, 1, None, None], eu[:, 0, None, None], \
            eu[:, 1, None, None]
        V, U = vs[None, :, None], us[None, None, :]
        straddle = (pv > V) != (qv > V)
        with np.errstate(divide="ignore", invalid="ignore"):
            cross_u = pu + (V - pv) * (qu - pu) / (qv - pv)
        odd = (np.count_nonzero(straddle & (U < cross_u), axis=0) % 2) == 1  # (H+1, W+1)
        inside = odd[:-1, :-1] & odd[1:, :-1] & odd[:-1, 1:] & odd[1:, 1:]
        if not inside.any():
            continue
        # Pixels an edge may touch: its line passes near the pixel, inside its bounding box.
        a, b = -(ev[:, 1] - ev[:, 0]), eu[:, 1] - eu[:, 0]
        c = -(a * eu[:, 0] + b * ev[:, 0])
        margin = EDGE_SLACK * (np.abs(a) + np.abs(b) + np.abs(c))
        line = a[:, None, None] * U + b[:, None, None] * V + c[:, None, None]
        lo = np.minimum(np.minimum(line[:, :-1, :-1], line[:, 1:, :-1]),
                        np.minimum(line[:, :-1, 1:], line[:, 1:, 1:]))
        hi = np.maximum(np.maximum(line[:, :-1, :-1], line[:, 1:, :-1]),
                        np.maximum(line[:, :-1, 1:], line[:, 1:, 1:]))
        near_line = (lo <= margin[:, None, None]) & (hi >= -margin[:, None, None])
        x0 = np.floor((eu.min(axis=1) + 1.0) * 0.5 * width - 1e-6)
        x1 = np.floor((eu.max(axis=1) + 1.0) * 0.5 * width + 1e-6)
        y0 = np.floor((ev.min(axis=1) + 1.0) * 0.5 * height - 1e-6)
        y1 = np.floor((ev.max(axis=1) + 1.0) * 0.5 * height + 1e-6)
        in_box = (((pix_u >= x0[:, None]) & (pix_u <= x1[:, None]))[:, None, :]
                  & ((pix_v >= y0[:, None]) & (pix_v <= y1[:, None]))[:, :, None])
        covered = inside & ~(near_line & in_box).any(axis=0)
        if not covered.any():
            continue
        n = np.cross(part[:, 1] - part[:, 0], part[:, 2] - part[:, 0])
        d = np.einsum("ij,ij->i", n, part[:, 0])
        inv = ((n[:, 0] * tx / d)[:, None, None] * us[None, None, :]
               + (n[:, 1] * ty / d)[:, None, None] * vs[None, :, None]
               + (n[:, 2] / d)[:, None, None]).min(axis=0)  # (H+1, W+1) over members
        low = np.minimum(np.minimum(inv[:-1, :-1], inv[1:, :-1]),
                         np.minimum(inv[:-1, 1:], inv[1:, 1:]))
        with np.errstate(divide="ignore"):
            depth = np.where(covered & (low > 0), (1.0 + DEPTH_SLACK) / low, np.inf)
        np.minimum(buffer, depth, out=buffer)
    return buffer


def _lex_greater(a, b) -> np.ndarray:
    """(E,) bool: row a > row b lexicographically (a, b (E, 3))."""
    greater = np.zeros(len(a), dtype=bool)
    decided = np.zeros(len(a), dtype=bool)
    for k in range(a.shape[1]):
        greater |= ~decided & (a[:, k] > b[:, k])
        decided |= a[:, k] != b[:, k]
    return greater

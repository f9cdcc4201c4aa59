"""Crack portals of the PVS's view cells: the lines where the rasteriser may leave a pixel open.

Two triangles meeting along an edge with the same two corners never leave a gap (the GPU's
fill rule); an edge that is not shared so (a T-junction, two surfaces meeting in a crease with
their own vertices, a mesh's border) may leave pixels open along it, and the item buffer shows
what lies behind (W1: a floor meeting a wall, the ceiling below the slab seen through the
crease). Every unshared edge becomes a segment portal between each pair of cells whose
common face (or line) it lies in, and the walk (pvs_kernels.flow_from_cell) lets every line
through it that comes within its width: grow + CRACK_SLOPE x the distance from the source.

Contract: the sets hold what the item buffer shows through a crack where the line of sight
passes the wall within the crack's width w = grow + CRACK_SLOPE x (its distance from the eye)
of an unshared edge. A rasteriser snapping vertices to 1/2^b of a pixel opens gaps about 2^-b
pixels wide across the line of sight, which on a wall met at an angle a lie within
2^-b / sin(a) pixels of the edge; CRACK_SLOPE is CRACK_PIXELS = 1/16 of a pixel PIXEL_SLOPE
= 2^-6 wide per unit of depth (a 120° field of view over at least 222 pixels; the devices'
240 x 320 buffers have 0.0108 at 120°): it covers b = 8 (llvmpipe, most GPUs) on walls met at
more than 3.6° and b = 4 (GL's minimum) at right angles. A line passing the wall at such a
point y leaves a cell A for a cell B there, y lies on their common face or line, and so does
the wall's unshared edge (crack_portals): the walk lets it through the pair's crack portal,
with y in the crossing box (pvs_kernels._crack_candidate).
"""
from __future__ import annotations

import numpy as np

CRACK_PIXELS = 1.0 / 16.0  # gap width in pixels (module docstring)
PIXEL_SLOPE = 2.0 ** -6  # pixel width per unit of depth the contract covers
CRACK_SLOPE = CRACK_PIXELS * PIXEL_SLOPE  # crack width per unit of distance from the eye
CHUNK = 2048  # edges tested against every cell at once
PAIRS = 1 << 18  # pairs of an edge's cells tested at once


def unshared_edges(world) -> np.ndarray:
    """(E, 2, 3) float64 triangle edges whose two corners (by position) no other triangle shares."""
    return unshared_edge_triangles(world)[0]


def unshared_edge_triangles(world) -> tuple:
    """(unshared_edges (E, 2, 3) float64, the triangle each belongs to (E,) int64)."""
    tri = np.asarray(world.triangles)
    if not len(tri):
        return np.zeros((0, 2, 3)), np.zeros(0, dtype=np.int64)
    _, inv = np.unique(np.asarray(world.vertices), axis=0, return_inverse=True)
    t = inv.ravel()[tri]
    edges = np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]])
    ends = np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]])
    edges.sort(axis=1)
    _, first, counts = np.unique(edges, axis=0, return_index=True, return_counts=True)
    lone = first[counts == 1]
    lone = lone[edges[lone, 0] != edges[lone, 1]]  # a degenerate triangle's point edge: skip
    return (np.asarray(world.vertices, dtype=np.float64)[ends[lone]],
            (lone % len(tri)).astype(np.int64))


def clip_segments(seg, lo, hi, eps):
    """(K,) t0, t1 of each segment's part inside its box grown by eps (t0 > t1: misses)."""
    p, d = seg[:, 0], seg[:, 1] - seg[:, 0]
    t0, t1 = np.zeros(len(seg)), np.ones(len(seg))
    for a in range(3):
        da = d[:, a]
        flat = np.abs(da) < 1e-300
        with np.errstate(divide="ignore", invalid="ignore"):
            u = (lo[:, a] - eps - p[:, a]) / da
            v = (hi[:, a] + eps - p[:, a]) / da
        near, far = np.minimum(u, v), np.maximum(u, v)
        inside = (p[:, a] >= lo[:, a] - eps) & (p[:, a] <= hi[:, a] + eps)
        near = np.where(flat, np.where(inside, -np.inf, np.inf), near)
        far = np.where(flat, np.where(inside, np.inf, -np.inf), far)
        t0, t1 = np.maximum(t0, near), np.minimum(t1, far)
    return t0, t1


def crack_reach(world, grow) -> float:
    """The widest crack (grow + CRACK_SLOPE x the world box's diagonal)."""
    return grow + CRACK_SLOPE * float(np.linalg.norm(np.ptp(world.extent, axis=0)))


def crack_portals(world, boxes, eps, reach=0.0) -> tuple:
    """(pairs (K, 2) int64 low cell id first, quads (K, 4, 3) float64 degenerate segments
    [q0, q1, q1, q0]) of the unshared edges: for every pair of cells whose boxes touch along a
    face or a line (within eps) in which the edge lies, the part of the edge within reach +
    eps of that face or line; collinear pieces of one pair along one axis-aligned line are
    merged into their bounding segment.

    Why only those: a line passes a surface at a crack point y into another cell only where
    the surface lies in a cell face (portal.py: walls within the cells' thickness of a face
    block; anything else lies inside a cell, which the walk crosses whole), so y lies in the
    face A | B of the cells before and after it (or on their common line), and so does the
    wall's unshared edge within the crack's width of y. And only edges of triangles lying in
    that face's plane (within eps; on a common line, in either plane through it): what blocks
    a line crossing the face is the triangles lying in it (portal.py; a closed solid crossing
    it has no unshared edge), and their rasterised cover of the plane is open only within the
    crack's width of their own unshared edges; elsewhere an edge they share by both corners
    is watertight (the fill rule), whatever other triangle's edge lies on them (a ramp's side
    standing against a wall does not open the wall)."""
    seg, owner = unshared_edge_triangles(world)
    pairs, quads, _ = edge_portals(world, seg, owner, boxes, eps, reach)
    return pairs, quads


def edge_portals(world, seg, owner, boxes, eps, reach=0.0, tags=None) -> tuple:
    """crack_portals' (pairs, quads) for the edges seg (E, 2, 3) of the triangles owner (E,),
    plus each portal's tag (K,) int64 (its edge's tags[e], -1 without tags; pieces of
    different tags are not merged). Portals in the order of their first piece (edges in
    order, then the pairs of their cells in ascending order)."""
    tags = np.full(len(seg), -1, dtype=np.int64) if tags is None else np.asarray(tags)
    tri_lo, tri_hi = world.bounds[owner, 0], world.bounds[owner, 1]
    lo_b, hi_b = boxes[:, 0], boxes[:, 1]
    near = eps + reach
    found = []  # per chunk: (a, b, edge ids, q0, q1) of the pieces kept, in order
    for s in range(0, len(seg), CHUNK):
        part = seg[s:s + CHUNK]
        slo, shi = part.min(axis=1), part.max(axis=1)
        hit = ((slo[:, None] <= hi_b[None] + near) & (shi[:, None] >= lo_b[None] - near)).all(-1)
        e, c = np.nonzero(hit)
        t0, t1 = clip_segments(part[e], lo_b[c], hi_b[c], near)
        ok = t0 <= t1
        e, c = e[ok], c[ok]
        if not len(e):
            continue
        # cells per edge (ascending), and every pair of them, edge by edge
        order = np.argsort(e, kind="stable")
        e, c = e[order], c[order]
        last = np.r_[np.flatnonzero(e[1:] != e[:-1]), len(e) - 1]  # each edge's last row
        end = np.repeat(last + 1, np.diff(np.r_[0, last + 1]))
        later = end - np.arange(len(e)) - 1
        pair_i = np.repeat(np.arange(len(e)), later)
        pair_j = pair_i + 1 + np.arange(len(pair_i)) - np.repeat(np.cumsum(later) - later, later)
        for k in range(0, len(pair_i), PAIRS):  # bounded memory: an edge may span many cells
            i, j = pair_i[k:k + PAIRS], pair_j[k:k + PAIRS]
            a, b = np.minimum(c[i], c[j]), np.maximum(c[i], c[j])
            lo = np.maximum(lo_b[a], lo_b[b])
            hi = np.minimum(hi_b[a], hi_b[b])
            flat = hi - lo <= eps
            keep = ~(hi < lo - eps).any(axis=1) & flat.any(axis=1)  # touching, not overlapping
            mid = 0.5 * (lo + hi)
            edge = part[e[i]]
            # the edge lies in their common face or line ...
            keep &= ~((np.abs(edge - mid[:, None]) > eps) & flat[:, None]).any(axis=(1, 2))
            t = s + e[i]
            # ... and its triangle in one of that face's (line's) planes
            keep &= (flat & (np.abs(tri_lo[t] - mid) <= eps)
                     & (np.abs(tri_hi[t] - mid) <= eps)).any(axis=1)
            rows = np.flatnonzero(keep)
            u0, u1 = clip_segments(edge[rows], lo[rows], hi[rows], near)
            inside = u0 <= u1
            rows, u0, u1 = rows[inside], u0[inside], u1[inside]
            p = edge[rows, 0]
            d = edge[rows, 1] - edge[rows, 0]
            found.append((a[rows], b[rows], t[rows], p + u0[:, None] * d,
                          p + u1[:, None] * d))
    if not found:
        return np.zeros((0, 2), np.int64), np.zeros((0, 4, 3)), np.zeros(0, np.int64)
    a, b, t, q0, q1 = (np.concatenate(x) for x in zip(*found))
    d = seg[t, 1] - seg[t, 0]
    moving = np.abs(d) > 0
    aligned = moving.sum(axis=1) == 1  # axis-aligned: merged along its line
    axis = np.argmax(moving, axis=1)
    rounded = np.round(q0, 9)
    slot_of, slots, keys = {}, np.empty(len(a), dtype=np.int64), []
    for r in range(len(a)):
        if aligned[r]:
            k = int(axis[r])
            u, v = rounded[r, (k + 1) % 3], rounded[r, (k + 2) % 3]
            key = (int(a[r]), int(b[r]), k, u, v, int(tags[t[r]]))
        else:
            key = r  # a piece of its own
        slots[r] = slot_of.setdefault(key, len(slot_of))
        if slots[r] == len(keys):
            keys.append(r)
    first = np.asarray(keys, dtype=np.int64)
    out0 = np.where(aligned[first, None], np.inf, q0[first])
    out1 = np.where(aligned[first, None], -np.inf, q1[first])
    merge = np.flatnonzero(aligned)
    np.minimum.at(out0, slots[merge], np.minimum(q0[merge], q1[merge]))
    np.maximum.at(out1, slots[merge], np.maximum(q0[merge], q1[merge]))
    pairs = np.stack([a[first], b[first]], axis=1).astype(np.int64).reshape(-1, 2)
    quads = np.stack([out0, out1, out1, out0], axis=1).astype(np.float64).reshape(-1, 4, 3)
    return pairs, quads, tags[t[first]].astype(np.int64)


def with_cracks(world, g, eps, reach=0.0) -> dict:
    """The view grid g (pvs_cells.view_grid) with the crack portals (crack_portals: cells
    within reach of an unshared edge) appended last, their count in g['cracks']."""
    pairs, quads = crack_portals(world, np.asarray(g["cell_bounds"], dtype=np.float64), eps,
                                 reach)
    if not len(pairs):
        return g
    pcells = np.concatenate([np.asarray(g["portal_cells"], dtype=np.int64).reshape(-1, 2), pairs])
    verts = np.concatenate([np.asarray(g["portal_vertices"], dtype=np.float64).reshape(-1, 3),
                            quads.reshape(-1, 3)])
    count = len(g["cell_bounds"])
    ends = np.concatenate([pcells[:, 0], pcells[:, 1]])
    ids = np.tile(np.arange(len(pcells)), 2)
    order = np.lexsort((ids, ends))
    cps = np.concatenate([[0], np.cumsum(np.bincount(ends, minlength=count))]).astype(np.int64)
    return {**g, "portal_cells": pcells, "portal_vertices": verts,
            "portal_start": np.arange(0, 4 * len(pcells) + 1, 4),
            "cell_portal_start": cps, "cell_portals": ids[order].astype(np.int64),
            "cracks": len(pairs)}

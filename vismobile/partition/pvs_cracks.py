"""Crack portals of the PVS's view cells: the lines where the rasteriser may leave a pixel open.

Two triangles meeting along an edge with the same two corners never leave a gap (the GPU's
fill rule); an edge that is not shared so (a T-junction, two surfaces meeting in a crease with
their own vertices, a mesh's border) may leave single pixels open along it, and the item buffer
shows what lies behind (W1: a ceiling meeting a wall, the inside of the slab above seen
through the crease; the hollow walls are otherwise closed once pvs_refine seals the doorways).
A line through such an edge passes from one cell to another without crossing an open face, so
every unshared edge lying on the boundary of two cells becomes a degenerate portal (a segment)
between them: the walk (pvs_kernels.flow_from_cell) takes it like any other portal.

Sound: the crack portals hold every point of every unshared edge where it lies in two cells'
boxes (within eps), for every pair of cells whose boxes both hold it, face or edge neighbours.
"""
from __future__ import annotations

import numpy as np

CHUNK = 2048  # edges tested against every cell at once


def unshared_edges(world) -> np.ndarray:
    """(E, 2, 3) float64 triangle edges whose two corners (by position) no other triangle shares."""
    tri = np.asarray(world.triangles)
    if not len(tri):
        return np.zeros((0, 2, 3))
    _, inv = np.unique(np.asarray(world.vertices), axis=0, return_inverse=True)
    t = inv.ravel()[tri]
    edges = np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]])
    ends = np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]])
    edges.sort(axis=1)
    _, first, counts = np.unique(edges, axis=0, return_index=True, return_counts=True)
    lone = first[counts == 1]
    lone = lone[edges[lone, 0] != edges[lone, 1]]  # a degenerate triangle's point edge: skip
    return np.asarray(world.vertices, dtype=np.float64)[ends[lone]]


def _clip(seg, lo, hi, eps):
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


def crack_portals(world, boxes, eps) -> tuple:
    """(pairs (K, 2) int64 low cell id first, quads (K, 4, 3) float64 degenerate segments) of
    the unshared edges lying in two cells' boxes (grown by eps); collinear pieces of one pair
    along one axis-aligned line are merged into their bounding segment."""
    seg = unshared_edges(world)
    lo_b, hi_b = boxes[:, 0], boxes[:, 1]
    pieces = {}
    for s in range(0, len(seg), CHUNK):
        part = seg[s:s + CHUNK]
        slo, shi = part.min(axis=1), part.max(axis=1)
        hit = ((slo[:, None] <= hi_b[None] + eps) & (shi[:, None] >= lo_b[None] - eps)).all(-1)
        e, c = np.nonzero(hit)
        t0, t1 = _clip(part[e], lo_b[c], hi_b[c], eps)
        ok = t0 <= t1
        e, c, t0, t1 = e[ok], c[ok], t0[ok], t1[ok]
        if not len(e):
            continue
        # cells per edge: every pair of them whose parameter ranges overlap
        order = np.argsort(e, kind="stable")
        e, c, t0, t1 = e[order], c[order], t0[order], t1[order]
        starts = np.flatnonzero(np.r_[True, e[1:] != e[:-1]])
        ends = np.r_[starts[1:], len(e)]
        for i0, i1 in zip(starts, ends):
            if i1 - i0 < 2:
                continue
            p, d = part[e[i0], 0], part[e[i0], 1] - part[e[i0], 0]
            for i in range(i0, i1):
                for j in range(i + 1, i1):
                    a0, a1 = max(t0[i], t0[j]), min(t1[i], t1[j])
                    if a0 > a1:
                        continue
                    a, b = sorted((int(c[i]), int(c[j])))
                    if np.sum(np.minimum(hi_b[a], hi_b[b]) - np.maximum(lo_b[a], lo_b[b])
                              > eps) < 2:
                        continue  # edge neighbours: the line crosses a face neighbour's face
                    q0, q1 = p + a0 * d, p + a1 * d
                    axis = np.flatnonzero(np.abs(d) > 0)
                    if len(axis) == 1:  # axis-aligned: merge along its line
                        k = int(axis[0])
                        key = (a, b, k) + tuple(np.round(np.delete(q0, k), 9))
                    else:
                        key = (a, b, -1, len(pieces))
                    old = pieces.get(key)
                    lo, hi = np.minimum(q0, q1), np.maximum(q0, q1)
                    if key[2] < 0:
                        pieces[key] = (q0, q1)
                    else:  # the bounding segment of the pieces on this line
                        pieces[key] = (lo, hi) if old is None else (np.minimum(old[0], lo),
                                                                    np.maximum(old[1], hi))
    pairs = np.array([k[:2] for k in pieces], dtype=np.int64).reshape(-1, 2)
    quads = np.array([[q0, q1, q1, q0] for q0, q1 in pieces.values()],
                     dtype=np.float64).reshape(-1, 4, 3)
    return pairs, quads


def with_cracks(world, g, eps) -> dict:
    """The view grid g (pvs_cells.view_grid) with the crack portals appended."""
    pairs, quads = crack_portals(world, np.asarray(g["cell_bounds"], dtype=np.float64), eps)
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

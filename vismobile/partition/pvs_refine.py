"""The PVS's view cells split at the walls inside them (pvs_cells.view_grid, then refine).

A thin cell (the inside of a hollow wall or slab, pvs_cells.paired_edges) is a box the portal
walk takes as free space, but the reveals lining a doorway or a window cross it: a line entering
through the doorway may, in the box, run along the wall's inside to every other doorway, and the
hollow walls joined every room to every other (W1: a room's set held 78% of the world; with
these channels closed, 9%). Splitting the cell at the planes of the axis-aligned walls inside it
that span its thin side puts each reveal on a cell face, where the portals see it: the doorway
becomes a cell of its own, closed on its sides and above by its reveals.

Sound whatever the cuts: the sub-cells tile their cell, portals inside a cell are its sub-cells'
faces' openings (portal.PlaneGeometry, as for any cell face), and a portal between sub-cells of
two cells is a portal of those cells clipped to both sub-cells' faces (every open point of the
face lies in some portal, and in the faces of the two sub-cells a line crosses between).
"""
from __future__ import annotations

import numpy as np

from . import grid, portal
from .solids import outward_solid_faces

THIN = 0.1  # a cell is thin when its smallest side is at most this share of its largest one
MAX_CUTS = 6  # wall planes per axis per cell, largest walls first
ALIGNED = 0.999  # |normal| along an axis above this: the triangle lies in that axis's plane


def inner_cuts(world, lo, hi, tris, eps) -> list:
    """Three ascending boundary arrays of one cell [lo, hi]: its own faces plus, along each axis
    but the thinnest, the planes of axis-aligned triangles (of `tris`) strictly inside the cell
    whose boxes span its thin side (at most MAX_CUTS per axis, largest total area first)."""
    edges = [np.array([lo[a], hi[a]], dtype=np.float64) for a in range(3)]
    size = np.sort(hi - lo)
    if not len(tris) or size[0] > THIN * size[2]:
        return edges
    t = int(np.argmin(hi - lo))
    tb = world.bounds[tris]
    spans = (tb[:, 0, t] <= lo[t] + eps) & (tb[:, 1, t] >= hi[t] - eps)
    for a in range(3):
        if a == t:
            continue
        pos = tb[:, 0, a]
        ok = (spans & (np.abs(world.normals[tris, a]) > ALIGNED) & (pos > lo[a] + eps)
              & (pos < hi[a] - eps))
        if not ok.any():
            continue
        keys, inverse = np.unique(np.round(pos[ok], 6), return_inverse=True)
        area = np.bincount(inverse.ravel(), weights=world.areas[tris[ok]])
        keep = keys[np.argsort(-area)[:MAX_CUTS]]
        edges[a] = np.unique(np.concatenate([edges[a], keep]))
    return edges


def _face_rect(box, axis):
    """(2, 2) [[u0, v0], [u1, v1]] of a box's extent across `axis`."""
    u, v = (axis + 1) % 3, (axis + 2) % 3
    return np.array([[box[0, u], box[0, v]], [box[1, u], box[1, v]]])


def _quads(axis, plane, rects):
    """(Q, 4, 3) portal quads of (Q, 2, 2) rectangles in the plane (portal.find_portals' order)."""
    u, v = (axis + 1) % 3, (axis + 2) % 3
    quads = np.zeros((len(rects), 4, 3))
    quads[:, :, axis] = plane
    quads[:, :, u] = rects[:, [0, 1, 1, 0], 0]
    quads[:, :, v] = rects[:, [0, 0, 1, 1], 1]
    return quads


def refine(world, g, thickness) -> dict:
    """A view grid (pvs_cells.view_grid's dict) with its thin cells split at their inner walls
    (inner_cuts); the same keys, 'edges' kept as the unsplit grid's, plus 'parent' (C',) int64."""
    bounds, start, tris = g["cell_bounds"], g["cell_start"], g["cell_tris"]
    eps = portal.COINCIDE * float(np.ptp(world.extent, axis=0).max())
    eps = max(eps, thickness)
    boxes, parent, first, cell_tris, cell_counts, local_edges = [], [], [], [], [], []
    split = np.zeros(len(bounds), dtype=bool)
    for c, (lo, hi) in enumerate(bounds):
        own = tris[start[c]:start[c + 1]]
        edges = inner_cuts(world, lo, hi, own, eps)
        local_edges.append(edges)
        first.append(len(boxes))
        if all(len(e) == 2 for e in edges):
            boxes.append(np.asarray(bounds[c], dtype=np.float64))
            parent.append(c)
            cell_tris.append(own)
            cell_counts.append(len(own))
            continue
        split[c] = True
        sub = grid.cell_boxes(edges)
        cell, tri = grid.cell_pairs(world, edges, triangles=own, slack=thickness)
        counts = np.bincount(cell, minlength=len(sub))
        boxes.extend(sub)
        parent.extend([c] * len(sub))
        order = np.argsort(cell, kind="stable")
        cell_tris.append(tri[order])
        cell_counts.extend(counts.tolist())
    first.append(len(boxes))
    boxes = np.asarray(boxes, dtype=np.float64).reshape(-1, 2, 3)
    pcells, quads = [], []
    solid = outward_solid_faces(world)
    corners = world.corners
    planes = {}

    def geometry(axis, plane):
        key = (axis, float(plane))
        if key not in planes:
            planes[key] = portal.PlaneGeometry(world, corners, axis, plane, thickness, eps, solid)
        return planes[key]

    # portals inside a split cell: its sub-cells' shared faces
    for c in np.flatnonzero(split):
        edges = local_edges[c]
        shape = [len(e) - 1 for e in edges]
        for axis in range(3):
            for b in range(1, shape[axis]):
                plane = edges[axis][b]
                geo = geometry(axis, plane)
                for low in range(first[c], first[c + 1]):
                    i = np.unravel_index(low - first[c], shape)
                    if i[axis] != b - 1:
                        continue
                    j = list(i)
                    j[axis] = b
                    high = first[c] + int(np.ravel_multi_index(j, shape))
                    rect = _face_rect(boxes[low], axis)
                    rects = geo.openings(rect[0], rect[1])
                    if len(rects):
                        pcells.extend([(low, high)] * len(rects))
                        quads.append(_quads(axis, plane, rects))
    # portals between cells, clipped to their sub-cells' faces
    old = np.asarray(g["portal_vertices"], dtype=np.float64).reshape(-1, 4, 3)
    for p, (a, b) in enumerate(g["portal_cells"]):
        q = old[p]
        axis = int(np.argmin(np.ptp(q, axis=0)))
        plane = q[0, axis]
        if not split[a] and not split[b]:
            pcells.append((first[a], first[b]))
            quads.append(q[None])
            continue
        qr = _face_rect(np.stack([q.min(axis=0), q.max(axis=0)]), axis)
        subs_a = [s for s in range(first[a], first[a + 1]) if boxes[s, 1, axis] == plane
                  or (not split[a])]
        subs_b = [s for s in range(first[b], first[b + 1]) if boxes[s, 0, axis] == plane
                  or (not split[b])]
        for sa in subs_a:
            ra = _face_rect(boxes[sa], axis)
            for sb in subs_b:
                rb = _face_rect(boxes[sb], axis)
                lo_uv = np.maximum(np.maximum(ra[0], rb[0]), qr[0])
                hi_uv = np.minimum(np.minimum(ra[1], rb[1]), qr[1])
                if np.all(hi_uv > lo_uv):
                    pcells.append((sa, sb))
                    quads.append(_quads(axis, plane, np.stack([lo_uv, hi_uv])[None]))
    count = len(boxes)
    pcells = np.array(pcells, dtype=np.int64).reshape(-1, 2)
    verts = np.concatenate(quads).reshape(-1, 3) if quads else np.zeros((0, 3))
    ends = np.concatenate([pcells[:, 0], pcells[:, 1]])
    ids = np.tile(np.arange(len(pcells)), 2)
    order = np.lexsort((ids, ends))
    cps = np.concatenate([[0], np.cumsum(np.bincount(ends, minlength=count))]).astype(np.int64)
    cell_start = np.concatenate([[0], np.cumsum(cell_counts)]).astype(np.int64)
    return {"edges": g["edges"], "cell_bounds": boxes, "cell_start": cell_start,
            "cell_tris": (np.concatenate(cell_tris) if cell_tris else np.zeros(0)).astype(np.int64),
            "portal_cells": pcells, "portal_start": np.arange(0, 4 * len(pcells) + 1, 4),
            "portal_vertices": verts, "cell_portal_start": cps,
            "cell_portals": ids[order].astype(np.int64), "parent": np.asarray(parent, np.int64)}

"""The view cells of the conservative PVS: a portal grid of its own (portal.py's cells and
portals), whatever the partition's structure, whose boundaries take both faces of each thick
wall or slab.

portal.auto_edges snaps each cell boundary to one large axis-aligned wall plane. A hollow wall
or slab then lies inside a cell, and its inside (unless it is a closed solid, solids.py) is a
thin open strip on every cell face that crosses it: the portals join every cell to every other
along the walls. Adding the wall's other face as a boundary puts the inside in thin cells of its
own, closed on both sides by the walls lying in their faces; they connect to the rooms only
where the wall is open (doorways' uncapped jambs), as sight lines really can.
"""
from __future__ import annotations

import numpy as np

from . import grid, portal

# A second face is looked for this far (a fraction of the world's extent along the axis).
PAIR_REACH = 0.02
# ... and kept when its wall area is at least this share of the snapped plane's.
PAIR_AREA = 0.25
# An axis with no interior boundary takes every wall plane covering this share of the world's
# cross-section (a floor slab between storeys: both its faces).
SLAB_AREA = 0.25


def paired_edges(world, cells) -> list:
    """Three ascending boundary arrays: portal.auto_edges plus, next to each interior boundary,
    the largest parallel wall plane within PAIR_REACH on either side, and on an axis without
    interior boundaries every plane of walls covering SLAB_AREA of the cross-section."""
    edges = portal.auto_edges(world, cells)
    low, high = world.extent
    for axis in range(3):
        e = edges[axis]
        aligned = np.abs(world.normals[:, axis]) > 0.999
        if not aligned.any():
            continue
        pos = world.centroids[aligned, axis]
        keys, inverse = np.unique(np.round(pos, 6), return_inverse=True)
        area = np.bincount(inverse.ravel(), weights=world.areas[aligned])
        actual = np.empty(len(keys))
        actual[inverse.ravel()] = pos
        if len(e) <= 2:
            others = np.delete(high - low, axis)
            big = (area >= SLAB_AREA * float(np.prod(others))) & (actual > low[axis]) \
                & (actual < high[axis])
            edges[axis] = np.unique(np.concatenate([e, actual[big]]))
            continue
        reach = PAIR_REACH * float(high[axis] - low[axis])
        added = []
        for b in e:  # the world's sides too: an outer wall's inside
            at = np.flatnonzero(np.abs(keys - b) <= 1e-6)
            base = area[at].max() if len(at) else 0.0
            if base == 0.0:  # no wall on this boundary (the world's side): a large one near
                base = SLAB_AREA / PAIR_AREA * float(np.prod(np.delete(high - low, axis)))
            for side in (-1.0, 1.0):
                near = np.flatnonzero((side * (keys - b) > 1e-6) & (side * (keys - b) <= reach))
                if len(near) and area[near].max() >= PAIR_AREA * base > 0.0:
                    added.append(actual[near[np.argmax(area[near])]])
        added = np.asarray(added, dtype=np.float64)
        added = added[(added > low[axis]) & (added < high[axis])]
        edges[axis] = np.unique(np.concatenate([e, added]))
    return edges


def view_grid(world, cells=None, thickness=None) -> dict:
    """The PVS's own cells and portals: {'edges', 'cell_bounds' (C, 2, 3), 'cell_start'
    (C + 1,) int64 and 'cell_tris' (R,) int64 (CSR cell -> triangles within thickness),
    'portal_cells', 'portal_start', 'portal_vertices' (portal.find_portals), 'cell_portal_start'
    (C + 1,) int64, 'cell_portals' (2P,) int64}."""
    target = int(np.clip(round(np.sqrt(world.triangle_count) / 2), 8, 256)) if cells is None \
        else int(cells)
    edges = paired_edges(world, target)
    size = float(np.ptp(world.extent, axis=0).max())
    thickness = portal.THICKNESS * size if thickness is None else float(thickness)
    cell, tri = grid.cell_pairs(world, edges, slack=thickness)
    boxes = grid.cell_boxes(edges)
    count = len(boxes)
    start = np.concatenate([[0], np.cumsum(np.bincount(cell, minlength=count))]).astype(np.int64)
    pcells, pstart, pverts = portal.find_portals(world, edges, thickness)
    ends = np.concatenate([pcells[:, 0], pcells[:, 1]]).astype(np.int64)
    ids = np.tile(np.arange(len(pcells)), 2)
    order = np.lexsort((ids, ends))
    cps = np.concatenate([[0], np.cumsum(np.bincount(ends, minlength=count))]).astype(np.int64)
    return {"edges": edges, "cell_bounds": boxes, "cell_start": start,
            "cell_tris": tri.astype(np.int64), "portal_cells": pcells.astype(np.int64),
            "portal_start": pstart, "portal_vertices": pverts,
            "cell_portal_start": cps, "cell_portals": ids[order].astype(np.int64)}

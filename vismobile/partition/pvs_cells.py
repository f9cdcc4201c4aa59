"""The view cells of the conservative PVS: a portal grid of its own (portal.py's cells and
portals), whatever the partition's structure, whose boundaries take both faces of each thick
wall or slab.

portal.auto_edges snaps each cell boundary to one large axis-aligned wall plane. A hollow wall
or slab then lies inside a cell, and its inside (unless it is a closed solid, solids.py) is a
thin open strip on every cell face that crosses it: the portals join every cell to every other
along the walls. Adding the wall's other face as a boundary puts the inside in thin cells of its
own, closed on both sides by the walls lying in their faces; they connect to the rooms only
where the wall is open (doorways' uncapped jambs), as sight lines really can.

A building (thin walls on at least two axes, portal_edges.thin_walls: W1-W4) takes its cells
from its walls alone (building_edges): both faces of every hollow wall and slab, the outer
walls' too, so each room of each storey is a cell whatever objects stand in it (the quantile
boundaries snapped to planes followed W2's and W3's objects and missed the slab between the
storeys: a ground-floor cell saw the upper floor), each span wider than SPAN_SHARE of the
world cut in equal parts (a smaller source sees less through the same doorways).
"""
from __future__ import annotations

import numpy as np

from . import grid, portal
from .portal_edges import WALL_SHARE, plane_areas, thin_walls
from .pvs_cracks import crack_reach, with_cracks
from .pvs_planes import with_plane_cracks
from .pvs_refine import refine

# A second face is looked for this far (a fraction of the world's extent along the axis).
PAIR_REACH = 0.02
# ... and kept when its wall area is at least this share of the snapped plane's.
PAIR_AREA = 0.25
# An axis with no interior boundary takes every wall plane covering this share of the world's
# cross-section (a floor slab between storeys: both its faces).
SLAB_AREA = 0.25
# The added planes may multiply the cell count by at most MAX_GROWTH, to at most MAX_CELLS
# cells (the bake's time follows the cells times the portals): the largest walls go first.
MAX_GROWTH, MAX_CELLS = 16, 640
# A building's spans between wall faces wider than this share of the world's largest side are
# cut in equal parts (W1-W4: rooms of 6-10 m in halves, storeys of 3 m whole) ...
SPAN_SHARE = 0.125
# ... while its cells stay within this many (the bake's time follows the cells).
BUILDING_CELLS = 2048


def building_edges(world) -> list | None:
    """Three ascending boundary arrays of a building's cells, or None when the world is not
    one (thin walls, portal_edges.thin_walls, of at least WALL_SHARE of the largest one's area,
    on fewer than two axes): the world's extent, both faces of every such wall, the largest
    wall plane within PAIR_REACH of each side of the world (an outer wall: the strip beyond it,
    where its windows' reveals stand, is a thin cell of its own), then each span wider than
    SPAN_SHARE of the world's largest side cut in equal parts (within BUILDING_CELLS)."""
    low, high = world.extent
    edges, walled = [], 0
    for axis in range(3):
        pairs = thin_walls(world, axis)
        if len(pairs):
            pairs = pairs[pairs[:, 2] >= WALL_SHARE * pairs[:, 2].max()]
        faces = pairs[:, :2].ravel()
        faces = faces[(faces > low[axis]) & (faces < high[axis])]
        walled += bool(len(faces))
        if len(faces):
            pos, area = plane_areas(world, axis)
            reach = PAIR_REACH * float(high[axis] - low[axis])
            for side in (low[axis], high[axis]):
                near = np.flatnonzero((np.abs(pos - side) <= reach) & (pos > low[axis])
                                      & (pos < high[axis]))
                if len(near) and area[near].max() >= WALL_SHARE * pairs[:, 2].max():
                    faces = np.append(faces, pos[near[np.argmax(area[near])]])
        edges.append(np.unique(np.concatenate([[low[axis], high[axis]], faces])))
    if walled < 2 or np.prod([len(e) - 1 for e in edges]) > BUILDING_CELLS:
        return None
    span = SPAN_SHARE * float(np.ptp(world.extent, axis=0).max())
    cut = []
    for e in edges:
        parts = np.maximum(1, np.ceil(np.diff(e) / span - 1e-9)).astype(int)
        cut.append(np.unique(np.concatenate(
            [e] + [np.linspace(e[i], e[i + 1], parts[i] + 1) for i in range(len(e) - 1)])))
    if np.prod([len(e) - 1 for e in cut]) > BUILDING_CELLS:
        return edges
    return cut


def paired_edges(world, cells) -> list:
    """Three ascending boundary arrays: a building's walls (building_edges) when it is one;
    else portal.auto_edges plus, next to each interior boundary,
    the largest parallel wall plane within PAIR_REACH on either side, and on an axis without
    interior boundaries every plane of walls covering SLAB_AREA of the cross-section; the
    largest walls first, within MAX_GROWTH times the automatic cell count and MAX_CELLS."""
    building = building_edges(world)
    if building is not None:
        return building
    edges = portal.auto_edges(world, cells)
    base = [len(e) - 1 for e in edges]
    low, high = world.extent
    offers = []  # (area, axis, position) of every plane the rules below would add
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
            big = np.flatnonzero((area >= SLAB_AREA * float(np.prod(others)))
                                 & (actual > low[axis]) & (actual < high[axis]))
            offers += [(area[k], axis, actual[k]) for k in big]
            continue
        reach = PAIR_REACH * float(high[axis] - low[axis])
        for b in e:  # the world's sides too: an outer wall's inside
            at = np.flatnonzero(np.abs(keys - b) <= 1e-6)
            here = area[at].max() if len(at) else 0.0
            if here == 0.0:  # no wall on this boundary (the world's side): a large one near
                here = SLAB_AREA / PAIR_AREA * float(np.prod(np.delete(high - low, axis)))
            for side in (-1.0, 1.0):
                near = np.flatnonzero((side * (keys - b) > 1e-6) & (side * (keys - b) <= reach))
                if len(near) and area[near].max() >= PAIR_AREA * here > 0.0:
                    k = near[np.argmax(area[near])]
                    if low[axis] < actual[k] < high[axis]:
                        offers.append((area[k], axis, actual[k]))
    # largest walls first, while the cell count stays within MAX_GROWTH of the automatic one
    limit = max(min(MAX_GROWTH * int(np.prod(base)), MAX_CELLS), int(np.prod(base)))
    for _, axis, position in sorted(offers, key=lambda o: -o[0]):
        grown = np.unique(np.append(edges[axis], position))
        counts = [len(e) - 1 for e in edges]
        counts[axis] = len(grown) - 1
        if int(np.prod(counts)) <= limit:
            edges[axis] = grown
    return edges


def view_grid(world, cells=None, thickness=None, split=False, grow=0.0, cracks=True,
              planes=False) -> dict:
    """The PVS's own cells and portals: {'edges', 'cell_bounds' (C, 2, 3), 'cell_start'
    (C + 1,) int64 and 'cell_tris' (R,) int64 (CSR cell -> triangles within thickness),
    'portal_cells', 'portal_start', 'portal_vertices' (portal.find_portals), 'cell_portal_start'
    (C + 1,) int64, 'cell_portals' (2P,) int64, 'cracks': how many portals at the end are the
    rasteriser's cracks (pvs_cracks.with_cracks, reach from `grow`, the bake's growth)}; with
    split, thin cells are split at the walls inside them (pvs_refine.refine: the cells no
    longer form a grid, 'parent' names each one's grid cell); without cracks (a diagnostic,
    tools/pvs_slack.py: not conservative) no crack portals; with planes, the portals of edges a
    line lying in a face's plane passes appended after them (pvs_planes.with_plane_cracks:
    'planes', 'plane_of', 'plane_table')."""
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
    g = {"edges": edges, "cell_bounds": boxes, "cell_start": start,
         "cell_tris": tri.astype(np.int64), "portal_cells": pcells.astype(np.int64),
         "portal_start": pstart, "portal_vertices": pverts,
         "cell_portal_start": cps, "cell_portals": ids[order].astype(np.int64)}
    if split:
        g = refine(world, g, thickness)
    if cracks:
        g = with_cracks(world, g, thickness, crack_reach(world, grow))
    return with_plane_cracks(world, g, thickness, grow) if planes else g

"""Where the portal octree's cells meet: the boundaries of its irregular grid (portal.py).

auto_edges (the default): about `cells` quantile boundaries (grid.auto_edges), each snapped to
the largest axis-aligned wall plane near it, so cell faces lie on walls and their portals are
doorways rather than whole faces.

wall_edges (`portal:walls=true`, issue 25): a boundary on every large wall plane, both faces of
each hollow wall and slab. The inside of a hollow wall (or of a slab between storeys) then lies
in thin cells of its own, closed on both sides by the walls lying in their faces, instead of
being an open strip on every face that crosses it (that strip joins each room to the storey
above: partition/pvs_cells.py makes the same point for the PVS's view cells). Each room is a
cell per storey, and outdoors (a street before a building) the cells' portals into the
building are its doors, windows and arches.
"""
from __future__ import annotations

import numpy as np

from . import grid

# wall_edges keeps the thin walls whose area is at least this share of the largest one's on the
# same axis: a building's walls, floors and ceilings, not small ledges.
WALL_SHARE = 0.1
# A wall is thin when its faces are at most this times the square root of its area apart (W1's
# 0.2 m walls: 0.015 to 0.05; a city tower's opposite sides: 0.4 and more).
THIN = 0.1
# Planes closer than this (world units, rounding) are one plane.
PLANE_DIGITS = 6


def plane_areas(world, axis: int, facing: bool = False) -> tuple:
    """(positions (K,), areas (K,)) float64: each distinct plane x[axis] = position holding
    axis-aligned triangles (|normal| within 0.999 of the axis), their total area; positions are
    a triangle's own coordinate, grouped at PLANE_DIGITS decimals. facing=True adds (K,)
    float64 the sign of the area-weighted normal (+1: the plane's walls face +axis) and the
    bounds (K, 2) low and (K, 2) high of its triangles in the other two axes."""
    aligned = np.abs(world.normals[:, axis]) > 0.999
    if not aligned.any():
        return (np.zeros(0), np.zeros(0)) + ((np.zeros(0), np.zeros((0, 2)), np.zeros((0, 2)))
                                             if facing else ())
    pos = world.centroids[aligned, axis]
    keys, inverse = np.unique(np.round(pos, PLANE_DIGITS), return_inverse=True)
    inverse = inverse.ravel()
    area = np.bincount(inverse, weights=world.areas[aligned], minlength=len(keys))
    actual = np.empty(len(keys))
    actual[inverse] = pos  # a wall's own coordinate, not its rounded key
    if facing:
        side = np.bincount(inverse, weights=world.areas[aligned] * world.normals[aligned, axis],
                           minlength=len(keys))
        others = [a for a in range(3) if a != axis]
        low = np.full((len(keys), 2), np.inf)
        high = np.full((len(keys), 2), -np.inf)
        np.minimum.at(low, inverse, world.bounds[aligned][:, 0][:, others])
        np.maximum.at(high, inverse, world.bounds[aligned][:, 1][:, others])
        return actual, area, np.sign(side), low, high
    return actual, area


def auto_edges(world, cells):
    """Quantile boundaries (grid.auto_edges) snapped to the nearest large axis-aligned wall plane.

    Snapping puts cell faces on walls, where portals are doorways rather than whole faces.
    """
    edges = grid.auto_edges(world, grid.auto_counts(world, cells))
    low, high = world.extent
    for axis in range(3):
        e = edges[axis]
        if len(e) <= 2:
            continue
        actual, area = plane_areas(world, axis)
        if not len(actual):
            continue
        keys = np.round(actual, PLANE_DIGITS)
        snapped = e.copy()
        for b in range(1, len(e) - 1):
            reach = 0.5 * min(e[b] - e[b - 1], e[b + 1] - e[b])
            near = np.flatnonzero(np.abs(keys - e[b]) < reach)
            near = near[(keys[near] > low[axis]) & (keys[near] < high[axis])]
            if len(near):
                snapped[b] = actual[near[np.argmax(area[near])]]
        snapped = np.unique(snapped)
        edges[axis] = snapped
    return edges


def wall_edges(world, limit: int | None = None) -> list:
    """Three ascending boundary arrays: the world's extent plus both faces of every thin wall
    (thin_walls) whose wall area is at least WALL_SHARE of the largest thin wall's on that
    axis; when the cells would exceed `limit`, the smallest walls of all axes are left out
    first (a wall's two faces together). An axis without thin walls keeps one slab."""
    low, high = world.extent
    offers, edges = [], []
    for axis in range(3):
        pairs = thin_walls(world, axis)
        span = float(high[axis] - low[axis])
        inside = (pairs[:, 0] > low[axis] + 1e-9 * span) & (pairs[:, 1] < high[axis] - 1e-9 * span)
        pairs = pairs[inside]
        if len(pairs):
            pairs = pairs[pairs[:, 2] >= WALL_SHARE * pairs[:, 2].max()]
        offers += [(area, axis, (lo, hi)) for lo, hi, area in pairs]
        edges.append([float(low[axis]), float(high[axis])])
    counts = [1, 1, 1]
    for _, axis, faces in sorted(offers, key=lambda o: -o[0]):
        new = [f for f in faces if f not in edges[axis]]
        grown = counts.copy()
        grown[axis] += len(new)
        if limit is None or int(np.prod(grown)) <= limit:
            counts = grown
            edges[axis] += new
    return [np.unique(np.asarray(e, dtype=np.float64)) for e in edges]


def thin_walls(world, axis: int) -> np.ndarray:
    """(W, 3) float64 rows (low face, high face, area): pairs of parallel wall planes whose
    walls face away from each other (the low plane's toward -axis, the high one's toward +axis:
    the two faces of a hollow wall or slab, each facing its own room), whose walls' bounds
    overlap along the plane, no more than THIN times the square root of the smaller one's wall
    area apart (the nearest such plane); area is the smaller of the two. A closed box's
    opposite sides (a tower's) are far apart for their size; the two sides of a doorway's or
    window's reveal face each other."""
    pos, area, facing, lo, hi = plane_areas(world, axis, facing=True)
    rows = []
    for k in np.flatnonzero(facing < 0):
        gap = pos - pos[k]
        near = (facing > 0) & (gap > 0) & (gap <= THIN * np.sqrt(np.minimum(area, area[k])))
        near &= ((lo < hi[k]) & (hi > lo[k])).all(axis=1)  # the walls overlap along the plane
        if near.any():
            j = np.flatnonzero(near)[np.argmin(gap[near])]
            rows.append((pos[k], pos[j], min(area[k], area[j])))
    return np.array(rows, dtype=np.float64).reshape(-1, 3)

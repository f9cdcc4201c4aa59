"""Occluder columns for the outdoor PVS (pvs_street.py): the parts of a world proven to be solid
2.5D blocks standing on its floor, a building's walls and roof.

A connected part (triangles joined by edges whose two corners are the same exact coordinates)
is a column when:
  * every corner is at the part's base y or its top y (top > base), the base being the
    world's lowest y (nothing lies below it);
  * its corners' x-z points are the vertices of, or lie on, their convex hull (the footprint,
    at least 3 corners, turning counter-clockwise from above);
  * each triangle is a wall (its three x-z points on one hull edge) facing away from the
    footprint, or a roof triangle (all corners at the top) facing up;
  * the walls on each hull edge cover edge length x height, the roof covers the hull's area;
  * every edge is used by exactly two of the part's triangles running along it in opposite
    directions, except the bottom loop's edges (both ends at the base), used once.
Consistent winding over a manifold surface whose pieces lie in the prism's faces and whose areas
match covers each face exactly, and shared edges leave no crack in the rasteriser (the fill
rule), so a line from outside the prism (above its base) that passes inside it first meets a
wall or the roof, on its front face: the column hides what lies behind it with and without
back-face culling. Anything else (open, T-junctions, overhangs, curved or sloping surfaces,
a part not standing on the floor) is never an occluder, only an occludee.
"""
from __future__ import annotations

import numpy as np

from ..world.footprint import convex_hull, polygon_area

# coordinates equal within this (relative to the world's size) count as on a plane or edge
RELATIVE = 1e-9
AREA_RELATIVE = 1e-7  # covered areas must match within this share


def _parts(triangles, count) -> np.ndarray:
    """(T,) int64 component label of triangles joined through shared (exact) vertices."""
    label = np.arange(count, dtype=np.int64)
    vertex = np.full(int(triangles.max()) + 1 if len(triangles) else 0, count, dtype=np.int64)
    while True:
        vertex[:] = count
        np.minimum.at(vertex, triangles.ravel(), np.repeat(label, 3))
        new = vertex[triangles].min(axis=1)
        new = np.minimum(new, label)
        new = new[new]  # pointer jumping
        if np.array_equal(new, label):
            return label
        label = new


def _column(world, ids, directed, floor, tol):
    """(footprint (H, 2) counter-clockwise x-z, base, top) of the part's triangles ids, or None."""
    corners = world.corners[ids]
    ys = corners[..., 1]
    base, top = float(ys.min()), float(ys.max())
    if base > floor + tol or top - base <= 10 * tol:
        return None
    at_top = np.abs(ys - top) <= tol
    if not (at_top | (np.abs(ys - base) <= tol)).all():
        return None
    hull = convex_hull(corners[..., [0, 2]].reshape(-1, 2))
    if len(hull) < 3:
        return None
    a, b = hull, np.roll(hull, -1, axis=0)
    edge = b - a
    length = np.hypot(edge[:, 0], edge[:, 1])
    if (length <= 10 * tol).any():
        return None
    outward = np.column_stack([edge[:, 1], -edge[:, 0]]) / length[:, None]  # right of a->b
    xz = corners[..., [0, 2]]
    # signed distance of every corner from every hull edge's line (<= 0 inside)
    dist = np.einsum("tkj,hj->tkh", xz, outward) - np.einsum("hj,hj->h", a, outward)
    if (dist > tol).any():
        return None
    normals = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    area = 0.5 * np.linalg.norm(normals, axis=1)
    roof = at_top.all(axis=1)
    if (roof & (normals[:, 1] <= 0)).any():
        return None
    on_edge = (np.abs(dist) <= tol).all(axis=1)  # (t, h): all three x-z points on edge h's line
    walls = ~roof
    which = np.argmax(on_edge, axis=1)
    if not on_edge[walls].any(axis=1).all():
        return None
    wall_n = normals[walls][:, [0, 2]]
    if (np.abs(normals[walls][:, 1]) > tol * np.linalg.norm(normals[walls], axis=1)).any() or \
            (np.einsum("ij,ij->i", wall_n, outward[which[walls]]) <= 0).any():
        return None
    height = top - base
    cover = np.bincount(which[walls], weights=area[walls], minlength=len(hull))
    if (np.abs(cover - length * height) > AREA_RELATIVE * length * height).any():
        return None
    hull_area = polygon_area(hull)
    if abs(area[roof].sum() - hull_area) > AREA_RELATIVE * hull_area:
        return None
    # edges: twice in opposite directions, or once along the bottom loop
    d = directed.reshape(-1, 2)
    ends = np.sort(d, axis=1)
    keys, inverse, uses = np.unique(ends, axis=0, return_inverse=True, return_counts=True)
    inverse = inverse.reshape(-1)
    if (uses > 2).any():
        return None
    once = uses[inverse] == 1
    start_y = ys.reshape(-1)  # directed edge k of triangle t runs from corner k to k + 1
    end_y = ys[:, [1, 2, 0]].reshape(-1)
    if (once & ~((np.abs(start_y - base) <= tol) & (np.abs(end_y - base) <= tol))).any():
        return None
    twice = np.flatnonzero(uses[inverse] == 2)
    order = twice[np.argsort(inverse[twice], kind="stable")]
    first, second = order[0::2], order[1::2]
    if (d[first, 0] == d[second, 0]).any():  # same direction: wound inconsistently
        return None
    return hull, base, top


def find_columns(world) -> tuple:
    """The world's occluder columns (module docstring).

    returns (footprints: list of (H, 2) float64 counter-clockwise x-z polygons, base (N,),
             top (N,) float64, part (T,) int64 the column of each triangle or -1)
    """
    count = world.triangle_count
    part_of = np.full(count, -1, dtype=np.int64)
    if not count:
        return [], np.zeros(0), np.zeros(0), part_of
    _, exact = np.unique(world.vertices, axis=0, return_inverse=True)
    t = exact.reshape(-1)[world.triangles].astype(np.int64)
    label = _parts(t, count)
    low, high = world.extent
    tol = RELATIVE * max(float((high - low).max()), 1.0)
    floor = float(low[1])
    directed = np.stack([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]], axis=1)
    order = np.argsort(label, kind="stable")
    cuts = np.flatnonzero(np.diff(label[order])) + 1
    footprints, bases, tops = [], [], []
    for ids in np.split(order, cuts):
        if len(ids) < 4:
            continue
        found = _column(world, ids, directed[ids], floor, tol)
        if found is None:
            continue
        part_of[ids] = len(footprints)
        footprints.append(found[0])
        bases.append(found[1])
        tops.append(found[2])
    return footprints, np.array(bases, dtype=np.float64), np.array(tops, dtype=np.float64), part_of

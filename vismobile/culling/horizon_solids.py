"""Occluders that stand on the ground, found from an object world's geometry, as a map of solid
columns for the horizon (terrain/horizon_cells.py).

Two kinds of object (triangles sharing an object id) qualify, each checked from its triangles:
- a ground: every triangle faces up (n_y > 0) and their projections tile the object's x-z box
  (projected areas sum to the box's area): a height field whose drawn top face blocks any ray
  that passes below it from an eye above it, so its column is solid all the way down;
- a vertical extrusion (a building, a wall): every triangle is a wall (n_y = 0) or a roof
  (facing up at the object's top), the roofs' projected areas sum to the convex hull of its
  footprint and each hull edge's wall triangles sum to the edge's length times the height: the
  hull prism is closed except perhaps its bottom, so its column is solid from base to top.
Other objects (models, furniture) do not occlude here. A prism whose base is not below its
ground merges with the ground into one column down without end; a free-standing one keeps its
base, and the stage casts only when the eye is above every such base (its open bottom could let
a ray in from below).

Per cell (row i along z, column j along x): `tops` a lower bound of a solid's top over the whole
cell, `highs` an upper bound of any solid's top touching the cell, `bases` an upper bound of the
bottom of the solid of `tops` (+inf where none). Footprints shrink and tops sink by `margin` (the
device's vertex rounding), highs and bases rise by it.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..world.footprint import convex_hull, polygon_area

MAX_CELLS = 1024  # map side (cells); the spacing is the power of two that covers the solids
AREA_TOLERANCE = 1e-6  # relative: projected areas must tile to this
FLAT = 1e-9  # |n_y| below this is a wall, n_y above 1 - this a roof


@dataclass
class SolidMap:
    """Columns of solid on a square grid (see the module doc); bases None: every solid goes
    down without end. max_base: highest finite base (-inf when none): an eye must be above it."""

    tops: np.ndarray
    highs: np.ndarray
    bases: np.ndarray | None
    origin: tuple
    spacing: float
    max_base: float
    grounds: int
    prisms: int


def _projected_areas(corners) -> np.ndarray:
    """(T,) signed x-z areas of triangles (T, 3, 3) (the sign follows their x-z winding)."""
    a, b, c = corners[:, 0], corners[:, 1], corners[:, 2]
    return 0.5 * ((b[:, 0] - a[:, 0]) * (c[:, 2] - a[:, 2])
                  - (b[:, 2] - a[:, 2]) * (c[:, 0] - a[:, 0]))


def is_ground(corners, normals) -> tuple | None:
    """(x0, z0, x1, z1, corners) when the triangles (T, 3, 3) tile their x-z box facing up."""
    if not len(corners) or not np.all(normals[:, 1] > FLAT):
        return None
    low, high = corners.reshape(-1, 3).min(axis=0), corners.reshape(-1, 3).max(axis=0)
    box = (high[0] - low[0]) * (high[2] - low[2])
    area = np.abs(_projected_areas(corners)).sum()
    if not box > 0 or abs(area - box) > AREA_TOLERANCE * box:
        return None
    return low[0], low[2], high[0], high[2]


def is_prism(corners, normals) -> tuple | None:
    """(footprint hull (K, 2), base, top) when the triangles close a vertical extrusion."""
    ys = corners[..., 1]
    base, top = float(ys.min()), float(ys.max())
    if not top > base:
        return None
    wall = np.abs(normals[:, 1]) < FLAT
    roof = (normals[:, 1] > 1 - FLAT) & np.all(ys == top, axis=1)
    if not np.all(wall | roof) or not roof.any():
        return None
    hull = convex_hull(corners[..., [0, 2]].reshape(-1, 2))
    if len(hull) < 3:
        return None
    area = abs(polygon_area(hull))
    if abs(np.abs(_projected_areas(corners[roof])).sum() - area) > AREA_TOLERANCE * area:
        return None
    height = top - base
    wall_c = corners[wall]
    wall_area = 0.5 * np.linalg.norm(np.cross(wall_c[:, 1] - wall_c[:, 0],
                                              wall_c[:, 2] - wall_c[:, 0]), axis=1)
    size = float(np.ptp(hull, axis=0).max())
    for a, b in zip(hull, np.roll(hull, -1, axis=0)):
        d = b - a
        length = float(np.hypot(*d))
        rel = wall_c[..., [0, 2]] - a
        off = np.abs(rel[..., 0] * d[1] - rel[..., 1] * d[0]) / length  # distance to the line
        along = (rel[..., 0] * d[0] + rel[..., 1] * d[1]) / length
        on = np.all((off <= 1e-9 * size) & (along >= -1e-9 * size)
                    & (along <= length + 1e-9 * size), axis=1)
        if abs(wall_area[on].sum() - length * height) > AREA_TOLERANCE * length * height:
            return None
    return hull, base, top


def _inside(hull, x, z, margin) -> np.ndarray:
    """(...,) bool: points (x, z) at least `margin` inside the convex counter-clockwise hull."""
    ok = np.ones(np.shape(x), dtype=bool)
    for a, b in zip(hull, np.roll(hull, -1, axis=0)):
        d = b - a
        length = np.hypot(*d)
        ok &= (d[0] * (z - a[1]) - d[1] * (x - a[0])) / length >= margin
    return ok


@dataclass
class Solids:
    """What find_solids found: grounds [(triangle ids, (x0, z0, x1, z1))], their rectangles
    (G, 4) float64, and prisms [(hull (K, 2), base, top)]."""

    grounds: list
    rects: np.ndarray
    prisms: list

    def __post_init__(self):
        self.rect_list = [tuple(map(float, r)) for r in self.rects]

    def grounds_under(self, eye, margin: float = 0.0) -> tuple:
        """Indices of the grounds whose rectangle holds the eye (x, z) at least margin inside:
        only from above its own ground can a ray not pass under a ground's open edge."""
        x, z = float(eye[0]), float(eye[2])  # a few grounds: plain floats beat numpy here
        return tuple(k for k, (x0, z0, x1, z1) in enumerate(self.rect_list)
                     if x0 + margin < x < x1 - margin and z0 + margin < z < z1 - margin)


def find_solids(world) -> Solids:
    """The grounds and prisms among the world's objects (see the module doc)."""
    corners = world.corners
    normals = world.normals
    ids = np.asarray(world.object_ids)
    order = np.argsort(ids, kind="stable")
    starts = np.flatnonzero(np.r_[True, ids[order][1:] != ids[order][:-1]]) if len(ids) else []
    groups = np.split(order, starts[1:]) if len(ids) else []
    grounds, prisms = [], []
    for tris in groups:
        c, n = corners[tris], normals[tris]
        rect = is_ground(c, n)
        if rect is not None:
            grounds.append((tris, rect))
            continue
        prism = is_prism(c, n)
        if prism is not None:
            prisms.append(prism)
    rects = np.array([r for _, r in grounds], dtype=np.float64).reshape(-1, 4)
    return Solids(grounds, rects, prisms)


def solid_map(world, solids: Solids, valid=None, margin: float = 0.0,
              max_cells: int = MAX_CELLS) -> SolidMap | None:
    """The solids as a SolidMap, or None when there are none. valid: indices of the grounds
    that count (the eye is over them; None: all); the map's frame covers every solid either
    way, so maps of one world share spacing and origin."""
    corners = world.corners
    all_grounds, prisms = solids.grounds, solids.prisms
    if not all_grounds and not prisms:
        return None
    grounds = [g for k, g in enumerate(all_grounds) if valid is None or k in valid]
    lows = [np.array([r[0], r[1]]) for _, r in all_grounds] + [h.min(axis=0)
                                                                for h, _, _ in prisms]
    highs_ = [np.array([r[2], r[3]]) for _, r in all_grounds] + [h.max(axis=0)
                                                                 for h, _, _ in prisms]
    low, high = np.min(lows, axis=0), np.max(highs_, axis=0)
    extent = float(max(np.max(high - low), 1e-9))
    spacing = float(2.0 ** np.ceil(np.log2(extent / max_cells)))
    n = int(2 ** np.ceil(np.log2(max(extent / spacing, 1.0))))
    origin = np.floor(low / spacing) * spacing
    while origin[0] + n * spacing < high[0] or origin[1] + n * spacing < high[1]:
        n *= 2
    edges_x = origin[0] + spacing * np.arange(n + 1)
    edges_z = origin[1] + spacing * np.arange(n + 1)
    ground = np.full((n, n), -np.inf)  # lower bound of the ground over the cell
    ground_high = np.full((n, n), -np.inf)
    for tris, (x0, z0, x1, z1) in grounds:
        covered = np.zeros((n, n), dtype=bool)
        rows = (edges_z[:-1] >= z0 + margin) & (edges_z[1:] <= z1 - margin)
        cols = (edges_x[:-1] >= x0 + margin) & (edges_x[1:] <= x1 - margin)
        covered[np.ix_(rows, cols)] = True
        lo_c = corners[tris].min(axis=1)
        hi_c = corners[tris].max(axis=1)
        low_cell = np.full((n, n), np.inf)
        high_cell = np.full((n, n), -np.inf)
        def cell(v, o):
            return np.clip(np.floor((v - o) / spacing).astype(np.int64), 0, n - 1)

        j0, j1 = cell(lo_c[:, 0] - margin, origin[0]), cell(hi_c[:, 0] + margin, origin[0])
        i0, i1 = cell(lo_c[:, 2] - margin, origin[1]), cell(hi_c[:, 2] + margin, origin[1])
        span_i, span_j = i1 - i0 + 1, j1 - j0 + 1
        count = span_i * span_j
        t = np.repeat(np.arange(len(tris)), count)
        k = np.arange(int(count.sum())) - np.repeat(np.cumsum(count) - count, count)
        ci = i0[t] + k // span_j[t]
        cj = j0[t] + k % span_j[t]
        np.minimum.at(low_cell, (ci, cj), lo_c[t, 1] - margin)
        np.maximum.at(high_cell, (ci, cj), hi_c[t, 1] + margin)
        ground = np.where(covered, np.maximum(ground, low_cell), ground)
        ground_high = np.maximum(ground_high, high_cell)
    cx, cz = np.meshgrid(edges_x, edges_z)  # (n + 1, n + 1) cell corners
    prism_top = np.full((n, n), -np.inf)
    prism_base = np.full((n, n), np.inf)
    highs = ground_high.copy()
    tops = ground.copy()
    max_base = -np.inf
    for hull, base, top in prisms:
        lo, hi = hull.min(axis=0), hull.max(axis=0)
        j0, j1 = (np.clip(np.floor((v - origin[0]) / spacing).astype(np.int64), 0, n - 1)
                  for v in (lo[0] - margin, hi[0] + margin))
        i0, i1 = (np.clip(np.floor((v - origin[1]) / spacing).astype(np.int64), 0, n - 1)
                  for v in (lo[1] - margin, hi[1] + margin))
        highs[i0:i1 + 1, j0:j1 + 1] = np.maximum(highs[i0:i1 + 1, j0:j1 + 1], top + margin)
        inside = _inside(hull, cx[i0:i1 + 2, j0:j1 + 2], cz[i0:i1 + 2, j0:j1 + 2], margin)
        full = inside[:-1, :-1] & inside[1:, :-1] & inside[:-1, 1:] & inside[1:, 1:]
        if not full.any():
            continue
        region = (slice(i0, i1 + 1), slice(j0, j1 + 1))
        g = ground[region]
        on_ground = full & (base <= g)  # stands on its ground: one column down without end
        tops[region] = np.where(on_ground, np.maximum(tops[region], top - margin), tops[region])
        free = full & ~on_ground & (top - margin > prism_top[region])
        if free.any():
            prism_top[region] = np.where(free, top - margin, prism_top[region])
            prism_base[region] = np.where(free, base + margin, prism_base[region])
            max_base = max(max_base, base + margin)
    # A free-standing prism's column replaces a lower top where no ground column is higher.
    use_prism = prism_top > tops
    bases = None
    if use_prism.any():
        bases = np.where(use_prism, prism_base, np.where(np.isfinite(tops), -np.inf, np.inf))
        tops = np.where(use_prism, prism_top, tops)
    else:
        max_base = -np.inf
    return SolidMap(tops, highs, bases, (float(origin[0]), float(origin[1])), spacing,
                    float(max_base), len(grounds), len(prisms))

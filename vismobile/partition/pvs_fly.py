"""Fly-over view cells for the outdoor PVS (opt-in, `fly=on`): layers of cells above the street
cells (pvs_street.py), each coarser than the one below, up to a ceiling above the tallest
column, baked with the same fused occluder shadows (pvs_shadow.py) from the boundary of each
region's top face.

Layers: from the street layer's top, squares of FLY_CELL (each layer up doubles it), half as
high as wide, up to FLY_CEILING times the tallest column's height above the floor (the last
layer reaches it). A layer's squares split in four near a column that pokes into it (down to
1 / SPLIT of its side, at least the street cells' least square); a least square wholly inside
a column taller than the layer is no cell. A camera above the ceiling, or whose near plane
leaves the cells, falls back (culling/pvs.py, as for the street cells).

A fly-over region's occluders (`usable`): every column x-z clear of it by r (the samples'
reach), and every column lower than its bottom (the region lies above it). A column taller
than the samples hides through its front walls, one no taller through its exit walls
(pvs_shadow.sample_steps). Triangles whose x-z box meets the top face (grown by r) are kept.

Why that is conservative (the street argument's other half; pvs_street.py has the depth slack,
growth and rounding, unchanged). A pixel shows q along a line from a near-plane point p in the
region. Let p' be p raised to the region's top (height H); a line from p' that passes through a
column at parameter t puts the line from p at the same x-z point lower but above the floor, so
inside the column too (p is not inside a usable column: such a column is either clear of the
region or below it). If q is no higher than H and its x-z point is outside the top face, let
p''' be where the x-z line from p' toward q leaves the face, forwards. A column hiding q from
p''' (crossing at c, beyond p''' as the face is convex) hides it from p': at c the line from
p' (farther from q, same height) is lower, still above the floor. A sample s within r of p'''
(samples SPACING apart along the boundary) that sees the line s -> q through a footprint shrunk
by r (plus the tolerance) puts the line p''' -> q, moved by at most r at every parameter, inside
the unshrunk one at the same heights. If q is higher than H, only a column taller than H can
hide it (lines from p' rise), clear of the region, and pvs_street.py's argument holds as it
stands (p'' behind p' on the boundary). A q whose x-z point is inside the top face is kept.
"""
from __future__ import annotations

import numpy as np

from .pvs_squares import near, square_cells

FLY_CELL = 16.0  # the lowest fly-over layer's squares (x-z, world units); each layer up doubles
FLY_CEILING = 1.5  # the layers reach this times the tallest column's height above the floor
SPLIT = 4  # a layer's squares split near a column poking into it down to 1 / SPLIT of its side


def fly_layers(world, tops, street_top, street_side, least) -> list:
    """[(y0, y1, cell, least)]: the fly-over layers from street_top to the ceiling (module
    docstring), each's square side (at least twice the street cells' street_side) and the
    least a split makes (at least least); [] when no column stands."""
    low = world.extent[0]
    if not len(tops):
        return []
    ceiling = low[1] + FLY_CEILING * (float(np.max(tops)) - low[1])
    cell = max(FLY_CELL, 2.0 * street_side)
    layers, y = [], street_top
    while y < ceiling:
        top = min(y + cell / 2.0, ceiling)
        if ceiling - top < cell / 4.0:  # no thin layer under the ceiling
            top = ceiling
        layers.append((y, top, cell, max(least, cell / SPLIT)))
        y, cell = top, 2.0 * cell
    return layers


def fly_cells(world, footprints, tops, street_top, street_side, least, pad,
              margin) -> np.ndarray:
    """(V, 2, 3) float64 fly-over cell boxes, layer by layer (each in Morton order).

    tops   : (N,) the columns' tops; street_top, street_side, least: the street cells' top,
             square side and least split (fly_layers); pad: how near a footprint splits a
             square (the bake's growth plus the samples' reach); margin: how far a region
             reaches below its cell (COVER plus the growth)
    """
    out = []
    tops = np.asarray(tops, dtype=np.float64)
    for y0, y1, cell, smallest in fly_layers(world, tops, street_top, street_side, least):
        poking = [f for f, t in zip(footprints, tops) if t > y0 - margin]
        over = [f for f, t in zip(footprints, tops) if t >= y1 + margin]
        out.append(square_cells(world, poking, over, pad, y0, y1, cell, smallest))
    return np.concatenate(out) if out else np.zeros((0, 2, 3))


def usable(a, b, table, valid, tops, r, tol) -> np.ndarray:
    """(N,) bool the columns a fly-over region a..b (its corners, grown) may use as occluders:
    surviving the shrinking, and x-z clear of it by r or lower than its bottom.

    tops : the columns' tops lowered by tol (as the bake passes them)"""
    clear = ~near(a[[0, 2]], b[[0, 2]], table, r)[0]
    return valid & (clear | (tops + tol < a[1]))


def face_triangles(world, a, b, r) -> np.ndarray:
    """(T,) bool the triangles whose x-z box meets the region's top face grown by r (kept:
    no boundary point stands in front of them)."""
    lo, hi = world.bounds[:, 0], world.bounds[:, 1]
    return ((lo[:, 0] <= b[0] + r) & (hi[:, 0] >= a[0] - r)
            & (lo[:, 2] <= b[2] + r) & (hi[:, 2] >= a[2] - r))


"""The outdoor PVS: view cells at eye height over the open ground and fused occluder shadows from
each (Wonka, Wimmer and Schmalstieg 2000, occluder shrinking; kernels in pvs_shadow.py).

An outdoor world (little lies over the eye-height layer besides the columns' roofs: `outdoor`)
gets view cells only where a camera walks: a grid of CELL x CELL squares over its x-z extent,
EYE_LOW..EYE_HIGH above its floor, each split in four (down to MIN_CELL) while it comes near a
column's footprint (pvs_columns.py: the solid blocks, a building's walls and roof); a square
wholly inside a footprint is no cell. The cells tile the layer but for those holes. A camera
whose near plane may leave the cells (above the layer, by a building's inside or the world's
edge) or is nearer than NEAR_MIN, or reaches farther than COVER, falls back (culling/pvs.py).
With fly=on, layers of fly-over cells lie over the layer (pvs_fly.py, baked here too, after
the street cells, with pvs_fly's occluders and kept triangles).

A cell's region is its box grown by the bake's growth, and by COVER up and down (a near plane
may reach over the layer). Its set: every triangle some sample point (SPACING apart along the
boundary of the region's top) sees past the columns clear of the region by r (= SPACING / 2,
the samples' reach) and taller than it, each shrunk by r plus the tolerance. Anything not a
column (objects, open or sloping surfaces, the ground) is only ever hidden.

Why that is conservative (for cameras the stage does not fall back on, every arithmetic mode,
with or without back-face culling). A pixel shows q along a line from a near-plane point p in
some cell's region (the stage checks the near plane stays in the cells found). Let p' be p
raised to the region's top, and p'' the point where the x-z line from q through p' leaves the
top face backwards. If a sample s within r of p'' hides q from its shrunk walls (crossing at c,
below the top, beyond the pushed-back line), then: the line p'' -> q, moved by at most r, passes
through the same heights inside the unshrunk column (shrinking covered the move); p' lies on
that x-z line nearer q with nothing between (the region is clear of columns), and its line to q
passes over the same x-z point higher when q is below the eye, but under the region's top and
so under the column's (taller than the region), and lower when q is above; lowering the eye to
p only lowers it, staying above the base (p and q are above the floor). So the line from p passes at least
the growth deep inside a column: it meets a wall or the roof first, on a front face with no crack
(pvs_columns.py), in front of q by a relative depth_slack (the wedge starts (1 + S) times the
wall's distance plus S (COVER + r) out, and the eye is within COVER of p), which the device's
float32 transform and 24-bit depth buffer resolve (culling/precision.depth_order and 64x the
buffer's step at the world's diagonal, for near >= NEAR_MIN). Device rounding moves eyes and
corners by less than the growth, which the shrinking and the regions include.
"""
from __future__ import annotations

import time

import numpy as np

from .pvs_columns import find_columns
from .pvs_fly import face_triangles, fly_cells, usable
from .pvs_pool import fan_out
from .pvs_shadow import cell_hidden, erode, triangle_groups
from .pvs_squares import near, polygon_table, square_cells

CELL, MIN_CELL = 8.0, 4.0  # view cells' x-z size, and the least a split makes (world units)
EYE_LOW, EYE_HIGH = 1.0, 3.0  # the cells' y above the floor (a walker's or a car's eye)
COVER = 0.75  # the sets hold what lines from within this of the cell see (the near plane)
NEAR_MIN = 0.1  # cameras with a nearer near plane fall back (the depth slack assumes it)
SPACING = 1.0  # sample points this far apart along the boundary of the region's top
MAX_CELLS = 6000  # CELL grows until the grid's squares are at most this many
OVERHEAD = 0.5  # outdoor: what lies above the layer, columns' roofs aside, covers less than this
GROUP_TILE = 16.0  # triangles grouped by object and x-z square: a hidden group's box skips them
ZBUFFER_MARGIN = 2.0 ** -18  # as culling/occlusion.py: 64x a 24-bit buffer's step, z^2 / near


def reach() -> float:
    """How far (x-z) a point of the boundary of a region's top is from its nearest sample."""
    return SPACING / 2.0


def depth_slack(world, grow) -> float:
    """S: a surface a relative S nearer along a line is drawn in front of what is behind, for
    cameras with near >= NEAR_MIN whose device reach fits the bake's growth (the stage checks):
    float32 transform 2e / (2 near - e), e = 2 device moves <= grow / sqrt 3
    (culling/precision.depth_order), plus the depth buffer's step at the farthest distance
    (ZBUFFER_MARGIN x far / near)."""
    e = grow / np.sqrt(3.0)
    far = float(np.linalg.norm(np.ptp(world.extent, axis=0))) + COVER
    return 2.0 * e / (2.0 * NEAR_MIN - e) + ZBUFFER_MARGIN * far / NEAR_MIN


def outdoor(world, part) -> bool:
    """True when the triangles above the eye-height layer, the columns' aside, cover (x-z
    projected area) less than OVERHEAD of the world's x-z extent and some column exists."""
    if not (part >= 0).any():
        return False
    low, high = world.extent
    top = low[1] + min(EYE_HIGH, 0.5 * (high[1] - low[1]))
    above = (world.bounds[:, 0, 1] > top) & (part < 0)
    c = world.corners[above]
    flat = 0.5 * np.abs(np.cross(c[:, 1] - c[:, 0], c[:, 2] - c[:, 0])[:, 1]).sum()
    size = np.ptp(world.extent, axis=0)
    return bool(flat < OVERHEAD * size[0] * size[2])


def street_cells(world, footprints, pad) -> np.ndarray:
    """(V, 2, 3) float64 view-cell boxes (module docstring): CELL squares split near the
    footprints (within pad) down to MIN_CELL, those wholly inside a footprint left out."""
    low, high = world.extent
    y0 = low[1] + min(EYE_LOW, 0.25 * (high[1] - low[1]))
    y1 = low[1] + min(EYE_HIGH, 0.5 * (high[1] - low[1]))
    return square_cells(world, footprints, footprints, pad, y0, y1, street_cell(world),
                        MIN_CELL)


def street_cell(world) -> float:
    """The street cells' square side: CELL, doubled until the grid holds at most MAX_CELLS."""
    low, high = world.extent
    size = high[[0, 2]] - low[[0, 2]]
    cell = CELL
    while np.prod(np.ceil(size / cell)) > MAX_CELLS:
        cell *= 2.0
    return cell


def boundary_samples(a, b) -> np.ndarray:
    """(K, 3) points at most SPACING apart along the boundary of the top face of the box a..b
    (its y = b[1]), its corners first."""
    xs = np.linspace(a[0], b[0], int(np.ceil((b[0] - a[0]) / SPACING)) + 1)
    zs = np.linspace(a[2], b[2], int(np.ceil((b[2] - a[2]) / SPACING)) + 1)
    corners = [(a[0], a[2]), (b[0], a[2]), (b[0], b[2]), (a[0], b[2])]
    edges = [(x, z) for x in xs[1:-1] for z in (a[2], b[2])] + \
        [(x, z) for z in zs[1:-1] for x in (a[0], b[0])]
    xz = np.array(corners + edges, dtype=np.float64)
    return np.column_stack([xz[:, 0], np.full(len(xz), b[1]), xz[:, 1]])


def bake_street_cells(world, boxes, polys, starts, valid, tops, footprints, grow, tol, slack,
                      street_top=np.inf, prepared=None):
    """[(T,) bool visible] per cell box (B, 2, 3): what the shadows from the cell do not hide.

    polys, starts : the shrunk footprints' corners (V, 2) and offsets (N + 1,); valid (N,) bool
                    the columns that survived shrinking; tops (N,) lowered by the tolerance
    street_top    : boxes from this height up are fly-over cells (pvs_fly.py's occluders)
    prepared      : prepare(world, footprints), if made once for all the bake's boxes
    """
    r = reach()
    table, corners, (groups, order, gboxes) = prepare(world, footprints) if prepared is None \
        else prepared
    out = []
    for box in boxes:
        a, b = box[0] - grow, box[1] + grow
        a[1] -= COVER  # a near plane may reach above or below the cell
        b[1] += COVER
        fly = box[0, 1] >= street_top
        if fly:
            use = usable(a, b, table, valid, tops, r, tol)
        else:
            use = ~near(a[[0, 2]], b[[0, 2]], table, r)[0]  # clear of the region by r
            use &= valid & (tops > b[1] + tol)  # taller than the region (boundary_samples)
        hidden = np.full(world.triangle_count, use.any(), dtype=np.bool_)
        if fly and use.any():
            hidden &= ~face_triangles(world, a, b, r)
        if use.any():
            cell_hidden(boundary_samples(a, b), polys, starts, tops, use, slack,
                        slack * 2.0 * (COVER + r), corners, groups, order, gboxes, tol, hidden)
        out.append(~hidden)
    return out


def prepare(world, footprints) -> tuple:
    """What every box of a bake reads: the footprints' polygon_table, the corners (T, 3, 3)
    float64 and triangle_groups (made once a bake, not once a cell)."""
    return (polygon_table(footprints), np.ascontiguousarray(world.corners, dtype=np.float64),
            triangle_groups(world, GROUP_TILE))


def bake_street(world, grow, tol, progress=None, jobs=1, executor=None, chunks=32,
                columns=None, fly=False) -> tuple:
    """(boxes (V, 2, 3), masks: V (T,) bool visible sets, stats) of the street cells (module
    docstring), and with fly the fly-over cells above them (pvs_fly.py) after them; pvs.bake
    stores them with pvs_cover (2,) float64 (COVER, NEAR_MIN).

    grow, tol : the bake's growth and plane tolerance (pvs.bake_grow, pvs.TOLERANCE + grow)
    chunks    : source-cell chunks handed to a given executor (a Dask Client or any pool)
    columns   : find_columns(world), if already found
    """
    began = time.perf_counter()
    footprints, _, top, _ = find_columns(world) if columns is None else columns
    r = reach()
    boxes = street_cells(world, footprints, grow + r)
    street_top = float(boxes[:, 1, 1].max()) if len(boxes) else np.inf
    street = len(boxes)
    if fly:
        boxes = np.concatenate([boxes, fly_cells(world, footprints, top, street_top,
                                                 street_cell(world), MIN_CELL, grow + r,
                                                 COVER + grow)])
    shrunk = [erode(p, r + tol) for p in footprints]
    valid = np.array([s is not None for s in shrunk], dtype=bool)
    polys = np.concatenate([s for s in shrunk if s is not None] or [np.zeros((0, 2))])
    lengths = [0 if s is None else len(s) for s in shrunk]
    starts = np.concatenate([[0], np.cumsum(lengths)]).astype(np.int64)
    tops = np.asarray(top, dtype=np.float64) - tol
    slack = depth_slack(world, grow)
    args = (world, polys, starts, valid, tops, footprints, grow, tol, slack, street_top,
            prepare(world, footprints))
    count = len(boxes)
    masks = fan_out(_chunk, (args,), boxes, (), jobs, executor, chunks, progress)
    stats = {"seconds": time.perf_counter() - began, "cells": count, "overflowed": 0,
             "walks": 0, "door_sets": 0, "columns": int(valid.sum()),
             "fly_cells": count - street}
    return boxes, masks, stats


def _chunk(args, boxes):
    """bake_street_cells over some boxes (a process pool's task)."""
    return bake_street_cells(args[0], boxes, *args[1:])

"""Precomputed visibility (PVS): for each view cell, the triangles some eye inside it may see.

`bake(partition)` works on any structure: the view cells are a portal grid of the PVS's own
(pvs_cells.py: portal.py's cells and portals, with both faces of thick walls as boundaries),
and `pvs_kernels.flow_from_cell` walks the portal crossings out of each (separating planes,
conservative). The result is stored with the partition as extras, so it travels in the `.vmp`
(CRC'd sections, checked on load by `check`):

    pvs_cells  (V, 2, 3) float64  view-cell boxes (the .vmp keeps them in pvs_pack)
    pvs_shape, pvs_pack           the boxes and the cells' sets, one pattern of cells per
                                  triangle, arithmetic-coded (pvs_codec.py)
    pvs_grow   (1,)      float64  how far eyes and portals were grown (device rounding)
    pvs_back   (1,)      float64  the stage may leave out what faces away from the whole cell
                                  grown by this much (pvs_back.py), when back faces are culled
    pvs_plane  (1,)      float64  optional: the sets hold what lines lying in a view grid face's
                                  plane see from eyes within this much of it (pvs_planes.py)
    pvs_door_boxes (D, 2, 3) float64, pvs_door_start (V D + 1,) int64, pvs_door_runs (R,)
                                  int32: optional (bake(doors=...)), per (cell, door) the
                                  runs of what the door shut hides from the cell (door_sets)

A sight line starts where the near plane cuts it, within the near plane's reach of the eye,
perhaps beyond a wall next to it: the runtime stage takes the union of the sets of every cell
within that reach (plus the device's) of the eye. An eye may sit inside a closed solid (the
portals close its inside): each cell's set holds every triangle of the closed outward parts
(solids.py) whose box comes within pvs_grow of the cell.

Contract (conservative): for every eye in a view cell grown by pvs_grow, every triangle the
item buffer without back-face culling shows along a line starting in that cell is in the
cell's set (the stage leaves out what faces away from every eye in the cell grown by pvs_back
only when back faces are culled: pvs_back.py's bound), provided the portals cover every
opening (portal.py) and the rasteriser's cracks lie within pvs_cracks.py's width of the
edges two triangles do not share by both corners (T-junctions, creases, borders: each is a
crack portal the walk passes, any number per line), and lines lying within pvs_plane of a view
grid face's plane pass every edge there with no triangles on both sides of the plane (a wall in
the plane is edge-on: pvs_planes.py, walked per source cell and plane). Errs toward visible: separating planes
only remove lines that cannot exist, a triangle facing out of the cell it is marked from is
left to the cells in front of it when every source point is in front of it
(pvs_kernels._behind_cell), sides within the tolerance count, and a source whose walk
exceeds the budget keeps every connected cell. The hollow walls' open insides and the cracks
into them keep the sets large (docs/partition.md; tools/pvs_sweep.py measures the drops).
"""
from __future__ import annotations

import time

import numpy as np

from . import pvs_cracks, pvs_kernels
from .pvs_check import check_pvs  # noqa: F401 (checked on load by base.Partition.check)
from .pvs_planes import SLAB, face_extras, source_slabs
from .pvs_pool import fan_out
from .pvs_sequences import sequence_grid, sequence_set

MODES = ("conservative",)
EXECUTOR_CHUNKS = 32  # source-cell chunks handed to a given executor (a progress step each)
BUDGET = 200_000  # cell walks per source cell before it keeps every connected cell
GROW_RELATIVE, GROW_ABSOLUTE = 2.0 ** -20, 2.0 ** -16  # a device move (culling/precision.py)
TOLERANCE = 1e-9  # relative to the world's size: plane sides within it count as on it
# The from-region back-face test holds for eyes this far outside a cell (a share of the world's
# size, at least BACK_MIN): the stage drops back faces only for cameras whose near plane's
# reach fits (culling/pvs.py), and only when the combination culls back faces.
BACK_RELATIVE, BACK_MIN = 0.002, 0.5
# culling/precision.py's device move, doubled (2^-20 x the magnitude, plus 2^-16)
DEVICE_RELATIVE, DEVICE_ABSOLUTE = 2.0 ** -19, 2.0 ** -15


def fly_option(value) -> bool:
    """The fly= option (fly-over cells over the street cells, pvs_fly.py): on/off, true/false."""
    text = str(value).strip().lower()
    if text not in ("on", "off", "true", "false"):
        raise ValueError(f"fly={value}: expected fly=on or fly=off")
    return text in ("on", "true")


def back_delta(world) -> float:
    """The device move the back-face test covers (twice precision.device_move's, at twice the
    world's magnitude)."""
    vertices = np.asarray(world.vertices)
    scale = float(max(-vertices.min(), vertices.max())) if vertices.size else 0.0
    return DEVICE_RELATIVE * 2.0 * scale + DEVICE_ABSOLUTE


def back_reach(world) -> float:
    """How far outside its cell an eye may be for the cell's back-face test (BACK_RELATIVE)."""
    return max(BACK_MIN, BACK_RELATIVE * float(np.ptp(world.extent, axis=0).max()))


def bake_grow(world) -> float:
    """How far eyes and portals are grown: 2 sqrt(3) times a device move (culling/precision.py's
    bound, fixed16.16: 2^-20 x the magnitude + 2^-16) at twice the world's coordinate magnitude.
    The runtime stage checks that its own reach fits inside it, else it falls back."""
    vertices = np.asarray(world.vertices)
    scale = 2.0 * float(max(-vertices.min(), vertices.max())) if vertices.size else 0.0
    return 2.0 * np.sqrt(3.0) * (GROW_RELATIVE * scale + GROW_ABSOLUTE)


def _connected(source, portal_cells, cell_portal_start, cell_portals, cells):
    """(C,) bool cells joined to the source by portals."""
    seen = np.zeros(cells, dtype=bool)
    seen[source] = True
    stack = [source]
    while stack:
        c = stack.pop()
        for p in cell_portals[cell_portal_start[c]:cell_portal_start[c + 1]]:
            a, b = portal_cells[p]
            m = b if a == c else a
            if not seen[m]:
                seen[m] = True
                stack.append(m)
    return seen


def runs_of(visible) -> np.ndarray:
    """(2R,) int64 ascending [first, end) pairs of the True runs of a (T,) bool array."""
    edges = np.flatnonzero(np.diff(np.concatenate([[0], visible.astype(np.int8), [0]])))
    return edges.astype(np.int64)


def ids_of(runs) -> np.ndarray:
    """(S,) int64 sorted ids of [first, end) pairs (runs_of inverted)."""
    runs = np.asarray(runs, dtype=np.int64)
    first, end = runs[0::2], runs[1::2]
    lengths = end - first
    if not len(lengths) or lengths.sum() == 0:
        return np.zeros(0, dtype=np.int64)
    return np.repeat(first - np.cumsum(lengths) + lengths, lengths) + np.arange(lengths.sum())


def bake_cells(world, g, sources, grow, tol, budget=BUDGET, door_portals=()):
    """[(runs (2R,) int64, walks or -1, hidden {door: runs (2H,) int64}, face runs (2F,)
    int64)] for the given source cells of the view grid g (pvs_cells.view_grid). hidden[d]:
    what the source's walk reaches with every portal open but not with door d's portals
    (door_portals[d], (k,) int64 ids) blocked; only doors with a portal the open walk crossed
    are walked again. face: what only the lines lying in a face's plane reach (pvs_planes.py,
    the walks in its slab; none when the walk overflowed: every connected cell is whole)."""
    cells = len(g["cell_bounds"])
    quads = np.asarray(g["portal_vertices"], dtype=np.float64).reshape(-1, 4, 3)
    pcells, cps, cp = g["portal_cells"], g["cell_portal_start"], g["cell_portals"]
    bounds, start, tris = g["cell_bounds"], g["cell_start"], g["cell_tris"]
    corners = world.corners
    crack = np.zeros(len(pcells), dtype=np.bool_)
    planes = int(g.get("planes", 0))  # pvs_planes appends them after the cracks
    crack[len(pcells) - int(g.get("cracks", 0)) - planes:] = True  # pvs_cracks: last
    in_plane = np.zeros(len(pcells), dtype=np.bool_)
    in_plane[len(pcells) - planes:] = True  # walked only in their plane's slab
    plane_of = np.full(len(pcells), -1, dtype=np.int64)
    plane_of[len(pcells) - planes:] = g.get("plane_of", np.zeros(0, np.int64))
    plane_cells = {int(p): np.unique(pcells[plane_of == p])
                   for p in np.unique(plane_of[plane_of >= 0])}
    slope = pvs_cracks.CRACK_SLOPE
    out = []

    def walk(s, blocked):
        """The source's walk with the plane portals shut, then one per face plane it meets
        with that plane's open, over the lines in its slab (pvs_planes.py): skipped when the
        first walk reached no cell of that plane's portals (a line in the slab is a line from
        the source until it passes one)."""
        visible = np.zeros(world.triangle_count, dtype=np.bool_)
        crossed = np.zeros(len(pcells), dtype=np.bool_)
        seen = np.zeros(cells, dtype=np.bool_)
        args = (bounds, pcells, quads, cps, cp, start[:-1], start[1:], tris, corners, grow,
                tol, budget)
        steps = pvs_kernels.flow_from_cell(int(s), bounds[s, 0], bounds[s, 1], *args, visible,
                                           seen, crack, slope, blocked | in_plane, crossed)
        reached = seen.copy()
        more_visible = visible.copy()  # and what the lines in a face's plane add
        for p, slab, lo, hi in source_slabs(g, bounds[s, 0], bounds[s, 1], grow):
            if steps < 0:
                break
            if not reached[plane_cells[p]].any():
                continue
            more = pvs_kernels.flow_in_slab(int(s), lo, hi, *args, more_visible, seen, crack,
                                            slope, blocked | (in_plane & (plane_of != p)),
                                            crossed, slab)
            steps = -1 if more < 0 else steps + more
        return visible, crossed, int(steps), more_visible

    none = np.zeros(len(pcells), dtype=np.bool_)
    joined = g.get("joined")
    for s in sources:
        visible, crossed, steps, more = walk(s, none)
        if steps < 0:  # too many walks: every connected cell, whole
            for c in np.flatnonzero(_connected(int(s), pcells, cps, cp, cells)):
                visible[tris[start[c]:start[c + 1]]] = True
            more = visible
        elif joined is not None:  # both walks keep every line: so does what both mark
            tight = sequence_set(world, joined, s, bounds[s, 0], bounds[s, 1], grow, tol)
            if tight is not None:
                visible &= tight
        face = more & ~visible
        hidden = {}
        for d, ports in enumerate(door_portals):
            if steps < 0 or not crossed[ports].any():  # no line from the source crosses it
                continue
            blocked = none.copy()
            blocked[ports] = True
            shut, _, shut_steps, _ = walk(s, blocked)
            if shut_steps >= 0 and (visible & ~shut).any():
                hidden[d] = visible & ~shut
        out.append((runs_of(visible), steps, hidden, runs_of(face)))
    return out


def with_solids(world, boxes, masks, grow) -> list:
    """Each cell's mask ORed with every closed outward part (solids.py) whose box comes within
    grow (plus the tolerance) of the cell: an eye inside a solid sees its inside.

    masks : list of C (T,) bool from-cell sets; returns a new list
    """
    from .solids import outward_solid_parts

    pad = grow + TOLERANCE * float(np.ptp(world.extent, axis=0).max())
    parts = outward_solid_parts(world)
    solid = np.flatnonzero(parts >= 0)
    count = int(parts.max()) + 1 if len(solid) else 0
    lo = np.full((count, 3), np.inf)
    hi = np.full((count, 3), -np.inf)
    bounds = world.bounds
    np.minimum.at(lo, parts[solid], bounds[solid, 0])
    np.maximum.at(hi, parts[solid], bounds[solid, 1])
    out = []
    for c, mask in enumerate(masks):
        close = np.flatnonzero(((lo <= boxes[c, 1] + pad) & (hi >= boxes[c, 0] - pad)).all(axis=1))
        out.append(mask | np.isin(parts, close) if len(close) else mask)
    return out


def bake(partition, mode="conservative", progress=None, jobs=1, budget=BUDGET,
         cells=None, executor=None, doors=None, planes=True, sequences=True) -> tuple:
    """The PVS extras (module docstring) of a partition of any kind, and bake statistics.

    The view cells are a portal grid of the PVS's own (pvs_cells.view_grid: about `cells`
    cells, default as the portal structure's), so the structure's kind does not matter; a
    BSP tree's leaves then become the view cells, each taking the grid cells its region may
    touch (pvs_leaves.py). An outdoor world (pvs_street.outdoor) gets the street cells and
    their occluder shadows instead, whatever the kind (BSP too), unless doors or cells are
    given.
    progress : optional callable(done, total) per source cell
    jobs     : processes (>1: source cells split over a process pool)
    executor : optional pool with submit(fn, *args) -> future with result(), used instead of
               a process pool of `jobs`: the source cells split in EXECUTOR_CHUNKS chunks (a
               Dask Client: world and view grid scattered to its workers once)
    doors    : optional (D, 2, 3) closed boxes of doors (world/doors.py): per view cell and
               door, what the door shut hides from the cell (door_sets; not for a BSP)
    planes   : False: no walks of the lines lying in a face's plane (pvs_planes.py; a
               diagnostic: the stage then falls back for eyes in those planes, no pvs_plane)
    sequences : False: the union walk's sets alone (pvs_sequences.py: a diagnostic; with it
               each cell keeps what both its union walk and its sequence walk mark, on a
               repaired world or one without crack portals)
    partition.params["fly"] "on": fly-over cells over an outdoor world's street cells
               (pvs_fly.py; ValueError when the world gets no street cells)
    partition.params["budget"]: a share of the OBJ's bytes the PVS may take; the sets are
               coarsened until they fit (pvs_coarsen.py; stats["budget"] says how, and
               whether they did); not there: pvs_coarsen.DEFAULT_BUDGET; "none": exact sets
    returns  : (extras dict, stats dict: seconds, cells, overflowed cells, walks, budget)
    """
    from .pvs_cells import view_grid

    if mode not in MODES:
        raise ValueError(f"unknown pvs mode {mode!r}; valid: {', '.join(MODES)}")
    began = time.perf_counter()
    world = partition.world
    fly = fly_option(partition.params.get("fly", "off"))
    # outdoors every kind takes the street cells, the BSP tree too: its leaves span far more
    # than the street layer, and their sets from the grid's cells were the whole world
    if doors is None and cells is None:
        from .pvs_columns import find_columns
        from .pvs_street import COVER, NEAR_MIN, bake_street, outdoor

        columns = find_columns(world)
        if outdoor(world, columns[3]):  # street-level cells and occluder shadows
            grow = bake_grow(world)
            tol = TOLERANCE * float(np.ptp(world.extent, axis=0).max()) + grow
            boxes, masks, stats = bake_street(world, grow, tol, progress, jobs, executor,
                                              EXECUTOR_CHUNKS, columns, fly)
            masks = with_solids(world, boxes, masks, grow)
            extras = {"pvs_grow": np.array([grow], dtype=np.float64),
                      "pvs_back": np.array([back_reach(world)], dtype=np.float64),
                      "pvs_cover": np.array([COVER, NEAR_MIN], dtype=np.float64)}
            sets, stats["budget"] = stored_sets(partition, boxes, masks, extras)
            extras = {"pvs_cells": boxes.copy(), **sets, **extras}
            stats["seconds"] = time.perf_counter() - began
            return extras, stats
    if fly:
        raise ValueError("fly=on: fly-over cells lie over an outdoor world's street cells (a "
                         "world of standing blocks, no doors); this one has none")
    grow = bake_grow(world)
    # a world whose T-junctions were repaired (world/tjunctions.py) shares every crease's
    # corners, so the rasteriser opens no crack there: its thin cells are sealed at the walls
    # inside them. Its unshared edges left are open borders (a hollow wall's uncapped foot),
    # which stay crack portals: without them W1's sealed bake dropped 1 of 2,000 cameras
    # (docs/partition.md, "T-junctions repaired")
    sealed = getattr(world, "repair", None) == "tjunctions"
    g = view_grid(world, cells, grow=grow, split=sealed, planes=planes)
    tol = TOLERANCE * float(np.ptp(world.extent, axis=0).max()) + grow
    if sequences and (sealed or not g.get("cracks")):
        # a world as built with T-junction creases: every sequence walk passes its budget (the
        # cracks join the hollow walls), so it would cost a quarter of the bake for nothing
        g["joined"] = sequence_grid(g, tol)
    count = len(g["cell_bounds"])
    sources = np.arange(count)
    if doors is not None and partition.kind == "bsp":
        doors = None  # the leaves' sets are unions of grid cells' (pvs_leaves.py): not kept
    door_portals = door_portal_sets(world, g, doors, grow) if doors is not None else []
    results = fan_out(bake_cells, (world, g), sources, (grow, tol, budget, door_portals), jobs,
                      executor, EXECUTOR_CHUNKS, progress)
    masks, faces = [], []
    for r, _, _, f in results:
        for runs, out in ((r, masks), (f, faces)):
            mask = np.zeros(world.triangle_count, dtype=bool)
            mask[ids_of(runs)] = True
            out.append(mask)
    masks, boxes = with_solids(world, g["cell_bounds"], masks, grow), g["cell_bounds"]
    door_extras = {} if doors is None else door_sets(results, masks, doors)
    if partition.kind == "bsp":  # the BSP tree's leaves are the view cells (pvs_leaves.py)
        from .pvs_leaves import leaf_sets

        _, faces = leaf_sets(partition, boxes, faces, tol)
        boxes, masks = leaf_sets(partition, boxes, masks, tol)
    boxes = np.asarray(boxes, dtype=np.float64).copy()
    extras = {"pvs_grow": np.array([grow], dtype=np.float64),
              "pvs_back": np.array([back_reach(world)], dtype=np.float64), **door_extras}
    # the face sets' bytes count too, and go coarse first when the sets do not fit
    plane = face_extras(g, boxes, faces, SLAB * grow) if planes else {}
    sets, report = stored_sets(partition, boxes, masks, {**extras, **plane},
                               faces if "pvs_face_pack" in plane else None)
    extras = {"pvs_cells": boxes, **{k: sets[k] for k in ("pvs_shape", "pvs_pack")}, **extras,
              **plane, **{k: v for k, v in sets.items() if k in plane}}
    stats = {"budget": report, "seconds": time.perf_counter() - began, "cells": len(boxes),
             "overflowed": int(sum(r[1] < 0 for r in results)),
             "walks": int(sum(max(r[1], 0) for r in results)),
             "door_sets": int(sum(len(r[2]) for r in results))}
    return extras, stats


def stored_sets(partition, boxes, masks, others, faces=None) -> tuple:
    """(pvs_shape and pvs_pack of the sets, the budget's report): coarsened until the PVS
    (with the others extras) fits partition.params["budget"] x the OBJ's bytes
    (pvs_coarsen.py: cells merged, sets only grow; DEFAULT_BUDGET when the params name none),
    exact for budget "none". With faces ((V, T) bool face sets, others holding their exact
    coding), also their coding, collapsed to one set when the exact PVS does not fit
    (pvs_coarsen.fit)."""
    from .pvs_coarsen import budget_option, fit

    share = budget_option(partition.params.get("budget"))
    budget = None if share is None else share * partition.world.obj_bytes()
    return fit(boxes, masks, budget, others, partition.world.corners, faces=faces)


def door_portal_sets(world, g, doors, grow) -> list:
    """Per door, (k,) int64 the view grid's portals wholly inside its closed box deeper than
    the door rule asks of the portals stage at the bake's growth (culling/doors.py rule 2:
    1.5 grow plus what a closed door may move, at twice the world's magnitude)."""
    from ..world.doors import CLOSED, door_pairs

    doors = np.asarray(doors, dtype=np.float64).reshape(-1, 2, 3)
    vertices = np.asarray(world.vertices)
    scale = 2.0 * float(max(-vertices.min(), vertices.max())) if vertices.size else 0.0
    portals, ids, depth = door_pairs(g["portal_vertices"], g["portal_start"], doors)
    deep = depth > 1.5 * grow + 4.0 * CLOSED * (scale + 1.0)
    return [np.unique(portals[deep & (ids == d)]) for d in range(len(doors))]


def door_sets(results, masks, doors) -> dict:
    """The door extras: pvs_door_boxes (D, 2, 3) float64, pvs_door_start (V D + 1,) int64
    offsets (cell-major: c D + d) into pvs_door_runs (R,) int32 [first, end) runs of what
    door d shut hides from cell c (bake_cells' hidden), less what the cell's set holds
    besides its walk (with_solids: the insides of solids near it)."""
    doors = np.asarray(doors, dtype=np.float64).reshape(-1, 2, 3)
    runs = []
    for (r, _, hidden, _), mask in zip(results, masks):
        walked = np.zeros(len(mask), dtype=bool)
        walked[ids_of(r)] = True
        extra = mask & ~walked  # the solids' insides the cell keeps whatever the doors do
        for d in range(len(doors)):
            runs.append(runs_of(hidden[d] & ~extra) if d in hidden else np.zeros(0, np.int64))
    start = np.concatenate([[0], np.cumsum([len(r) for r in runs])]).astype(np.int64)
    return {"pvs_door_boxes": doors.copy(), "pvs_door_start": start,
            "pvs_door_runs": (np.concatenate(runs) if runs else np.zeros(0)).astype(np.int32)}

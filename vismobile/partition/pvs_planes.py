"""Lines lying in a view-cell face's plane: the creases they slip through, and their walks.

A wall closing a cell face lies in the face's plane P. From an eye in P (within the device's
rounding of it) that wall is edge-on and covers no pixel, so a sight line lying in P meets
another surface's edge lying in P with nothing behind it: where the triangles sharing such an
edge (by both corners) that do not lie in P are all on one side of P, the fill rule may leave
the pixel open and the line goes on in P past the edge (W2: eye (19.18, 1.55, 8.1) in the plane
z = 8.1 of a hollow wall's face, through the crease of a lintel's underside and of a ceiling
into the slab's inside). Between two triangles on either side of P the edge is watertight.

Such edges lying in a face's plane P (plane_edges) become segment portals between the cells
whose common face or line holds them (pvs_cracks.edge_portals, like the rasteriser's cracks),
tagged with P. The bake (pvs.py) walks them only in a walk of the lines lying in the slab of
P within SLAB grow of it (pvs_kernels.flow_in_slab), one per face plane with such portals that
the source cell meets; every other walk has them shut. What those walks add is stored apart,
as each cell's face set (face_extras): the runtime stage (culling/pvs.py in_face) adds it only
for an eye within its face reach (culling/pvs_frame.near_plane) of a plane walked, where it
fell back before, so the sets of every other eye stay as they were.

Contract: errs toward visible. The planes are every face plane of the view grid; an edge is
open unless two triangles sharing it lie on opposite sides of P; the slab walk is the portal
walk (sound, pvs_kernels.py) over the lines within the slab, with the edges' portals as wide as
cracks.
"""
from __future__ import annotations

import numpy as np

from . import portal
from .pvs_codec import encode
from .pvs_cracks import edge_portals

SLAB = 4.0  # eyes within SLAB x the bake's growth of a face plane lie in it (the device rounds)


def face_planes(boxes, eps) -> tuple:
    """(axis (P,) int64, coordinate (P,) float64) of every distinct cell face plane (within
    eps, per axis)."""
    axes, coords = [], []
    for a in range(3):
        c = np.unique(np.asarray(boxes)[:, :, a])
        keep = np.r_[True, np.diff(c) > eps]
        axes.append(np.full(int(keep.sum()), a, dtype=np.int64))
        coords.append(c[keep])
    return np.concatenate(axes), np.concatenate(coords)


def plane_edges(world, planes, eps) -> tuple:
    """(seg (E, 2, 3) float64, owner (E,) int64, plane (E,) int64): the edges lying in a face
    plane (planes: face_planes' pair, within eps) that a line in the plane may pass: shared
    by both corners (an unshared edge is a crack portal for every line already), with no two
    triangles sharing it on opposite sides of the plane; one row per triangle sharing it that
    does not lie in the plane (its owner)."""
    tri = np.asarray(world.triangles)
    vertices = np.asarray(world.vertices, dtype=np.float64)
    if not len(tri):
        return np.zeros((0, 2, 3)), np.zeros(0, np.int64), np.zeros(0, np.int64)
    _, inv = np.unique(vertices, axis=0, return_inverse=True)
    t = inv.ravel()[tri]
    count = len(tri)
    first, second, third = [0, 1, 2], [1, 2, 0], [2, 0, 1]
    keys = np.sort(np.concatenate([t[:, [i, j]] for i, j in zip(first, second)]), axis=1)
    _, group, counts = np.unique(keys, axis=0, return_inverse=True, return_counts=True)
    group = group.ravel()
    p0 = vertices[np.concatenate([tri[:, i] for i in first])]
    p1 = vertices[np.concatenate([tri[:, i] for i in second])]
    p2 = vertices[np.concatenate([tri[:, i] for i in third])]
    shared = (counts[group] >= 2) & (keys[:, 0] != keys[:, 1])
    axis_of, coord_of = planes
    segs, owners, ids = [], [], []
    for a in range(3):
        mine = np.flatnonzero(axis_of == a)
        if not len(mine):
            continue
        coords = coord_of[mine]
        at = np.clip(np.searchsorted(coords, p0[:, a]), 1, max(len(coords) - 1, 1))
        j = np.where(np.abs(coords[at - 1] - p0[:, a]) <= np.abs(coords[at] - p0[:, a]),
                     at - 1, at) if len(coords) > 1 else np.zeros(len(p0), np.int64)
        c = coords[j]
        lying = shared & (np.abs(p0[:, a] - c) <= eps) & (np.abs(p1[:, a] - c) <= eps)
        d = p2[:, a] - c
        side = np.where(d > eps, 1, np.where(d < -eps, -1, 0))
        groups = int(group.max()) + 1
        above = np.bincount(group[lying & (side > 0)], minlength=groups) > 0
        below = np.bincount(group[lying & (side < 0)], minlength=groups) > 0
        open_ = lying & (side != 0) & ~(above & below)[group]
        rows = np.flatnonzero(open_)
        segs.append(np.stack([p0[rows], p1[rows]], axis=1))
        owners.append(rows % count)
        ids.append(mine[j[rows]])
    if not segs:
        return np.zeros((0, 2, 3)), np.zeros(0, np.int64), np.zeros(0, np.int64)
    return (np.concatenate(segs), np.concatenate(owners).astype(np.int64),
            np.concatenate(ids).astype(np.int64))


def with_plane_cracks(world, g, eps, grow) -> dict:
    """The view grid g with the plane edges' portals (plane_edges over its face planes,
    pvs_cracks.edge_portals within the slab's reach) appended last: their count in
    g['planes'], each one's plane in g['plane_of'] (K,) int64, rows of g['plane_table'] (P, 2)
    float64 (axis, coordinate)."""
    size = float(np.ptp(world.extent, axis=0).max())
    tiny = portal.COINCIDE * size
    boxes = np.asarray(g["cell_bounds"], dtype=np.float64)
    planes = face_planes(boxes, tiny)
    seg, owner, plane = plane_edges(world, planes, tiny)
    table = np.stack([planes[0].astype(np.float64), planes[1]], axis=1)
    g = {**g, "planes": 0, "plane_of": np.zeros(0, np.int64), "plane_table": table}
    if not len(seg):
        return g
    pairs, quads, tags = edge_portals(world, seg, owner, boxes, eps, (SLAB + 1.0) * grow, plane)
    if not len(pairs):
        return g
    pcells = np.concatenate([np.asarray(g["portal_cells"], dtype=np.int64).reshape(-1, 2), pairs])
    verts = np.concatenate([np.asarray(g["portal_vertices"], dtype=np.float64).reshape(-1, 3),
                            quads.reshape(-1, 3)])
    ends = np.concatenate([pcells[:, 0], pcells[:, 1]])
    ids = np.tile(np.arange(len(pcells)), 2)
    order = np.lexsort((ids, ends))
    cps = np.concatenate([[0], np.cumsum(np.bincount(ends, minlength=len(boxes)))])
    return {**g, "portal_cells": pcells, "portal_vertices": verts,
            "portal_start": np.arange(0, 4 * len(pcells) + 1, 4),
            "cell_portal_start": cps.astype(np.int64),
            "cell_portals": ids[order].astype(np.int64), "planes": len(pairs),
            "plane_of": tags}


def source_slabs(g, lo, hi, grow) -> list:
    """[(plane id, slab (3,) float64 (axis, lo, hi), source lo (3,), hi (3,))] of the planes
    with portals (g['plane_of']) within SLAB grow of the source box [lo, hi]: the source is
    the box's part within SLAB grow of the plane, the slab that grown by the walk's grow."""
    table = g.get("plane_table")
    if table is None or not len(g.get("plane_of", ())):
        return []
    reach = SLAB * grow
    out = []
    for p in np.unique(g["plane_of"]):
        a, c = int(table[p, 0]), float(table[p, 1])
        if lo[a] - reach <= c <= hi[a] + reach:
            s_lo, s_hi = np.array(lo, dtype=np.float64), np.array(hi, dtype=np.float64)
            s_lo[a], s_hi[a] = max(lo[a], c - reach), min(hi[a], c + reach)
            half = reach + grow
            out.append((int(p), np.array([float(a), c - half, c + half]), s_lo, s_hi))
    return out


def face_extras(g, boxes, faces, reach) -> dict:
    """The extras of what lines lying in a face's plane add to each view cell's set (bake_cells'
    face runs, apart from the sets: the stage adds them only for eyes that near a face plane):
    pvs_plane (1,) reach (eyes within it of a plane were walked), pvs_face_planes (P, 2)
    float64 the planes walked (axis, coordinate), and pvs_face_shape, pvs_face_pack the
    cells' added sets (pvs_codec.encode over the same boxes) when some plane was walked."""
    tags = np.unique(np.asarray(g.get("plane_of", np.zeros(0)), dtype=np.int64))
    table = np.asarray(g.get("plane_table", np.zeros((0, 2))), dtype=np.float64).reshape(-1, 2)
    out = {"pvs_plane": np.array([reach], dtype=np.float64),
           "pvs_face_planes": table[tags].copy()}
    if len(tags):
        sets = encode(boxes, faces)
        out["pvs_face_shape"], out["pvs_face_pack"] = sets["pvs_shape"], sets["pvs_pack"]
    return out


def face_sets(extras) -> dict:
    """The face sets as pvs_shape, pvs_pack (and the cells' pvs_cells) for pvs_codec.decode,
    or None without them."""
    if "pvs_face_shape" not in extras:
        return None
    out = {"pvs_shape": extras["pvs_face_shape"], "pvs_pack": extras["pvs_face_pack"]}
    if "pvs_cells" in extras:
        out["pvs_cells"] = extras["pvs_cells"]
    return out

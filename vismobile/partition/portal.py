"""Portal octree: irregular-grid cells, each with its own octree (depth 1..3), joined by portals
found from the geometry: the parts of each shared cell face that no wall covers, each stored as
its bounding rectangle on the face (convex, never smaller than the opening it was found from)."""
from __future__ import annotations

import numpy as np

from . import grid
from .layout import make_partition
from .octree import check_depth, chain_levels, subdivide

# Samples along the longer side of a shared face when rasterising its coverage.
FACE_SAMPLES = 64
# Triangles within this fraction of the world's size of a face plane lie in it (walls).
THICKNESS = 1e-4


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
        aligned = np.abs(world.normals[:, axis]) > 0.999
        if not aligned.any():
            continue
        pos = world.centroids[aligned, axis]
        keys, inverse = np.unique(np.round(pos, 6), return_inverse=True)
        area = np.bincount(inverse, weights=world.areas[aligned])
        snapped = e.copy()
        for b in range(1, len(e) - 1):
            reach = 0.5 * min(e[b] - e[b - 1], e[b + 1] - e[b])
            near = np.flatnonzero(np.abs(keys - e[b]) < reach)
            near = near[(keys[near] > low[axis]) & (keys[near] < high[axis])]
            if len(near):
                snapped[b] = keys[near[np.argmax(area[near])]]
        snapped = np.unique(snapped)
        edges[axis] = snapped
    return edges


def _components(open_mask):
    """(nu, nv) int64 4-connected component labels of open samples (-1 where closed)."""
    nu, nv = open_mask.shape
    big = nu * nv
    label = np.where(open_mask, np.arange(big).reshape(nu, nv), big)
    while True:
        new = label.copy()
        new[1:] = np.minimum(new[1:], np.where(open_mask[1:], label[:-1], big))
        new[:-1] = np.minimum(new[:-1], np.where(open_mask[:-1], label[1:], big))
        new[:, 1:] = np.minimum(new[:, 1:], np.where(open_mask[:, 1:], label[:, :-1], big))
        new[:, :-1] = np.minimum(new[:, :-1], np.where(open_mask[:, :-1], label[:, 1:], big))
        new = np.where(open_mask, new, big)
        flat = new.ravel()
        jumped = np.where(open_mask.ravel(), np.append(flat, big)[np.minimum(flat, big)], big)
        new = np.minimum(new, jumped.reshape(nu, nv))
        if np.array_equal(new, label):
            return np.where(open_mask, label, -1)
        label = new


def _point_segment_sq(px, py, ax, ay, bx, by):
    """Squared 2D distance from points to segments, elementwise."""
    dx, dy = bx - ax, by - ay
    length = dx * dx + dy * dy
    t = np.where(length > 0, ((px - ax) * dx + (py - ay) * dy) / np.where(length > 0, length, 1), 0)
    t = np.clip(t, 0.0, 1.0)
    ex, ey = ax + t * dx - px, ay + t * dy - py
    return ex * ex + ey * ey


def face_openings(world, axis, plane, lo_uv, hi_uv, thickness, samples=FACE_SAMPLES):
    """Open rectangles of one shared face: (Q, 2, 2) float64 [[u0, v0], [u1, v1]] in the face's
    (axis + 1, axis + 2) coordinates.

    Errs large: each rectangle is an open region's sample box grown by one sample spacing s
    (openings narrower than about s are missed). A sample is covered when it lies within s/2 of
    a triangle lying in the plane (within `thickness`) or of the line where a triangle crosses it.
    """
    u_axis, v_axis = (axis + 1) % 3, (axis + 2) % 3
    size = hi_uv - lo_uv
    s = max(float(size.max()) / samples, 1e-300)
    nu, nv = (np.maximum(1, np.ceil(size / s - 1e-9)).astype(int))
    tb = world.bounds
    near = np.flatnonzero((tb[:, 0, axis] <= plane + thickness) & (tb[:, 1, axis] >= plane - thickness)
                          & (tb[:, 0, u_axis] <= hi_uv[0] + s) & (tb[:, 1, u_axis] >= lo_uv[0] - s)
                          & (tb[:, 0, v_axis] <= hi_uv[1] + s) & (tb[:, 1, v_axis] >= lo_uv[1] - s))
    covered = np.zeros(nu * nv, dtype=bool)
    if len(near):
        c = world.corners[near]
        h = c[:, :, axis] - plane
        cu, cv = c[:, :, u_axis], c[:, :, v_axis]
        flat = (np.abs(h) <= thickness).all(axis=1)
        # Crossing triangles: the segment where the plane h = 0 cuts them.
        crossing = ~flat & (h.min(axis=1) < 0) & (h.max(axis=1) > 0)
        seg = np.zeros((len(near), 2, 2))
        for t in np.flatnonzero(crossing):  # few per face; clarity over vectorising
            pts = []
            for a, b in ((0, 1), (1, 2), (2, 0)):
                if (h[t, a] < 0) != (h[t, b] < 0) and h[t, a] != h[t, b]:
                    w = h[t, a] / (h[t, a] - h[t, b])
                    pts.append((cu[t, a] + w * (cu[t, b] - cu[t, a]), cv[t, a] + w * (cv[t, b] - cv[t, a])))
                elif h[t, a] == 0:
                    pts.append((cu[t, a], cv[t, a]))
            pts = np.array(pts)
            seg[t] = [pts.min(axis=0), pts.max(axis=0)] if len(pts) < 2 else [pts[0], pts[-1]]
        use = np.flatnonzero(flat | crossing)
        # Sample rectangle of each triangle's footprint, grown by s/2.
        fu0 = np.where(flat, cu.min(axis=1), np.minimum(seg[:, 0, 0], seg[:, 1, 0]))[use]
        fu1 = np.where(flat, cu.max(axis=1), np.maximum(seg[:, 0, 0], seg[:, 1, 0]))[use]
        fv0 = np.where(flat, cv.min(axis=1), np.minimum(seg[:, 0, 1], seg[:, 1, 1]))[use]
        fv1 = np.where(flat, cv.max(axis=1), np.maximum(seg[:, 0, 1], seg[:, 1, 1]))[use]
        i0 = np.clip(np.floor((fu0 - lo_uv[0]) / s - 1).astype(int), 0, nu - 1)
        i1 = np.clip(np.ceil((fu1 - lo_uv[0]) / s).astype(int), 0, nu - 1)
        j0 = np.clip(np.floor((fv0 - lo_uv[1]) / s - 1).astype(int), 0, nv - 1)
        j1 = np.clip(np.ceil((fv1 - lo_uv[1]) / s).astype(int), 0, nv - 1)
        span_i, span_j = i1 - i0 + 1, j1 - j0 + 1
        total = span_i * span_j
        owner = np.repeat(np.arange(len(use)), total)
        local = np.arange(total.sum()) - np.repeat(np.cumsum(total) - total, total)
        si = i0[owner] + local // span_j[owner]
        sj = j0[owner] + local % span_j[owner]
        pu = lo_uv[0] + (si + 0.5) * s
        pv = lo_uv[1] + (sj + 0.5) * s
        tri = use[owner]
        reach = (0.5 * s) ** 2
        hit = np.zeros(len(owner), dtype=bool)
        is_flat = flat[tri]
        ft = np.flatnonzero(is_flat)
        if len(ft):
            t = tri[ft]
            x, y = pu[ft], pv[ft]
            d0 = (cu[t, 1] - cu[t, 0]) * (y - cv[t, 0]) - (cv[t, 1] - cv[t, 0]) * (x - cu[t, 0])
            d1 = (cu[t, 2] - cu[t, 1]) * (y - cv[t, 1]) - (cv[t, 2] - cv[t, 1]) * (x - cu[t, 1])
            d2 = (cu[t, 0] - cu[t, 2]) * (y - cv[t, 2]) - (cv[t, 0] - cv[t, 2]) * (x - cu[t, 2])
            inside = ((d0 >= 0) & (d1 >= 0) & (d2 >= 0)) | ((d0 <= 0) & (d1 <= 0) & (d2 <= 0))
            dist = np.minimum.reduce([_point_segment_sq(x, y, cu[t, a], cv[t, a], cu[t, b], cv[t, b])
                                      for a, b in ((0, 1), (1, 2), (2, 0))])
            hit[ft] = inside | (dist <= reach)
        st = np.flatnonzero(~is_flat)
        if len(st):
            t = tri[st]
            hit[st] = _point_segment_sq(pu[st], pv[st], seg[t, 0, 0], seg[t, 0, 1],
                                        seg[t, 1, 0], seg[t, 1, 1]) <= reach
        covered[(si * nv + sj)[hit]] = True
    labels = _components(~covered.reshape(nu, nv))
    found = np.unique(labels[labels >= 0])
    if not len(found):
        return np.zeros((0, 2, 2))
    li, lj = np.nonzero(labels >= 0)
    lab = np.searchsorted(found, labels[li, lj])
    lo_i = np.full(len(found), nu)
    hi_i = np.full(len(found), -1)
    lo_j, hi_j = lo_i.copy(), hi_i.copy()
    np.minimum.at(lo_i, lab, li)
    np.maximum.at(hi_i, lab, li)
    np.minimum.at(lo_j, lab, lj)
    np.maximum.at(hi_j, lab, lj)
    lo = np.stack([lo_uv[0] + (lo_i - 1) * s, lo_uv[1] + (lo_j - 1) * s], axis=1)
    hi = np.stack([lo_uv[0] + (hi_i + 2) * s, lo_uv[1] + (hi_j + 2) * s], axis=1)
    return np.stack([np.maximum(lo, lo_uv), np.minimum(hi, hi_uv)], axis=1)


def find_portals(world, edges, thickness, samples=FACE_SAMPLES):
    """Portals between face-adjacent cells of the grid `edges`.

    returns : portal_cells (P, 2) int32 (low cell, high cell along the face axis),
              portal_start (P + 1,) int64, portal_vertices (4P, 3) float64 rectangles wound
              so their right-hand normal points from portal_cells[:, 0] to portal_cells[:, 1]
    """
    shape = [len(e) - 1 for e in edges]
    cells, polys = [], []
    for axis in range(3):
        u_axis, v_axis = (axis + 1) % 3, (axis + 2) % 3
        for b in range(1, shape[axis]):
            for iu in range(shape[u_axis]):
                for iv in range(shape[v_axis]):
                    lo_uv = np.array([edges[u_axis][iu], edges[v_axis][iv]])
                    hi_uv = np.array([edges[u_axis][iu + 1], edges[v_axis][iv + 1]])
                    rects = face_openings(world, axis, edges[axis][b], lo_uv, hi_uv,
                                          thickness, samples)
                    if not len(rects):
                        continue
                    idx = [0, 0, 0]
                    idx[u_axis], idx[v_axis], idx[axis] = iu, iv, b - 1
                    low = np.ravel_multi_index(idx, shape)
                    idx[axis] = b
                    high = np.ravel_multi_index(idx, shape)
                    for r in rects:
                        quad = np.zeros((4, 3))
                        quad[:, axis] = edges[axis][b]
                        quad[:, u_axis] = [r[0, 0], r[1, 0], r[1, 0], r[0, 0]]
                        quad[:, v_axis] = [r[0, 1], r[0, 1], r[1, 1], r[1, 1]]
                        cells.append((low, high))
                        polys.append(quad)
    count = len(cells)
    portal_cells = np.array(cells, dtype=np.int32).reshape(count, 2)
    vertices = np.concatenate(polys) if polys else np.zeros((0, 3))
    return portal_cells, np.arange(0, 4 * count + 1, 4, dtype=np.int64), vertices


def build(world, depth=2, slabs=None, auto=False, cells=None, thickness=None,
          samples=FACE_SAMPLES, progress=None):
    """Portal octree: root -> every grid cell (level 1, empty ones too) -> each cell's octree.

    depth     : octree depth inside each cell, 1..3
    slabs     : explicit cells as in grid.build; otherwise automatic, about `cells` cells
                (default sqrt(T) / 2, 8..256) snapped to wall planes
    thickness : distance from a face plane within which a parallel triangle blocks the face
                (default THICKNESS x the world's size)
    returns   : Partition with extras octant (N,) int8 (-1 above the cell octrees), cell_node (C,) int32, cell_bounds (C, 2, 3) float64,
                portal_cells, portal_start, portal_vertices (find_portals), cell_portal_start
                (C + 1,) int64 and cell_portals (2P,) int32 (CSR cell -> portal ids), grid_x/y/z
    """
    depth = check_depth(depth, 1, 3, "portal octree depth")
    if slabs is None:
        target = int(np.clip(round(np.sqrt(world.triangle_count) / 2), 8, 256)) if cells is None else int(cells)
        edges = auto_edges(world, target)
    else:
        edges = grid.resolve_edges(world, slabs, auto, cells)
    size = float(np.ptp(world.extent, axis=0).max())
    thickness = THICKNESS * size if thickness is None else float(thickness)
    cell, tri = grid.cell_pairs(world, edges)
    boxes = grid.cell_boxes(edges)
    count = len(boxes)
    levels, (last_node, last_tri) = subdivide(world, boxes, cell, tri, depth)
    root = world.extent[None].astype(np.float64)
    parent, region, starts = chain_levels([root, boxes] + [b for b, _, _ in levels],
                                          [np.array([-1]), np.zeros(count, dtype=np.int64)]
                                          + [p for _, p, _ in levels])
    octant = np.concatenate([np.full(count + 1, -1)] + [o for _, _, o in levels]).astype(np.int8)
    if progress is not None:
        progress(1, 2)
    portal_cells, portal_start, portal_vertices = find_portals(world, edges, thickness, samples)
    if progress is not None:
        progress(2, 2)
    ends = np.concatenate([portal_cells[:, 0], portal_cells[:, 1]]).astype(np.int64)
    ids = np.tile(np.arange(len(portal_cells)), 2)
    order = np.lexsort((ids, ends))
    cell_portal_start = np.concatenate([[0], np.cumsum(np.bincount(ends, minlength=count))])
    params = {"depth": depth, "auto": slabs is None, "slabs": [len(e) - 1 for e in edges],
              "thickness": thickness, "samples": int(samples)}
    result, flat = make_partition(
        "portal", params, world, parent, last_node + starts[-1], last_tri, region,
        node_extras={"octant": octant},
        extras={"portal_cells": portal_cells, "portal_start": portal_start,
                "portal_vertices": portal_vertices,
                "cell_portal_start": cell_portal_start.astype(np.int64),
                "cell_portals": ids[order].astype(np.int32),
                **{f"grid_{grid.AXES[a]}": np.asarray(edges[a], dtype=np.float64) for a in range(3)}})
    result.extras["cell_node"] = flat["new_of_old"][1:count + 1].astype(np.int32)
    result.extras["cell_bounds"] = result.node_bounds[result.extras["cell_node"]].copy()
    return result

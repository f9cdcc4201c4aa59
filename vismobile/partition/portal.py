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


def plane_footprints(corners, axis, plane, thickness):
    """What each triangle leaves on the plane x[axis] = plane, in the (axis + 1, axis + 2) coords.

    corners   : (n, 3, 3) float64
    returns   : cu, cv (n, 3) float64 corner coordinates on the plane; flat (n,) bool (all
                corners within thickness of the plane: the triangle lies in it); crossing (n,)
                bool (corners strictly on both sides); seg (n, 2, 2) float64 [[u0, v0], [u1, v1]]
                the exact segment where a crossing triangle cuts the plane (zeros elsewhere);
                box (n, 2, 2) float64 [[u0, v0], [u1, v1]] bounds of the footprint (triangle or
                segment)
    """
    u_axis, v_axis = (axis + 1) % 3, (axis + 2) % 3
    h = corners[:, :, axis] - plane
    cu, cv = corners[:, :, u_axis], corners[:, :, v_axis]
    flat = (np.abs(h) <= thickness).all(axis=1)
    crossing = ~flat & (h.min(axis=1) < 0) & (h.max(axis=1) > 0)
    # Where each edge (0,1), (1,2), (2,0) meets h = 0; the cut is the longest pair of them.
    hb, ub, vb = (np.roll(x, -1, axis=1) for x in (h, cu, cv))
    meets = (np.minimum(h, hb) <= 0) & (np.maximum(h, hb) >= 0) & (h != hb)
    w = np.where(meets, h / np.where(h != hb, h - hb, 1.0), 0.0)
    pu, pv = cu + w * (ub - cu), cv + w * (vb - cv)
    pair_a, pair_b = np.array([0, 1, 2]), np.array([1, 2, 0])
    gap = (pu[:, pair_a] - pu[:, pair_b]) ** 2 + (pv[:, pair_a] - pv[:, pair_b]) ** 2
    gap = np.where(meets[:, pair_a] & meets[:, pair_b], gap, -1.0)
    best = np.argmax(gap, axis=1)
    rows = np.arange(len(h))
    a, b = pair_a[best], pair_b[best]
    seg = np.stack([np.stack([pu[rows, a], pv[rows, a]], axis=1),
                    np.stack([pu[rows, b], pv[rows, b]], axis=1)], axis=1)
    seg = np.where(crossing[:, None, None], seg, 0.0)
    box = np.where(flat[:, None, None],
                   np.stack([np.stack([cu.min(axis=1), cv.min(axis=1)], axis=1),
                             np.stack([cu.max(axis=1), cv.max(axis=1)], axis=1)], axis=1),
                   np.stack([seg.min(axis=1), seg.max(axis=1)], axis=1))
    return cu, cv, flat, crossing, seg, box


def _covered(cu, cv, flat, seg, box, lo_uv, s, nu, nv):
    """(nu, nv) bool samples within s/2 of a footprint (a flat triangle or a crossing segment).

    All footprints at once: each one's sample rectangle (its box grown by s/2) is enumerated
    with repeat/arange, every sample tested exactly, hits scattered into the mask.
    """
    covered = np.zeros(nu * nv, dtype=bool)
    if not len(flat):
        return covered.reshape(nu, nv)
    i0 = np.clip(np.floor((box[:, 0, 0] - lo_uv[0]) / s - 1).astype(np.int64), 0, nu - 1)
    i1 = np.clip(np.ceil((box[:, 1, 0] - lo_uv[0]) / s).astype(np.int64), 0, nu - 1)
    j0 = np.clip(np.floor((box[:, 0, 1] - lo_uv[1]) / s - 1).astype(np.int64), 0, nv - 1)
    j1 = np.clip(np.ceil((box[:, 1, 1] - lo_uv[1]) / s).astype(np.int64), 0, nv - 1)
    span_j = j1 - j0 + 1
    total = (i1 - i0 + 1) * span_j
    tri = np.repeat(np.arange(len(flat)), total)
    local = np.arange(int(total.sum())) - np.repeat(np.cumsum(total) - total, total)
    si = i0[tri] + local // span_j[tri]
    sj = j0[tri] + local % span_j[tri]
    pu = lo_uv[0] + (si + 0.5) * s
    pv = lo_uv[1] + (sj + 0.5) * s
    reach = (0.5 * s) ** 2
    hit = np.zeros(len(tri), dtype=bool)
    is_flat = flat[tri]
    ft = np.flatnonzero(is_flat)
    if len(ft):
        t = tri[ft]
        x, y = pu[ft], pv[ft]
        u, v = cu[t], cv[t]
        d = [(u[:, b] - u[:, a]) * (y - v[:, a]) - (v[:, b] - v[:, a]) * (x - u[:, a])
             for a, b in ((0, 1), (1, 2), (2, 0))]
        inside = (((d[0] >= 0) & (d[1] >= 0) & (d[2] >= 0))
                  | ((d[0] <= 0) & (d[1] <= 0) & (d[2] <= 0)))
        dist = np.minimum.reduce([_point_segment_sq(x, y, u[:, a], v[:, a], u[:, b], v[:, b])
                                  for a, b in ((0, 1), (1, 2), (2, 0))])
        hit[ft] = inside | (dist <= reach)
    st = np.flatnonzero(~is_flat)
    if len(st):
        t = tri[st]
        hit[st] = _point_segment_sq(pu[st], pv[st], seg[t, 0, 0], seg[t, 0, 1],
                                    seg[t, 1, 0], seg[t, 1, 1]) <= reach
    covered[(si * nv + sj)[hit]] = True
    return covered.reshape(nu, nv)


def _open_rectangles(covered, lo_uv, hi_uv, s):
    """(Q, 2, 2) float64 boxes of the 4-connected open regions of a coverage mask, each grown by
    one sample spacing and clipped to the face."""
    nu, nv = covered.shape
    labels = _components(~covered)
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


def _face_grid(lo_uv, hi_uv, samples):
    """Sample spacing s and sample counts (nu, nv) of a face: `samples` along its longer side."""
    size = hi_uv - lo_uv
    s = max(float(size.max()) / samples, 1e-300)
    nu, nv = (np.maximum(1, np.ceil(size / s - 1e-9)).astype(int))
    return s, int(nu), int(nv)


def _openings(footprints, lo_uv, hi_uv, samples):
    """face_openings for footprints (plane_footprints) of the triangles touching the plane."""
    cu, cv, flat, crossing, seg, box = footprints
    s, nu, nv = _face_grid(lo_uv, hi_uv, samples)
    use = np.flatnonzero((flat | crossing)
                         & (box[:, 0, 0] <= hi_uv[0] + s) & (box[:, 1, 0] >= lo_uv[0] - s)
                         & (box[:, 0, 1] <= hi_uv[1] + s) & (box[:, 1, 1] >= lo_uv[1] - s))
    covered = _covered(cu[use], cv[use], flat[use], seg[use], box[use], lo_uv, s, nu, nv)
    return _open_rectangles(covered, lo_uv, hi_uv, s)


def _touching(world, axis, plane, thickness):
    """(n,) int64 ids of triangles whose AABB reaches within thickness of x[axis] = plane."""
    tb = world.bounds
    return np.flatnonzero((tb[:, 0, axis] <= plane + thickness) & (tb[:, 1, axis] >= plane - thickness))


def face_openings(world, axis, plane, lo_uv, hi_uv, thickness, samples=FACE_SAMPLES):
    """Open rectangles of one shared face: (Q, 2, 2) float64 [[u0, v0], [u1, v1]] in the face's
    (axis + 1, axis + 2) coordinates.

    Errs large: each rectangle is an open region's sample box grown by one sample spacing s
    (openings narrower than about s are missed). A sample is covered when it lies within s/2 of
    a triangle lying in the plane (within `thickness`) or of the line where a triangle crosses it.
    """
    lo_uv, hi_uv = np.asarray(lo_uv, dtype=np.float64), np.asarray(hi_uv, dtype=np.float64)
    near = _touching(world, axis, plane, thickness)
    footprints = plane_footprints(world.vertices[world.triangles[near]], axis, plane, thickness)
    return _openings(footprints, lo_uv, hi_uv, samples)


def find_portals(world, edges, thickness, samples=FACE_SAMPLES):
    """Portals between face-adjacent cells of the grid `edges`.

    Footprints are computed once per interior grid plane; the faces of that plane (a loop over
    cell faces, tens to a few hundred) each rasterise only the footprints reaching them.
    returns : portal_cells (P, 2) int32 (low cell, high cell along the face axis),
              portal_start (P + 1,) int64, portal_vertices (4P, 3) float64 rectangles wound
              so their right-hand normal points from portal_cells[:, 0] to portal_cells[:, 1]
    """
    shape = [len(e) - 1 for e in edges]
    cells, polys = [], []
    for axis in range(3):
        u_axis, v_axis = (axis + 1) % 3, (axis + 2) % 3
        for b in range(1, shape[axis]):
            plane = edges[axis][b]
            near = _touching(world, axis, plane, thickness)
            footprints = plane_footprints(world.vertices[world.triangles[near]], axis, plane,
                                          thickness)
            for iu in range(shape[u_axis]):
                for iv in range(shape[v_axis]):
                    lo_uv = np.array([edges[u_axis][iu], edges[v_axis][iv]], dtype=np.float64)
                    hi_uv = np.array([edges[u_axis][iu + 1], edges[v_axis][iv + 1]],
                                     dtype=np.float64)
                    rects = _openings(footprints, lo_uv, hi_uv, samples)
                    if not len(rects):
                        continue
                    idx = [0, 0, 0]
                    idx[u_axis], idx[v_axis], idx[axis] = iu, iv, b - 1
                    low = np.ravel_multi_index(idx, shape)
                    idx[axis] = b
                    high = np.ravel_multi_index(idx, shape)
                    quads = np.zeros((len(rects), 4, 3))
                    quads[:, :, axis] = plane
                    quads[:, :, u_axis] = rects[:, [0, 1, 1, 0], 0]
                    quads[:, :, v_axis] = rects[:, [0, 0, 1, 1], 1]
                    cells.extend([(low, high)] * len(rects))
                    polys.append(quads.reshape(-1, 3))
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

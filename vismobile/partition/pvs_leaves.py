"""The BSP tree's leaves as the PVS's view cells (the thesis's request: a PVS for the BSP tree).

A leaf's region is the world's box cut by the half-spaces of the split planes on its path
(first child: n.x + d >= 0, as bsp.front_to_back reads them), a convex polytope. Its set is
the union of the sets of the PVS's own view cells (pvs_cells.view_grid, baked as usual) that
the region, grown by `pad`, may touch: a grid cell is left out only when its box lies wholly
outside the grown leaf's bounding box, or wholly on the far side of one path plane by more
than `pad`. The leaf's stored view cell is the grown bounding box of its region, grown on to
a lattice of LATTICE x the world's largest side (on_lattice: few distinct coordinates) within
the world's box grown by `pad`.

Contract (conservative, inherits the grid bake's): every eye within `pad` of a leaf's region
lies within `pad` of some grid cell the leaf takes, so the leaf's set holds what that eye may
see. The regions tile the world's box, so an eye inside it is inside some leaf's stored box,
and the `pvs` stage's union over every stored box holding the eye (grown by its reach)
includes the set of the leaf whose region holds it: looser boxes only add triangles.
"""
from __future__ import annotations

import numpy as np

LATTICE = 2.0 ** -10  # the stored boxes' lattice step, a share of the world's largest side


def box_faces(low, high) -> list:
    """The 6 faces of a box as (4, 3) float64 vertex loops."""
    c = np.array([[low[0], low[1], low[2]], [high[0], low[1], low[2]],
                  [high[0], high[1], low[2]], [low[0], high[1], low[2]],
                  [low[0], low[1], high[2]], [high[0], low[1], high[2]],
                  [high[0], high[1], high[2]], [low[0], high[1], high[2]]], dtype=np.float64)
    loops = ((0, 1, 2, 3), (4, 5, 6, 7), (0, 1, 5, 4), (3, 2, 6, 7), (0, 3, 7, 4), (1, 2, 6, 5))
    return [c[list(loop)] for loop in loops]


def clip(faces, plane, eps) -> list:
    """The faces of a convex polytope (list of (k, 3) loops) cut to n.x + d >= -eps, with the
    cap face on the plane; [] when nothing is left."""
    n, d = np.asarray(plane[:3], dtype=np.float64), float(plane[3])
    out, cap = [], []
    for face in faces:
        s = face @ n + d
        keep = s >= -eps
        if keep.all():
            out.append(face)
            continue
        if not keep.any():
            continue
        loop = []
        for i in range(len(face)):
            j = (i + 1) % len(face)
            if keep[i]:
                loop.append(face[i])
            if keep[i] != keep[j]:
                t = s[i] / (s[i] - s[j])
                point = face[i] + t * (face[j] - face[i])
                loop.append(point)
                cap.append(point)
        if len(loop) >= 3:
            out.append(np.array(loop))
    if len(cap) >= 3:
        cap = np.unique(np.round(np.array(cap), 12), axis=0)
        if len(cap) >= 3:
            centre = cap.mean(axis=0)
            u = cap[0] - centre
            u /= max(np.linalg.norm(u), 1e-300)
            v = np.cross(n, u)
            angles = np.arctan2((cap - centre) @ v, (cap - centre) @ u)
            out.append(cap[np.argsort(angles)])
    return out


def leaf_regions(partition) -> tuple:
    """(leaves (L,) int64 leaf node ids, boxes (L, 2, 3) float64 bounding boxes of their
    regions, paths: list of L (k, 4) arrays, each leaf's half-spaces as n.x + d >= 0).
    Leaves whose region is empty (a split plane missing the parent's region) are left out."""
    planes = np.asarray(partition.extras["split_planes"], dtype=np.float64)
    first, count = partition.first_child, partition.child_count
    low, high = (np.asarray(a, dtype=np.float64) for a in partition.world.extent)
    eps = 1e-9 * float(np.ptp([low, high], axis=0).max())
    stack = [(0, box_faces(low, high), np.zeros((0, 4)))]
    leaves, boxes, paths = [], [], []
    while stack:
        node, faces, path = stack.pop()
        if count[node] == 0:
            points = np.concatenate(faces)
            leaves.append(node)
            boxes.append([points.min(axis=0), points.max(axis=0)])
            paths.append(path)
            continue
        plane = planes[node]
        for child, signed in ((first[node], plane), (first[node] + 1, -plane)):
            cut = clip(faces, signed, eps)
            if cut:
                stack.append((int(child), cut, np.vstack([path, signed[None]])))
    order = np.argsort(leaves)
    return (np.asarray(leaves, dtype=np.int64)[order],
            np.asarray(boxes, dtype=np.float64).reshape(-1, 2, 3)[order],
            [paths[i] for i in order])


def leaf_sets(partition, cell_boxes, masks, pad) -> tuple:
    """(boxes (L, 2, 3) the leaves' stored view cells, sets: list of L (T,) bool) from the
    grid cells' boxes (C, 2, 3) and sets (C masks), per the module docstring; pad covers the
    grid bake's growth and tolerance."""
    _, boxes, paths = leaf_regions(partition)
    boxes = boxes + np.array([-pad, pad])[None, :, None]
    lo, hi = cell_boxes[:, 0], cell_boxes[:, 1]
    packed = np.packbits(np.asarray(masks, dtype=bool), axis=1)  # (C, T / 8): ORed 8 at a time
    triangles = len(masks[0])
    sets = []
    for box, path in zip(boxes, paths):
        near = ((lo <= box[1]) & (hi >= box[0])).all(axis=1)
        for plane in path:  # a grid box wholly behind a path plane (its nearest corner too)
            n, d = plane[:3], plane[3]
            best = np.where(n > 0, hi, lo) @ n + d  # the box's corner farthest along n
            near &= best >= -pad * np.abs(n).sum()
        union = np.bitwise_or.reduce(packed[near], axis=0) if near.any() else packed[0] * 0
        sets.append(np.unpackbits(union, count=triangles).astype(bool))
    extent = np.asarray(partition.world.extent, dtype=np.float64)
    step = LATTICE * float(np.ptp(extent, axis=0).max())
    # never past the world's box grown by pad: an eye beyond it is in no leaf's region's reach
    lattice = on_lattice(boxes, extent[0], step)
    return np.clip(lattice, extent[0] - pad, extent[1] + pad), sets


def on_lattice(boxes, origin, step) -> np.ndarray:
    """(L, 2, 3) float64 each box grown outward to the lattice origin + k x step (lo down, hi
    up; never inside the box given, whatever the rounding). The stored boxes then share few
    coordinates (pvs_codec codes each distinct one once: W4's 4,560 leaves' exact boxes took
    0.365x the OBJ in the two PVS sections), and looser boxes only add triangles (module
    docstring)."""
    boxes = np.asarray(boxes, dtype=np.float64)
    lo = origin + np.floor((boxes[:, 0] - origin) / step) * step
    hi = origin + np.ceil((boxes[:, 1] - origin) / step) * step
    lo = np.where(lo > boxes[:, 0], lo - step, lo)  # rounding past the box: one step more
    hi = np.where(hi < boxes[:, 1], hi + step, hi)
    return np.stack([lo, hi], axis=1)

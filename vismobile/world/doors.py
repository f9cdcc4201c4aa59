"""Doors (issue 25): which moving objects are doors, and which portals lie inside them.

A door is a moving object named DOOR_PREFIX... whose rest-pose triangles are a closed,
outward-wound box (its closed pose; the motion turns it about its hinge). find_doors picks them
out of an animated world; a `door_*` object that is not such a box is not a door (it never
blocks). door_pairs lists the (portal, door) pairs whose portal polygon lies inside the door's
box, with how deep. The `portals` stage (culling/doors.py) and the PVS bake (partition/pvs.py)
both use them; what a shut door blocks, and when, is culling/doors.py's.
"""
from __future__ import annotations

import numpy as np

DOOR_PREFIX = "door_"
CLOSED = 1e-9  # largest |M - I| entry of a closed door's matrix
BOX_TOLERANCE = 1e-9  # relative: vertices within this of a box corner are on it


def is_box(corners) -> np.ndarray | None:
    """(2, 3) float64 box whose closed outward surface the triangles (n, 3, 3) are, or None.

    The test: every vertex is a corner of the triangles' bounding box, their total area is the
    box's surface area, and their signed volume is the box's volume (closed, wound outward).
    """
    corners = np.asarray(corners, dtype=np.float64)
    if len(corners) < 12:
        return None
    lo, hi = corners.reshape(-1, 3).min(axis=0), corners.reshape(-1, 3).max(axis=0)
    size = hi - lo
    tol = BOX_TOLERANCE * max(float(np.abs(corners).max()), 1.0)
    if (size <= tol).any():
        return None
    points = corners.reshape(-1, 3)
    on_corner = ((np.abs(points - lo) <= tol) | (np.abs(points - hi) <= tol)).all(axis=1)
    if not on_corner.all():
        return None
    cross = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    area = 0.5 * np.linalg.norm(cross, axis=1).sum()
    surface = 2.0 * (size[0] * size[1] + size[1] * size[2] + size[0] * size[2])
    volume = np.einsum("ij,ij->", corners[:, 0] - lo, cross) / 6.0
    if abs(area - surface) > 1e-6 * surface or abs(volume - np.prod(size)) > 1e-6 * np.prod(size):
        return None
    return np.stack([lo, hi])


def find_doors(names, object_ids, corners, moving_ids, prefix: str = DOOR_PREFIX) -> tuple:
    """The doors among the moving objects: (rows (D,) int64 positions in moving_ids, boxes
    (D, 2, 3) float64 closed boxes at rest).

    names : object names;  object_ids (T,) per triangle;  corners (T, 3, 3) at rest;
    moving_ids : (M,) object ids that move (the motion's track order)
    """
    rows, boxes = [], []
    for row, object_id in enumerate(np.asarray(moving_ids, dtype=np.int64)):
        if not str(names[object_id]).startswith(prefix):
            continue
        box = is_box(corners[object_ids == object_id])
        if box is not None:
            rows.append(row)
            boxes.append(box)
    return np.array(rows, dtype=np.int64), np.array(boxes, dtype=np.float64).reshape(-1, 2, 3)


def door_pairs(portal_vertices, portal_start, boxes) -> tuple:
    """(portal ids (K,) int64, door ids (K,) int64, depth (K,) float64) for the portals whose
    every vertex lies strictly inside a door's box; depth is the smallest distance from one of
    its vertices to that box's faces (> 0)."""
    vertices = np.asarray(portal_vertices, dtype=np.float64)
    starts = np.asarray(portal_start, dtype=np.int64)
    boxes = np.asarray(boxes, dtype=np.float64).reshape(-1, 2, 3)
    portals, doors, depths = [], [], []
    if len(starts) < 2 or not len(boxes):
        empty = np.zeros(0, dtype=np.int64)
        return empty, empty.copy(), np.zeros(0)
    lows = np.minimum.reduceat(vertices, starts[:-1], axis=0)  # (P, 3) polygon bounds
    highs = np.maximum.reduceat(vertices, starts[:-1], axis=0)
    for d, (lo, hi) in enumerate(boxes):
        depth = np.minimum((lows - lo).min(axis=1), (hi - highs).min(axis=1))
        inside = np.flatnonzero(depth > 0)
        portals.append(inside)
        doors.append(np.full(len(inside), d, dtype=np.int64))
        depths.append(depth[inside])
    return (np.concatenate(portals).astype(np.int64), np.concatenate(doors),
            np.concatenate(depths))

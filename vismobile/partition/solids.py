"""Closed solids facing out: the triangles whose inside no sight line from outside can reach.

A connected part (triangles joined by manifold edges, after merging coincident vertices as
winding.check_winding does) is a closed outward solid when every edge of it is shared by exactly
two of its triangles, every such pair runs along the edge in opposite directions as wound (so it
is consistently wound as stored, no reversal assumed) and its signed volume is positive (fronts
face out). A ray from a point outside such a part first meets it on a front face; so a point
whose nearest surface along a ray is a back face of one lies inside it, and every line from
outside to that point crosses its surface (drawn with or without back-face culling: the
crossing where the line enters is a front face). Nothing else about winding is assumed: an open
surface, or a closed part facing in or wound inconsistently, is no solid.
"""
from __future__ import annotations

import numpy as np

from ..world.winding import _merged, _orient


def outward_solid_faces(world) -> np.ndarray:
    """(T,) bool: the triangle belongs to a closed, consistently wound, outward-facing part."""
    return outward_solid_parts(world) >= 0


def outward_solid_parts(world) -> np.ndarray:
    """(T,) int64: the closed, consistently wound, outward-facing part each triangle belongs to
    (0, 1, ... in order of first triangle), -1 for triangles in no such part."""
    t = _merged(world)
    count = len(t)
    if not count:
        return np.zeros(0, dtype=np.int64)
    degenerate = (t[:, 0] == t[:, 1]) | (t[:, 1] == t[:, 2]) | (t[:, 2] == t[:, 0])
    directed = np.stack([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]], axis=1).reshape(-1, 2)
    edge_face = np.repeat(np.arange(count), 3)
    ends = np.sort(directed, axis=1)
    size = int(t.max()) + 1
    key = ends[:, 0] * size + ends[:, 1]
    order = np.argsort(key, kind="stable")
    key_sorted = key[order]
    starts = np.flatnonzero(np.r_[True, key_sorted[1:] != key_sorted[:-1]])
    uses = np.diff(np.r_[starts, len(key_sorted)])
    pairs = starts[uses == 2]
    a, b = order[pairs], order[pairs + 1]
    same = (directed[a, 0] == directed[b, 0]).astype(np.uint8)
    root, _, _ = _orient(count, edge_face[a], edge_face[b], same)
    _, label = np.unique(root, return_inverse=True)
    label = label.reshape(-1)
    parts = int(label.max()) + 1
    bad = np.zeros(parts, dtype=bool)
    bad[label[edge_face[order[np.repeat(uses != 2, uses)]]]] = True  # open or non-manifold
    bad[label[degenerate]] = True
    bad[label[edge_face[a][same == 1]]] = True  # wound inconsistently as stored
    low, high = world.extent
    corners = world.corners - (low + high) / 2
    volume = np.einsum("ij,ij->i", corners[:, 0], np.cross(corners[:, 1], corners[:, 2])) / 6
    signed = np.bincount(label, weights=volume, minlength=parts)
    good = ~bad & (signed > 0)
    number = np.where(good, np.cumsum(good) - 1, -1)
    return number[label].astype(np.int64)

"""Boxes, points and spheres against sets of planes (n, d), inside where n.x + d >= 0.

The box test is the p-vertex/n-vertex test: per plane, the box corner farthest along the
normal (p-vertex) decides "outside", the nearest one (n-vertex) decides "inside".
"""
from __future__ import annotations

import numpy as np

# Relative slack on signed distances: a box touching a plane to within this fraction of the
# coordinate scale is never called outside, so cameras on node boundaries stay safe.
RELATIVE_SLACK = 1e-9


def slack(*arrays) -> float:
    """Absolute distance slack for the coordinates in `arrays`: RELATIVE_SLACK times their scale."""
    scale = 1.0
    for a in arrays:
        if np.size(a):
            scale = max(scale, float(np.abs(a).max()))
    return RELATIVE_SLACK * scale


def box_plane_distances(boxes, planes) -> tuple:
    """Signed distances of each box's p-vertex and n-vertex to each plane.

    boxes  : (B, 2, 3) float64 min/max corners
    planes : (P, 4) float64 (n, d), or (B, P, 4) one plane set per box
    returns (p_dist, n_dist), each (B, P) float64; p_dist >= n_dist.
    Exact up to float64 rounding (a few ulps of |n||x| + |d|): callers add their own slack.
    """
    boxes = np.asarray(boxes, dtype=np.float64)
    planes = np.asarray(planes, dtype=np.float64)
    center = 0.5 * (boxes[:, 0] + boxes[:, 1])  # (B, 3)
    half = 0.5 * (boxes[:, 1] - boxes[:, 0])
    if planes.ndim == 2:
        mid = center @ planes[:, :3].T + planes[:, 3]  # (B, P)
        reach = half @ np.abs(planes[:, :3]).T
    else:
        mid = np.einsum("bj,bpj->bp", center, planes[..., :3]) + planes[..., 3]
        reach = np.einsum("bj,bpj->bp", half, np.abs(planes[..., :3]))
    return mid + reach, mid - reach


def classify_boxes(boxes, planes, tol: float = 0.0) -> tuple:
    """Box-vs-planes classes: (outside (B,) bool, inside (B, P) bool per plane).

    Errs toward straddling by `tol`: never reports a box outside unless its p-vertex is more
    than tol behind some plane (exact for true boxes otherwise).
    boxes  : (B, 2, 3) float64;  planes : (P, 4) or (B, P, 4) float64
    """
    p_dist, n_dist = box_plane_distances(boxes, planes)
    outside = (p_dist < -tol).any(axis=1)
    inside = n_dist >= tol
    return outside, inside


def points_inside(points, planes, tol: float = 0.0) -> np.ndarray:
    """(N,) bool: point is on the inner side of every plane, widened by tol (errs inside by tol).

    points : (N, 3) float64;  planes : (P, 4) float64
    """
    points = np.asarray(points, dtype=np.float64)
    return ((points @ planes[:, :3].T + planes[:, 3]) >= -tol).all(axis=1)


def spheres_outside(centers, radii, planes, tol: float = 0.0) -> np.ndarray:
    """(N,) bool: sphere lies more than its radius (+ tol) outside some plane; never true for a
    sphere that reaches the inner side (exact, errs toward keeping by tol).

    centers : (N, 3) float64;  radii : (N,) float64;  planes : (P, 4) float64
    """
    dist = np.asarray(centers, dtype=np.float64) @ planes[:, :3].T + planes[:, 3]
    return (dist < -(np.asarray(radii, dtype=np.float64)[:, None] + tol)).any(axis=1)


def planes_through_eye(eye, corner_dirs) -> np.ndarray:
    """(..., K, 4) float64 inward planes of convex pyramids with apex `eye` and edge directions
    `corner_dirs` (..., K, 3) in cyclic order (either winding); exact, no slack.
    """
    eye = np.asarray(eye, dtype=np.float64)
    dirs = np.asarray(corner_dirs, dtype=np.float64)
    normals = np.cross(dirs, np.roll(dirs, -1, axis=-2))
    normals /= np.linalg.norm(normals, axis=-1, keepdims=True)
    # Clockwise input: flip every plane of that pyramid inward.
    sign = np.sign(np.einsum("...j,...j->...", normals[..., 0, :], dirs.sum(axis=-2)))
    normals = normals * np.where(sign < 0, -1.0, 1.0)[..., None, None]
    return np.concatenate([normals, -(normals @ eye)[..., None]], axis=-1)

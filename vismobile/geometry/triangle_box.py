"""Triangle-box overlap by the separating axis theorem (Akenine-Moller, "Fast 3D Triangle-Box
Overlap Testing", JGT 2001): 13 axes, vectorised over many (triangle, box) pairs."""
from __future__ import annotations

import numpy as np

# Relative slack on every separating-axis comparison; keeps triangles that touch a box face.
EPS = 1e-9
# Pairs per vectorised batch: bounds peak memory near 100 MB.
CHUNK = 1 << 17


def triangles_overlap_boxes(corners, box_min, box_max, eps: float = EPS) -> np.ndarray:
    """Errs toward overlap: reports overlap when no axis separates by more than eps x (axis scale).

    corners : (K, 3, 3) float64 triangle corners, one triangle per pair
    box_min : (K, 3) float64 box low corners (or (3,), broadcast)
    box_max : (K, 3) float64 box high corners (or (3,), broadcast)
    eps     : relative slack; the axis scale is the box radius plus the largest projected
              coordinate (about the box centre) plus the centre's magnitude, along that axis
    returns : (K,) bool, True where triangle k meets closed box k (touching counts)
    """
    corners = np.asarray(corners, dtype=np.float64).reshape(-1, 3, 3)
    count = len(corners)
    box_min = np.broadcast_to(np.asarray(box_min, dtype=np.float64), (count, 3))
    box_max = np.broadcast_to(np.asarray(box_max, dtype=np.float64), (count, 3))
    out = np.empty(count, dtype=bool)
    for start in range(0, count, CHUNK):
        stop = min(start + CHUNK, count)
        out[start:stop] = _overlap(corners[start:stop], box_min[start:stop],
                                   box_max[start:stop], eps)
    return out


def _overlap(corners, box_min, box_max, eps):
    centre = (box_min + box_max) * 0.5
    half = (box_max - box_min) * 0.5
    v = corners - centre[:, None, :]  # (k, 3, 3) corners about the box centre
    offset = np.abs(centre)
    separated = np.zeros(len(v), dtype=bool)

    def axis_separates(p, r, axis_abs):
        # p (k, 3) projected corners, r (k,) projected box radius, axis_abs (k, 3) |axis|.
        slack = eps * (r + np.abs(p).max(axis=1) + (axis_abs * offset).sum(axis=1))
        return (p.min(axis=1) > r + slack) | (p.max(axis=1) < -r - slack)

    # The box's own normals: the AABB test.
    eye = np.eye(3)
    for j in range(3):
        separated |= axis_separates(v[:, :, j], half[:, j], np.broadcast_to(eye[j], half.shape))
    edges = (v[:, 1] - v[:, 0], v[:, 2] - v[:, 1], v[:, 0] - v[:, 2])
    # The triangle's plane.
    normal = np.cross(edges[0], -edges[2])
    normal_abs = np.abs(normal)
    separated |= axis_separates(np.einsum("kij,kj->ki", v, normal),
                                (half * normal_abs).sum(axis=1), normal_abs)
    x, y, z = v[:, :, 0], v[:, :, 1], v[:, :, 2]
    for e in edges:
        ex, ey, ez = e[:, 0:1], e[:, 1:2], e[:, 2:3]
        ax, ay, az = np.abs(e[:, 0]), np.abs(e[:, 1]), np.abs(e[:, 2])
        zero = np.zeros_like(ax)
        # e x (1,0,0) = (0, ez, -ey)
        separated |= axis_separates(y * ez - z * ey, half[:, 1] * az + half[:, 2] * ay,
                                    np.stack([zero, az, ay], axis=1))
        # e x (0,1,0) = (-ez, 0, ex)
        separated |= axis_separates(z * ex - x * ez, half[:, 0] * az + half[:, 2] * ax,
                                    np.stack([az, zero, ax], axis=1))
        # e x (0,0,1) = (ey, -ex, 0)
        separated |= axis_separates(x * ey - y * ex, half[:, 0] * ay + half[:, 1] * ax,
                                    np.stack([ay, ax, zero], axis=1))
    return ~separated

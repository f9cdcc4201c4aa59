"""Axis-aligned boxes (B, 2, 3) min/max: corners, centres, sizes, point containment, meshes."""
from __future__ import annotations

import numpy as np

# Corner k of a box takes max on axis a when bit a of k is set.
_CORNER_BITS = ((np.arange(8)[:, None] >> np.arange(3)) & 1).astype(bool)  # (8, 3)


def box_corners(boxes) -> np.ndarray:
    """(B, 8, 3) float64 corners of (B, 2, 3) boxes (exact)."""
    boxes = np.asarray(boxes, dtype=np.float64)
    return np.where(_CORNER_BITS[None], boxes[:, None, 1], boxes[:, None, 0])


# The six faces as corner quads, counter-clockwise seen from outside (_CORNER_BITS order).
_FACE_QUADS = ((0, 2, 6, 4), (1, 5, 7, 3), (0, 4, 5, 1), (2, 3, 7, 6), (0, 1, 3, 2), (4, 6, 7, 5))
_BOX_FACES = np.array([[q[0], q[1], q[2]] for q in _FACE_QUADS]
                      + [[q[0], q[2], q[3]] for q in _FACE_QUADS])  # (12, 3)


def box_mesh(boxes) -> tuple[np.ndarray, np.ndarray]:
    """(8B, 3) float64 vertices and (12B, 3) int64 triangles of (B, 2, 3) boxes: box b owns
    vertices 8b..8b+7 and triangles 12b..12b+11. Wound inward (signed volume -V; reverse the
    index columns for outward faces, as scenes.crowd does)."""
    vertices = box_corners(boxes).reshape(-1, 3)
    triangles = (_BOX_FACES[None] + 8 * np.arange(len(vertices) // 8)[:, None, None])
    return vertices, triangles.reshape(-1, 3)


def box_centers(boxes) -> np.ndarray:
    """(B, 3) float64 box centres."""
    boxes = np.asarray(boxes, dtype=np.float64)
    return 0.5 * (boxes[:, 0] + boxes[:, 1])


def box_sizes(boxes) -> np.ndarray:
    """(B, 3) float64 edge lengths (non-negative for valid boxes)."""
    boxes = np.asarray(boxes, dtype=np.float64)
    return boxes[:, 1] - boxes[:, 0]


def boxes_contain_point(boxes, point, tol: float = 0.0) -> np.ndarray:
    """(B,) bool: point within the closed box grown by tol on every side (errs inside by tol)."""
    boxes = np.asarray(boxes, dtype=np.float64)
    point = np.asarray(point, dtype=np.float64)
    return ((boxes[:, 0] - tol <= point) & (point <= boxes[:, 1] + tol)).all(axis=1)

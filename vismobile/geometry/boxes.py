"""Axis-aligned boxes (B, 2, 3) min/max: corners, centres, sizes, point containment."""
from __future__ import annotations

import numpy as np

# Corner k of a box takes max on axis a when bit a of k is set.
_CORNER_BITS = ((np.arange(8)[:, None] >> np.arange(3)) & 1).astype(bool)  # (8, 3)


def box_corners(boxes) -> np.ndarray:
    """(B, 8, 3) float64 corners of (B, 2, 3) boxes (exact)."""
    boxes = np.asarray(boxes, dtype=np.float64)
    return np.where(_CORNER_BITS[None], boxes[:, None, 1], boxes[:, None, 0])


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

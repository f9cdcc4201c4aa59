"""Camera-space projection (the occlusion stage's rasteriser is culling/hiz/raster.py).

Camera space here: x right, y up, z = depth along the view direction (positive in front).
"""
from __future__ import annotations

import numpy as np


def to_camera(points, eye, rotation) -> np.ndarray:
    """(..., 3) float64 camera-space coordinates of world points.

    points : (..., 3) float64;  eye : (3,);  rotation : (3, 3) rows right, up, forward
    """
    return (np.asarray(points, dtype=np.float64) - eye) @ np.asarray(rotation).T

"""Camera angles from directions (the camera, the sphere regions and the path makers share it)."""
from __future__ import annotations

import numpy as np


def yaw_toward(dx, dz):
    """Camera yaw in degrees, in (-180, 180], that looks along (dx, dz) on the ground plane."""
    return np.degrees(np.arctan2(-np.asarray(dx, dtype=np.float64),
                                 -np.asarray(dz, dtype=np.float64)))

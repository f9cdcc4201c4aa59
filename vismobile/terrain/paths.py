"""Camera paths over a terrain (seed 000, Pires 2003): circle and lemniscate, slow and fast.

Speeds are Pires's for a 1025^2 map with unit spacing (circle 0.1 / 1.0 units per frame,
lemniscate 0.22 / 2.2 on average), scaled with the map's width so a lap takes the same number of
frames on every size. The eye is `eye_height` spacings above the full-resolution ground.
"""
from __future__ import annotations

import numpy as np

from ..camera import Camera

SPEEDS = {("circle", "slow"): 0.1, ("circle", "fast"): 1.0,
          ("lemniscate", "slow"): 0.22, ("lemniscate", "fast"): 2.2}
REFERENCE_WIDTH = 1024.0


def _yaw(dx, dz) -> np.ndarray:
    """Yaw in degrees that looks along (dx, dz) (camera yaw 0 looks toward -z)."""
    return np.degrees(np.arctan2(-dx, -dz))


def path_cameras(heightmap, kind: str = "circle", speed: str = "fast", frames: int = 100,
                 start: int = 0, eye_height: float = 1.0, pitch: float = -10.0,
                 fov: float | None = None, aspect: float = 240 / 320, far: float | None = None,
                 every: int = 1) -> list:
    """Cameras of frames start, start + every, ... (frames of them) along one path.

    circle: radius 0.4 of the width around the centre, looking at the centre.
    lemniscate: a figure of eight (half-width 0.45 of the map) through the centre, looking
    along the direction of travel; speed varies along it as in Pires's runs.
    fov is vertical; by default it gives the digest's 60 degrees horizontally.
    """
    if fov is None:
        fov = float(np.degrees(2 * np.arctan(np.tan(np.radians(30.0)) / aspect)))
    if (kind, speed) not in SPEEDS:
        raise ValueError(f"unknown path {kind}/{speed}; kinds circle, lemniscate; speeds slow, fast")
    width = heightmap.extent
    # World units per frame: Pires's speed in spacings, scaled by the width in samples.
    step = SPEEDS[(kind, speed)] * (heightmap.size - 1) / REFERENCE_WIDTH * heightmap.spacing
    centre = np.array([width / 2, width / 2])
    index = start + every * np.arange(frames)
    if kind == "circle":
        radius = 0.4 * width
        angle = index * step / radius
        x = centre[0] + radius * np.cos(angle)
        z = centre[1] + radius * np.sin(angle)
        yaw = _yaw(centre[0] - x, centre[1] - z)
    else:
        a = 0.45 * width
        # Lemniscate of Bernoulli: a lap (t over 2 pi) is 5.244 a long, so the mean speed is
        # the path's step; the actual speed varies along the curve.
        t = index * step * 2 * np.pi / (5.244 * a)
        denominator = 1 + np.sin(t) ** 2
        x = centre[0] + a * np.cos(t) / denominator
        z = centre[1] + a * np.sin(t) * np.cos(t) / denominator
        dt = 1e-4
        d2 = 1 + np.sin(t + dt) ** 2
        dx = centre[0] + a * np.cos(t + dt) / d2 - x
        dz = centre[1] + a * np.sin(t + dt) * np.cos(t + dt) / d2 - z
        yaw = _yaw(dx, dz)
    y = heightmap.height_at(x, z) + eye_height * heightmap.spacing
    far = far if far is not None else 1.5 * width
    near = max(0.05 * heightmap.spacing, far * 1e-5)
    return [Camera((px, py, pz), yaw=float(w), pitch=pitch, fov=fov, aspect=aspect, near=near,
                   far=far) for px, py, pz, w in zip(x, y, z, yaw)]

"""Camera paths over a terrain (seed 000, Pires 2003): circle and lemniscate, slow and fast.

Speeds are Pires's for a 1025^2 map with unit spacing (circle 0.1 / 1.0 units per frame,
lemniscate 0.22 / 2.2 on average), scaled with the map's width so a lap takes the same number of
frames on every size. The eye is `eye_height` spacings above the full-resolution ground.
"""
from __future__ import annotations

import numpy as np

from ..world.camera import Camera, yaw_toward

SPEEDS = {("circle", "slow"): 0.1, ("circle", "fast"): 1.0,
          ("lemniscate", "slow"): 0.22, ("lemniscate", "fast"): 2.2,
          ("valley", "slow"): 0.1, ("valley", "fast"): 1.0}
REFERENCE_WIDTH = 1024.0


def valley_polyline(heightmap, points: int = 64) -> np.ndarray:
    """(points, 2) world (x, z) of a path along low ground across the map, west to east.

    For each of `points` columns between 10% and 90% of the width, the row of the lowest
    smoothed ground between 20% and 80%; the rows are then smoothed along the path.
    """
    h = heightmap.heights.astype(np.float64)
    step = max(1, (heightmap.size - 1) // 128)
    coarse = h[::step, ::step]
    for _ in range(4):  # a few 3x3 box blurs: valleys, not single pits
        padded = np.pad(coarse, 1, mode="edge")
        coarse = sum(padded[1 + di:padded.shape[0] - 1 + di, 1 + dj:padded.shape[1] - 1 + dj]
                     for di in (-1, 0, 1) for dj in (-1, 0, 1)) / 9.0
    m = coarse.shape[0]
    cols = np.linspace(0.1 * (m - 1), 0.9 * (m - 1), points).round().astype(int)
    lo, hi = int(0.2 * (m - 1)), int(0.8 * (m - 1))
    rows = lo + np.argmin(coarse[lo:hi + 1, cols], axis=0).astype(np.float64)
    kernel = np.ones(9) / 9.0
    rows = np.convolve(np.pad(rows, 4, mode="edge"), kernel, mode="valid")
    scale = step * heightmap.spacing
    return np.stack([cols * scale, rows * scale], axis=1)


def lap_frames(heightmap, kind: str = "circle", speed: str = "fast") -> int:
    """Frames of one lap of the path (the valley path: there and back)."""
    if (kind, speed) not in SPEEDS:
        raise ValueError(f"unknown path {kind}/{speed}; kinds circle, lemniscate, valley; "
                         "speeds slow, fast")
    width = heightmap.extent
    step = SPEEDS[(kind, speed)] * (heightmap.size - 1) / REFERENCE_WIDTH * heightmap.spacing
    if kind == "circle":
        length = 2 * np.pi * 0.4 * width
    elif kind == "lemniscate":
        length = 5.244 * 0.45 * width
    else:
        line = valley_polyline(heightmap)
        length = 2 * float(np.linalg.norm(np.diff(line, axis=0), axis=1).sum())
    return max(1, int(round(length / step)))


def path_cameras(heightmap, kind: str = "circle", speed: str = "fast", frames: int = 100,
                 start: int = 0, eye_height: float = 1.0, pitch: float = -10.0,
                 fov: float | None = None, aspect: float = 240 / 320, far: float | None = None,
                 every: int = 1) -> list:
    """Cameras of frames start, start + every, ... (frames of them) along one path.

    circle: radius 0.4 of the width around the centre, looking at the centre.
    lemniscate: a figure of eight (half-width 0.45 of the map) through the centre, looking
    along the direction of travel; speed varies along it as in Pires's runs.
    valley: along valley_polyline and back, looking ahead (the horizon test's path).
    fov is vertical; by default it gives the digest's 60 degrees horizontally.
    """
    if fov is None:
        fov = float(np.degrees(2 * np.arctan(np.tan(np.radians(30.0)) / aspect)))
    if (kind, speed) not in SPEEDS:
        raise ValueError(f"unknown path {kind}/{speed}; kinds circle, lemniscate, valley; "
                         "speeds slow, fast")
    width = heightmap.extent
    # World units per frame: Pires's speed in spacings, scaled by the width in samples.
    step = SPEEDS[(kind, speed)] * (heightmap.size - 1) / REFERENCE_WIDTH * heightmap.spacing
    centre = np.array([width / 2, width / 2])
    index = start + every * np.arange(frames)
    if kind == "valley":
        line = valley_polyline(heightmap)
        lengths = np.r_[0, np.cumsum(np.linalg.norm(np.diff(line, axis=0), axis=1))]
        along = np.mod(index * step, 2 * lengths[-1])
        along = np.where(along > lengths[-1], 2 * lengths[-1] - along, along)  # there and back
        x = np.interp(along, lengths, line[:, 0])
        z = np.interp(along, lengths, line[:, 1])
        ahead = np.clip(along + 0.02 * width, 0, lengths[-1])
        back = np.mod(index * step, 2 * lengths[-1]) > lengths[-1]
        ahead = np.where(back, np.clip(along - 0.02 * width, 0, lengths[-1]), ahead)
        yaw = yaw_toward(np.interp(ahead, lengths, line[:, 0]) - x,
                         np.interp(ahead, lengths, line[:, 1]) - z)
    elif kind == "circle":
        radius = 0.4 * width
        angle = index * step / radius
        x = centre[0] + radius * np.cos(angle)
        z = centre[1] + radius * np.sin(angle)
        yaw = yaw_toward(centre[0] - x, centre[1] - z)
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
        yaw = yaw_toward(dx, dz)
    y = heightmap.height_at(x, z) + eye_height * heightmap.spacing
    far = far if far is not None else 1.5 * width
    near = max(0.05 * heightmap.spacing, far * 1e-5)
    return [Camera((px, py, pz), yaw=float(w), pitch=pitch, fov=fov, aspect=aspect, near=near,
                   far=far) for px, py, pz, w in zip(x, y, z, yaw)]

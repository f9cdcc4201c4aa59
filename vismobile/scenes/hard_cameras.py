"""Camera classes that stress a culler's conservativeness on any world (issue 17).

An independent tester's cameras, placed from the world's own geometry so they apply to thesis
worlds and to arbitrary meshes alike (coordinates in metres: worlds of a few to a few hundred
metres; scale the cameras with `moved` when the world is scaled or offset):

  box     anywhere in the world's box grown by 10% (inside rooms, walls and closed objects),
          random yaw, pitch in [-60, 60], aspect from ASPECTS
  pitch   as box, pitch +-89 or +-89.9 (looking straight up or down)
  wall    1e-3 in front of (one in four: behind) a random triangle, looking along its plane
          (+-20 deg), near 1e-4: the triangle's plane crosses the view
  narrow  fov 1, aimed at a random triangle's centroid from a box position
  wide    fov 170 from a box position
"""
from __future__ import annotations

import numpy as np

from ..world.camera import Camera, yaw_toward

CLASSES = ("box", "pitch", "wall", "narrow", "wide")
ASPECTS = (9 / 16, 0.75, 1.0, 2.5)
WALL_DISTANCE = 1e-3
WALL_NEAR = 1e-4


def angles(direction) -> tuple:
    """(yaw, pitch) in degrees of a camera looking along `direction` (3,) (need not be unit)."""
    d = np.asarray(direction, dtype=np.float64)
    d = d / np.linalg.norm(d)
    return (float(yaw_toward(d[0], d[2])),
            float(np.degrees(np.arcsin(np.clip(d[1], -1.0, 1.0)))))


def hard_cameras(world, count: int, seed: int = 0, classes=CLASSES, aspect=None) -> list:
    """(label, Camera) list: `count` cameras per class in `classes` (see the module docstring),
    labelled "<class>_<k>". aspect: one aspect for all, or None for a draw from ASPECTS."""
    unknown = sorted(set(classes) - set(CLASSES))
    if unknown:
        raise ValueError(f"unknown camera class(es) {unknown}; valid: {', '.join(CLASSES)}")
    rng = np.random.default_rng(seed)
    low, high = world.extent
    grow = 0.1 * (high - low)
    areas = world.areas
    usable = np.flatnonzero(areas > 1e-12 * max(float(areas.max(initial=0.0)), 1e-300))
    if not len(usable):
        raise ValueError(f"world {world.name} has no triangle of positive area")
    weights = areas[usable] / areas[usable].sum()

    def box_spot():
        return rng.uniform(low - grow, high + grow)

    def pick_aspect():
        return float(aspect if aspect is not None else rng.choice(ASPECTS))

    def make(kind):
        if kind in ("box", "pitch", "wide"):
            pitch = (rng.choice([89.0, 89.9]) * rng.choice([1.0, -1.0]) if kind == "pitch"
                     else rng.uniform(-60.0, 60.0))
            return Camera(box_spot(), rng.uniform(0.0, 360.0), float(pitch),
                          170.0 if kind == "wide" else 45.0, pick_aspect())
        tri = rng.choice(usable, p=weights)
        if kind == "narrow":
            eye = box_spot()
            target = world.centroids[tri]
            if np.linalg.norm(target - eye) == 0.0:
                eye = eye + (high - low) * 0.01 + 1e-3
            yaw, pitch = angles(target - eye)
            return Camera(eye, yaw, pitch, 1.0, pick_aspect())
        normal = world.normals[tri]
        side = -1.0 if rng.random() < 0.25 else 1.0
        point = rng.dirichlet([1.0, 1.0, 1.0]) @ world.corners[tri]
        eye = point + side * WALL_DISTANCE * normal
        along = rng.normal(size=3)
        along -= (along @ normal) * normal
        if np.linalg.norm(along) < 1e-9:
            along = np.cross(normal, [1.0, 0.0, 0.0] if abs(normal[0]) < 0.9 else [0, 1.0, 0])
        along /= np.linalg.norm(along)
        tilt = np.radians(rng.uniform(-20.0, 20.0))
        yaw, pitch = angles(np.cos(tilt) * along + np.sin(tilt) * normal)
        pitch = float(np.clip(pitch, -89.9, 89.9))
        return Camera(eye, yaw, pitch, float(rng.choice([45.0, 90.0])), pick_aspect(),
                      near=WALL_NEAR)

    return [(f"{kind}_{k}", make(kind)) for kind in classes for k in range(count)]


def moved(camera: Camera, scale: float = 1.0, offset=(0.0, 0.0, 0.0)) -> Camera:
    """The camera for the world scaled about the origin by `scale`, then moved by `offset`:
    same view (near and far scale too)."""
    eye = camera.eye * float(scale) + np.asarray(offset, dtype=np.float64)
    return camera.with_(position=eye, near=camera.near * scale, far=camera.far * scale)

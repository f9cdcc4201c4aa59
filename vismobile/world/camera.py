"""The pinhole camera: y up, yaw about +y (0 looks toward -z), pitch up positive, degrees."""
from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from ..geometry.angles import yaw_toward  # noqa: F401  (re-exported: its older home)

PLANE_NAMES = ("left", "right", "bottom", "top", "near", "far")


@dataclass(frozen=True)
class Camera:
    """A view: position (3,), yaw and pitch in degrees, vertical fov in degrees, aspect = w/h."""

    position: tuple
    yaw: float = 0.0
    pitch: float = 0.0
    fov: float = 45.0
    aspect: float = 240 / 320
    near: float = 0.1
    far: float = 1000.0

    def __post_init__(self):
        object.__setattr__(self, "position", tuple(float(c) for c in np.reshape(self.position, 3)))
        if not 0.0 < self.fov < 180.0:
            raise ValueError(f"fov must be in (0, 180) degrees, got {self.fov}")
        if not 0.0 < self.near < self.far:
            raise ValueError(f"need 0 < near < far, got near={self.near} far={self.far}")
        if not self.aspect > 0.0:
            raise ValueError(f"aspect must be positive, got {self.aspect}")
        if not np.all(np.isfinite(self.eye)) or not np.isfinite([self.yaw, self.pitch]).all():
            raise ValueError("camera position and angles must be finite")

    @property
    def eye(self) -> np.ndarray:
        """(3,) float64 eye position."""
        return np.array(self.position, dtype=np.float64)

    def axes(self) -> tuple:
        """(right, up, forward) as three tuples of 3 floats: basis() without the arrays."""
        yaw, pitch = math.radians(self.yaw), math.radians(self.pitch)
        cy, sy, cp, sp = math.cos(yaw), math.sin(yaw), math.cos(pitch), math.sin(pitch)
        f = (-sy * cp, sp, -cy * cp)
        r = (cy, 0.0, -sy)
        # right x forward in scalars (np.cross costs more than the rest of a culled frame)
        up = (r[1] * f[2] - r[2] * f[1], r[2] * f[0] - r[0] * f[2], r[0] * f[1] - r[1] * f[0])
        return r, up, f

    def basis(self) -> tuple:
        """(right, up, forward): three orthonormal (3,) float64 vectors in world space."""
        r, up, f = self.axes()
        return np.array(r), np.array(up), np.array(f)

    @property
    def forward(self) -> np.ndarray:
        return self.basis()[2]

    def view_matrix(self) -> np.ndarray:
        """(4, 4) float64 world-to-eye matrix (OpenGL: eye looks down -z)."""
        right, up, forward = self.basis()
        rotation = np.stack([right, up, -forward])
        view = np.eye(4)
        view[:3, :3] = rotation
        view[:3, 3] = -rotation @ self.eye
        return view

    def projection_matrix(self) -> np.ndarray:
        """(4, 4) float64 OpenGL perspective matrix (gluPerspective)."""
        f = 1.0 / np.tan(np.radians(self.fov) / 2.0)
        n, fa = self.near, self.far
        return np.array([
            [f / self.aspect, 0.0, 0.0, 0.0],
            [0.0, f, 0.0, 0.0],
            [0.0, 0.0, (fa + n) / (n - fa), 2.0 * fa * n / (n - fa)],
            [0.0, 0.0, -1.0, 0.0],
        ])

    def view_projection(self) -> np.ndarray:
        """(4, 4) float64 projection_matrix() @ view_matrix()."""
        return self.projection_matrix() @ self.view_matrix()

    def frustum_planes(self) -> np.ndarray:
        """(6, 4) float64 planes (n, d), unit inward n: inside where n.x + d >= 0.

        Built from the camera basis rather than the clip matrix, so the near and far planes
        keep full precision at far/near ratios of 1e7. Order: left, right, bottom, top, near, far.
        """
        return self.pushed_planes(-0.0, np.inf)  # x + -0.0 is x: the offsets unchanged

    def half_angles(self) -> tuple:
        """(cos, sin) of the horizontal then the vertical half field of view, as Python floats
        (the side planes' rows; cached per fov and aspect)."""
        return _half_angles(self.fov, self.aspect)

    def pushed_planes(self, margin: float, limit: float) -> np.ndarray:
        """(6, 4) float64 Camera.frustum_planes (this class's, never a subclass's) with each
        offset raised by margin, and a plane whose raised offset exceeds limit in magnitude
        replaced by the always-inside (0, 0, 0, 1): culling.precision.conservative_planes of
        them, bit for bit, in one compiled call (world/view_planes.py)."""
        from .view_planes import view_planes  # numba: not on the --help import path

        x, y, z = self.position
        return view_planes(x, y, z, float(self.yaw), float(self.pitch),
                           *_half_angles(self.fov, self.aspect), float(self.near),
                           float(self.far), float(margin), float(limit))

    def with_(self, **changes) -> "Camera":
        """A copy with some fields replaced."""
        fields = dict(position=self.position, yaw=self.yaw, pitch=self.pitch, fov=self.fov,
                      aspect=self.aspect, near=self.near, far=self.far)
        fields.update(changes)
        return Camera(**fields)


@lru_cache(maxsize=64)  # every frame asks with the same fov and aspect
def _half_angles(fov: float, aspect: float) -> tuple:
    """(cos, sin) of the horizontal then the vertical half field of view, as Python floats."""
    half_v = np.radians(fov) / 2.0
    half_h = np.arctan(np.tan(half_v) * aspect)
    return (float(np.cos(half_h)), float(np.sin(half_h)), float(np.cos(half_v)),
            float(np.sin(half_v)))

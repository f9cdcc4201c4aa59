"""Keeping culling conservative when the device stores and tests geometry in float32 or fixed16.16.

The Culler itself computes in float64. A device in another arithmetic mode (geometry/arithmetic.py)
differs in two ways: it renders rounded vertices from a rounded camera, and it evaluates plane
tests with rounding. Both are bounded; the functions here turn the bounds into inflated planes
or a widened camera, so a float64 decision that keeps a triangle still keeps every
triangle the device could show.

Hooks: `Culler.cull(conservative_camera(quantize_camera(camera, mode), mode, scale))` needs no
change to the Culler; the direct form is `conservative_planes` in place of
`camera.frustum_planes()` inside Culler.cull.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from ..world.camera import Camera
from ..errors import ProfileError
from ..geometry import arithmetic

# A plane the mode cannot hold is replaced by this always-inside plane (dropping a plane only
# grows the frustum, so it is conservative).
_ALWAYS_INSIDE = np.array([0.0, 0.0, 0.0, 1.0])

# How far the device moves a vertex or the eye, per coordinate: DEVICE_RELATIVE x the largest
# coordinate magnitude (16 float32 ulps: rounding the vertex plus the GPU's float32 transform,
# which runs in float32 whatever the storage) plus, in fixed16.16, DEVICE_ABSOLUTE (2x the
# grid's rounding). tbfc, cbfc, cone and both occlusion stages keep what such moves could show.
DEVICE_RELATIVE = 2.0 ** -20
DEVICE_ABSOLUTE = 2.0 ** -16
# Float32's smallest normal: below it relative bounds no longer hold (absolute floor).
_FLOAT32_TINY = float(np.finfo(np.float32).tiny)


def world_scale(vertices, camera: Camera | None = None) -> float:
    """Largest |coordinate| of the vertices (V, 3) and the camera eye: the magnitude bounds use."""
    vertices = np.asarray(vertices)  # no float64 or abs copy: the array may be a mapped file
    scale = float(max(-vertices.min(), vertices.max())) if vertices.size else 0.0
    if camera is not None:
        scale = max(scale, float(np.abs(camera.eye).max()))
    return scale


@lru_cache(maxsize=256)  # called every frame with the same few (mode, scale) pairs
def margin(mode: str, scale: float) -> float:
    """Distance by which every plane must be pushed out: plane-test error in the mode plus the
    largest move of a rounded vertex (sqrt(3) x its per-coordinate error), plus float64's own
    plane-test error, for coordinates up to `scale`."""
    move = np.sqrt(3.0) * float(arithmetic.representation_error(scale, mode))
    own = arithmetic.distance_error_bound("float64", scale)
    return arithmetic.distance_error_bound(mode, scale) + move + own


def device_move(mode: str, scale: float) -> float:
    """Per-coordinate bound on how far the device moves a vertex or the eye from its float64
    value, for coordinates up to `scale`: DEVICE_RELATIVE x scale, plus DEVICE_ABSOLUTE in
    fixed16.16 (float modes: plus float32's smallest normal). Errs large (16 ulps, not 1)."""
    absolute = DEVICE_ABSOLUTE if arithmetic.check_mode(mode) == "fixed16.16" else _FLOAT32_TINY
    return DEVICE_RELATIVE * float(scale) + absolute


def depth_order(move: float, near: float) -> float:
    """Relative depth slack s of the device's depth test: occluder depths pushed back by s x
    depth keep every surface the device may draw in front of them. The device transforms in
    float32 with an error of up to e = move (m = 2 device_move: 16 float32 ulps of the scale,
    twice) in clip z and w together, so its normalised depth 1 - 2 n' (1 / z - 1 / far)
    (n' = far near / (far - near) >= near) is off by up to e / z, and it orders surfaces at
    z1 < z2 only when z2 > z1 (2 n' + e) / (2 n' - e): s = 2 e / (2 near - e). inf when
    e >= 2 near: it cannot order depths (nor draw an occluder for sure), so nothing is hidden.
    Errs large (e as device_move does; near <= n'). W2 in float32: 7.6e-4; near 1e-3 at a 1e5
    offset in float32: inf."""
    if not move < 2.0 * near:
        return np.inf
    return 2.0 * move / (2.0 * near - move)


def conservative_planes(planes, mode: str, scale: float) -> np.ndarray:
    """(K, 4) float64 planes with offsets raised by margin(mode, scale); errs outward by it.

    A plane whose inflated offset the mode cannot hold is replaced by an always-inside plane.
    planes : (K, 4) float64 unit-normal planes (n, d), inside where n.x + d >= 0
    """
    planes = np.array(planes, dtype=np.float64).reshape(-1, 4)
    offsets = planes[:, 3]
    offsets += margin(mode, scale)
    beyond = np.abs(offsets) > _max_magnitude(mode)
    if beyond.any():
        planes[beyond] = _ALWAYS_INSIDE
    return planes


def culling_planes(camera: Camera, mode: str, scale: float) -> np.ndarray:
    """conservative_planes(camera.frustum_planes(), mode, scale), bit for bit: in one compiled
    call (Camera.pushed_planes) when the camera's planes are Camera's own, else (a subclass
    that pushes them, ConservativeCamera) through its frustum_planes."""
    if type(camera).frustum_planes is Camera.frustum_planes:
        return camera.pushed_planes(margin(mode, scale), _max_magnitude(mode))
    return conservative_planes(camera.frustum_planes(), mode, scale)


def culling_push(camera: Camera, mode: str, scale: float) -> tuple:
    """(planes, margin, limit) for culling_planes' planes computed elsewhere: (None, the
    margin and the largest offset the mode holds) when the camera's planes are Camera's own
    (Camera.pushed_planes(margin, limit) gives them), else (culling_planes' planes, 0, inf)."""
    if type(camera).frustum_planes is Camera.frustum_planes:
        return None, margin(mode, scale), _max_magnitude(mode)
    return conservative_planes(camera.frustum_planes(), mode, scale), 0.0, np.inf


@lru_cache(maxsize=8)
def _max_magnitude(mode: str) -> float:
    return arithmetic.max_magnitude(mode)


def quantize_camera(camera: Camera, mode: str) -> Camera:
    """The camera as the device holds it: eye rounded to the mode, angles and fov kept.

    Raises ProfileError when the eye, near or far is out of the mode's range, or when near is
    below the mode's resolution (fixed16.16: 2^-16).
    """
    eye = arithmetic.quantize(camera.eye, mode, "camera position")
    near, far = arithmetic.quantize([camera.near, camera.far], mode, "camera near/far")
    if near <= 0.0:
        raise ProfileError(f"camera near plane {camera.near:g} is below the {mode} resolution")
    return camera.with_(position=eye, near=float(near), far=float(max(far, near * 2)))


@dataclass(frozen=True)
class ConservativeCamera(Camera):
    """A Camera whose frustum_planes() are pushed out by `margin`; eye, angles and fov unchanged.

    Hands the inflation to a Culler that knows nothing of arithmetic modes: every stage that
    reads camera.frustum_planes() gets the inflated planes, stages reading the eye (backface,
    cones, occlusion) see the camera unchanged. with_() returns a plain Camera.
    """

    margin: float = 0.0

    def frustum_planes(self) -> np.ndarray:
        """(6, 4) float64 Camera.frustum_planes with d raised by margin; errs outward by margin."""
        planes = super().frustum_planes()
        planes[:, 3] += self.margin
        return planes


def conservative_camera(camera: Camera, mode: str, scale: float) -> ConservativeCamera:
    """camera as a ConservativeCamera with margin(mode, scale): its frustum errs outward by the
    mode's plane-test error plus the largest move of a rounded vertex (coordinates <= scale)."""
    return ConservativeCamera(camera.position, camera.yaw, camera.pitch, camera.fov,
                              camera.aspect, camera.near, camera.far, margin(mode, scale))

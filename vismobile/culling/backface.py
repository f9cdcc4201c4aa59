"""Back-face culling: the driver's flag (`bfc`) and the thesis's region method made safe in 3D
(`cbfc`, thesis 4.3.4, Algorithm 3).

Why the region test is safe. A triangle with unit normal n is back-facing (or edge-on) seen
from the eye e when n.(p - e) >= 0 for one point p of its plane (the value is the same for all).
Every point p the camera can show lies in the frustum, so p - e = t r with t > 0 and r a
non-negative combination of the four corner rays c_1..c_4. Hence if n.c_i >= 0 for the four
corner rays, the triangle is back-facing wherever it is in the frustum, and dropping it never
removes a front-facing triangle inside the frustum. Per frame we drop whole regions of normal
directions: a region inside a cap (centre m, radius rho) is droppable when
angle(m, c_i) + rho <= 90 degrees for the four corners, i.e. m.c_i >= sin(rho).

The thesis (2D) drops a triangle when its normal's yaw sector equals the view's yaw sector,
with n = 360 / (90 - FOV) sectors. That ignores pitch, the vertical field of view and the
aspect: a floor (normal straight up) sits in some yaw sector and is dropped whenever the camera
yaws into it, though it faces the eye. Here sectors are split further into elevation bands, and
the per-frame table is derived from the actual frustum, so any FOV, aspect and pitch are safe.

Device rounding. The device draws the triangle with rounded corners and eye; its GPU clips to
the same frustum directions, so only the rounded normal matters: if every corner moves by at
most m, the normal turns by an angle theta with sin(theta) <= k1 m + k2 m^2 (geometry/tilt.py).
A triangle is dropped only when its region's cap, widened by its own theta, still passes the
test, i.e. asin(min_i m.c_i) - rho >= theta.
"""
from __future__ import annotations

import math
from functools import lru_cache

import numpy as np

from ..geometry.sphere_regions import caps_within, direction_regions, region_caps
from ..world.mapped import corner_chunks
from ..world.world import unit_normals
from .facing import region_spare, tilt_scales, tilt_select
from .precision import device_move, world_scale
from .state import CullState
from .tree import Tree


# Triangles per chunk when a stage builds its per-triangle table (bounds prepare's memory).
CHUNK = 1 << 18


def normal_regions(world, yaw_regions: int, pitch_bands: int, horizontal: bool = False):
    """(T,) direction region of each triangle's normal (sphere_regions.direction_regions: ids
    0..R, R = yaw_regions x pitch_bands for degenerate normals) in the smallest unsigned type
    that holds them, built CHUNK triangles at a time so a memory-mapped world is never held
    whole. horizontal: the normals' y dropped first (the thesis's 2D sectors)."""
    ids = yaw_regions * pitch_bands + 1
    dtype = np.uint8 if ids <= 256 else np.uint16 if ids <= 65536 else np.int32
    regions = np.empty(world.triangle_count, dtype=dtype)
    for start, corners in corner_chunks(world, CHUNK):
        normals, _ = unit_normals(corners)
        if horizontal:
            normals = normals * [1.0, 0.0, 1.0]
        regions[start:start + len(corners)] = direction_regions(normals, yaw_regions,
                                                                pitch_bands)
    return regions


def corner_rays(camera) -> np.ndarray:
    """(4, 3) float64 directions of the frustum's four corner rays (from the eye, unnormalised)."""
    return np.array(_corner_rays(camera))


def unit_corner_rays(camera) -> np.ndarray:
    """(4, 3) float64 corner_rays(camera) scaled to unit length (the same bits as dividing the
    array by its row norms)."""
    rays = []
    for x, y, z in _corner_rays(camera):
        length = math.sqrt(x * x + y * y + z * z)
        rays.append((x / length, y / length, z / length))
    return np.array(rays)


def _corner_rays(camera) -> list:
    """corner_rays as four tuples of floats (scalars: numpy's small-array calls cost more)."""
    (rx, ry, rz), (ux, uy, uz), (fx, fy, fz) = camera.axes()
    tx, ty = half_tangents(camera.fov, camera.aspect)
    return [(fx + a * rx + b * ux, fy + a * ry + b * uy, fz + a * rz + b * uz)
            for a, b in ((-tx, -ty), (tx, -ty), (tx, ty), (-tx, ty))]


@lru_cache(maxsize=64)  # every frame asks with the same fov and aspect
def half_tangents(fov: float, aspect: float) -> tuple:
    """(tan of the horizontal, of the vertical half field of view) as the frustum's corners use
    them: ty = tan(fov / 2), tx = ty x aspect."""
    ty = np.tan(np.radians(fov) / 2.0)
    return float(ty * aspect), float(ty)


def thesis_region_count(fov: float = 45.0) -> int:
    """n = 360 / (90 - FOV) yaw sectors (thesis Algorithm 3), at least 1."""
    return max(1, int(round(360.0 / (90.0 - fov)))) if fov < 90.0 else 1


class BackfaceFlag:
    """`bfc`: sets the render flag GL_CULL_FACE; sends the same triangles."""

    name = "bfc"
    cost = 90

    def prepare(self, tree: Tree) -> None:
        pass

    def apply(self, state: CullState) -> None:
        state.cull_back = True
        state.count("bfc.render_flag", 1)


class ConservativeBackface:
    """`cbfc`: drops triangles whose normal region is back-facing for every frustum ray.

    yaw_regions : sectors about the vertical axis (default the thesis's 360/(90-45) = 8)
    pitch_bands : elevation bands of the normal (the 3D extension)
    Contract: never drops a triangle that faces the eye and has a point inside the frustum,
    also after the device moves its corners by device_move(arithmetic) (errs toward keeping).
    Per frame: a (R,) table from 4 R dot products, then per candidate one lookup, and when its
    region is droppable a second lookup (its power-of-two tilt bound) and, only when that bound
    does not fit, its tilt from its corners. Prepare keeps two bytes per triangle.
    """

    name = "cbfc"
    cost = 80
    arithmetic = "float64"  # the Culler sets its mode: the device-rounding margin follows it

    def __init__(self, yaw_regions: int | None = None, pitch_bands: int = 6):
        self.yaw_regions = thesis_region_count() if yaw_regions is None else int(yaw_regions)
        self.pitch_bands = int(pitch_bands)
        if self.yaw_regions < 1 or self.pitch_bands < 1:
            raise ValueError("cbfc needs yaw_regions >= 1 and pitch_bands >= 1")

    def prepare(self, tree: Tree) -> None:
        # One small int per triangle (its normal's region); the tilt coefficients are computed
        # per frame, only for droppable candidates whose scale byte below does not decide.
        world = tree.world
        self.centers, self.radii = region_caps(self.yaw_regions, self.pitch_bands)
        self.regions = normal_regions(world, self.yaw_regions, self.pitch_bands)
        self.vertices, self.triangles = np.asarray(world.vertices), np.asarray(world.triangles)
        # One more byte per triangle: a power-of-two bound on its tilt (facing.tilt_scales), so
        # a droppable candidate is decided without reading its corners when the bound fits.
        self.scales = np.empty(world.triangle_count, dtype=np.uint8)
        for start in range(0, world.triangle_count, CHUNK):
            tilt_scales(self.vertices, self.triangles, start,
                        self.scales[start:start + CHUNK])
        self.magnitude = world_scale(self.vertices)
        # Per-frame constant: caps_within's bound per region.
        need = np.where(self.radii < np.pi / 2, np.sin(np.minimum(self.radii, np.pi / 2)), np.inf)
        self._need = need + 1e-12
        self._dropped_key = f"{self.name}.regions_dropped"
        self._culled_key = f"{self.name}.refs_culled"

    def droppable(self, camera) -> np.ndarray:
        """(R + 1,) bool per region (last: degenerate normals, never dropped).

        Errs toward False (keeping) by 1e-12 in cos: a region drops only when every normal of
        its cap faces away from every frustum corner ray (caps_within)."""
        table = np.zeros(len(self.radii) + 1, dtype=bool)
        table[:-1] = caps_within(self.centers, self.radii, corner_rays(camera))
        return table

    def spare(self, camera, table) -> np.ndarray:
        """(R + 1,) float64 per droppable region: sin of the angle its cap could still grow and
        pass (asin(min_i m.c_i) - rho); -1 elsewhere. Errs small by 1e-12."""
        rays = corner_rays(camera)
        rays = rays / np.linalg.norm(rays, axis=1, keepdims=True)
        low = np.clip((self.centers @ rays.T).min(axis=1), -1.0, 1.0)
        room = np.clip(np.arcsin(low) - self.radii, 0.0, np.pi / 2)
        out = np.full(len(table), -1.0)
        out[:-1] = np.where(table[:-1], np.sin(room) - 1e-12, -1.0)
        return out

    def frame_table(self, camera) -> tuple:
        """(regions dropped, spare): droppable(camera).sum() and spare(camera, droppable(camera))
        in one compiled pass (facing.region_spare; its sums may differ from the BLAS products
        by an ulp). Errs as they do (toward keeping by 1e-12)."""
        spare = np.empty(len(self.radii) + 1)
        dropped = region_spare(self.centers, self._need, self.radii, unit_corner_rays(camera),
                               spare)
        return dropped, spare

    def apply(self, state: CullState) -> None:
        dropped, spare = self.frame_table(state.camera)
        state.count(self._dropped_key, dropped)
        if not dropped:
            return
        regions = self.regions
        scale = max(self.magnitude, *map(abs, state.camera.position))
        move = np.sqrt(3.0) * device_move(self.arithmetic, scale)  # Euclidean, per corner

        def keep_of(ids):  # the kept ids themselves (CullState.filters)
            kept = np.empty(len(ids), dtype=np.int64)
            count = tilt_select(np.ascontiguousarray(ids, dtype=np.int64), regions, self.scales,
                                spare, self.vertices, self.triangles, move, kept)
            state.count("triangles_tested", len(ids))
            state.count(self._culled_key, len(ids) - count)
            return kept[:count]

        state.filters.append(keep_of)


class ThesisBackface:
    """`cbfc_thesis`: the thesis's 2D rule, kept for the comparisons: drop a triangle whose
    normal's yaw sector equals the view direction's (n = 360 / (90 - FOV) sectors).

    Contract: aggressive, NOT conservative: it ignores the normal's elevation and the camera's
    pitch, so it drops tilted triangles that face the eye (object surfaces); the study measures
    how many. Normals are projected on the ground plane; exactly vertical ones are never dropped.
    """

    name = "cbfc_thesis"
    cost = 79

    def __init__(self, yaw_regions: int | None = None):
        self.yaw_regions = yaw_regions

    def prepare(self, tree: Tree) -> None:
        self.tree = tree

    def apply(self, state: CullState) -> None:
        count = self.yaw_regions or thesis_region_count(state.camera.fov)
        if not hasattr(self, "_count") or self._count != count:
            self._count = count
            self.sectors = normal_regions(self.tree.world, count, 1, horizontal=True)
        view = direction_regions(state.camera.forward[None] * [1.0, 0.0, 1.0], count, 1)[0]
        if view == count:  # looking straight up or down: the 2D rule has no view sector
            return
        sectors = self.sectors

        def keep_of(ids):
            keep = sectors[ids] != view
            state.count("triangles_tested", len(ids))
            state.count(f"{self.name}.refs_culled", len(ids) - np.count_nonzero(keep))
            return keep

        state.filters.append(keep_of)

"""Stress worlds and stress cameras for the numerical-stability suite (issue 7).

Every world case derives from one small base world (two rooms joined by a doorway, with a few
boxes), so a failure points at the stress, not at the scene. Cameras are placed by the base
world's own coordinates and follow each case's scale and offset. Cameras on partition planes,
node corners and portal planes are computed from a partition's flat arrays (duck-typed: this
module does not import partition/).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..world.camera import Camera
from ..world.world import World

# Base world: rooms [0, 8] x [0, 3] x [0, 12], split at z = 6 by a wall with a doorway.
ROOM_SIZE = np.array([8.0, 3.0, 12.0])
DOOR = (3.0, 5.0, 2.2)  # x from, x to, height


@dataclass(eq=False)
class StressCase:
    """A stress world with its cameras.

    name    : case name, e.g. "translate_1e7"
    world   : World
    scale   : float, how base coordinates map to world ones: x_world = x_base * scale + offset
    offset  : (3,) float64
    cameras : list of (label, Camera)
    """

    name: str
    world: World
    scale: float = 1.0
    offset: np.ndarray = field(default_factory=lambda: np.zeros(3))
    cameras: list = field(default_factory=list)


# ---- base geometry -----------------------------------------------------------------------

def grid_quad(origin, u, v, nu, nv) -> tuple:
    """Quad origin + [0,1]u + [0,1]v split into nu x nv cells of 2 triangles, front along u x v.

    returns (vertices ((nu+1)(nv+1), 3) float64, triangles (2 nu nv, 3) int32)
    """
    origin, u, v = (np.asarray(a, dtype=np.float64) for a in (origin, u, v))
    a, b = np.meshgrid(np.linspace(0, 1, nu + 1), np.linspace(0, 1, nv + 1), indexing="ij")
    vertices = origin + a.reshape(-1, 1) * u + b.reshape(-1, 1) * v
    i, j = np.meshgrid(np.arange(nu), np.arange(nv), indexing="ij")
    p00 = (i * (nv + 1) + j).ravel()
    p10, p01 = p00 + nv + 1, p00 + 1
    p11 = p10 + 1
    triangles = np.concatenate([np.stack([p00, p10, p11], 1), np.stack([p00, p11, p01], 1)])
    return vertices, triangles.astype(np.int32)


def _soup(parts, names) -> World:
    """World from a list of (vertices, triangles) lists, one object per entry of names."""
    vertices, triangles, ids = [], [], []
    offset = 0
    for index, pieces in enumerate(parts):
        for v, t in pieces:
            vertices.append(v)
            triangles.append(t + offset)
            ids.append(np.full(len(t), index, dtype=np.int32))
            offset += len(v)
    return World(np.concatenate(vertices), np.concatenate(triangles), np.concatenate(ids),
                 list(names), "stress")


def box_faces(lo, hi, inward=False, cells=1) -> list:
    """Six faces of the box [lo, hi] as grid quads, normals outward (or inward)."""
    lo, hi = np.asarray(lo, dtype=np.float64), np.asarray(hi, dtype=np.float64)
    size = hi - lo
    ex, ey, ez = np.diag(size)
    # (origin, u, v) with u x v pointing outward
    faces = [(lo, ez, ey), (lo + ex, ey, ez),           # -x, +x
             (lo, ex, ez), (lo + ey, ez, ex),           # -y, +y
             (lo, ey, ex), (lo + ez, ex, ey)]           # -z, +z
    out = []
    for origin, u, v in faces:
        if inward:
            u, v = v, u
        out.append(grid_quad(origin, u, v, cells, cells))
    return out


def base_world() -> World:
    """Two 8 x 3 x 6 rooms joined by a doorway in the wall z = 6, three boxes: 264 triangles."""
    sx, sy, sz = ROOM_SIZE
    shell = box_faces((0, 0, 0), ROOM_SIZE, inward=True, cells=3)
    x0, x1, height = DOOR
    wall = []
    for side in (+1, -1):  # both faces of the dividing wall, front toward each room
        z = sz / 2
        pieces = [((0, 0), (x0, sy)), ((x1, 0), (sx, sy)), ((x0, height), (x1, sy))]
        for (a0, b0), (a1, b1) in pieces:
            origin = np.array([a0, b0, z])
            u, v = np.array([a1 - a0, 0, 0.0]), np.array([0, b1 - b0, 0.0])
            wall.append(grid_quad(origin, u, v, 2, 2) if side > 0 else
                        grid_quad(origin, v, u, 2, 2))
    boxes = [box_faces((1.0, 0.0, 1.5), (2.5, 1.0, 2.5), cells=2),
             box_faces((5.5, 0.0, 8.0), (6.5, 2.0, 9.0), cells=2),
             box_faces((3.5, 0.8, 3.0), (4.5, 1.2, 3.4), cells=1)]
    return _soup([shell, wall] + boxes, ["shell", "wall", "crate", "cabinet", "table"])


# ---- world cases -------------------------------------------------------------------------

def _extra(world: World, vertices, triangles, name: str) -> World:
    """world plus extra triangles as one more object (kept even when degenerate)."""
    vertices = np.asarray(vertices, dtype=np.float64).reshape(-1, 3)
    triangles = np.asarray(triangles, dtype=np.int32).reshape(-1, 3) + len(world.vertices)
    ids = np.full(len(triangles), len(world.object_names), dtype=np.int32)
    return World(np.concatenate([world.vertices, vertices]),
                 np.concatenate([world.triangles, triangles]),
                 np.concatenate([world.object_ids, ids]),
                 list(world.object_names) + [name], world.name)


def slivers(world: World, count=24, seed=7) -> World:
    """Needles (one side 1e-7 of the others) and slivers (an angle near 180 degrees)."""
    rng = np.random.default_rng(seed)
    base = rng.uniform([1.0, 1.0, 1.0], ROOM_SIZE - [1.0, 1.0, 1.0], size=(count, 3))
    direction = rng.normal(size=(count, 3))
    direction /= np.linalg.norm(direction, axis=1, keepdims=True)
    across = np.cross(direction, rng.normal(size=(count, 3)))
    across /= np.linalg.norm(across, axis=1, keepdims=True)
    half = count // 2
    # needles: long edge 1, apex 1e-7 off it near one end; slivers: apex 1e-7 off the midpoint
    apex = np.where(np.arange(count)[:, None] < half, 0.0, 0.5)
    corners = np.stack([base, base + 1.0 * direction,
                        base + apex * direction + 1e-7 * across], axis=1)
    return _extra(world, corners.reshape(-1, 3), np.arange(3 * count).reshape(-1, 3), "slivers")


def zero_area(world: World, count=12, seed=8) -> World:
    """Exactly zero-area triangles: collinear corners and repeated corners, inside the rooms."""
    rng = np.random.default_rng(seed)
    a = rng.uniform([0.5, 0.2, 0.5], ROOM_SIZE - [0.5, 0.2, 0.5], size=(count, 3))
    b = a + rng.uniform(-1, 1, size=(count, 3))
    third = np.where(np.arange(count)[:, None] % 2 == 0, b, a)  # repeated or on the segment
    third = np.where(np.arange(count)[:, None] % 4 == 1, 0.5 * (a + b), third)
    # the midpoint of a and b is not exactly collinear in floating point; use exact halves
    b = np.where(np.arange(count)[:, None] % 4 == 1, a + 2.0 * (third - a), b)
    corners = np.stack([a, b, third], axis=1)
    return _extra(world, corners.reshape(-1, 3), np.arange(3 * count).reshape(-1, 3), "zero_area")


def duplicated(world: World) -> World:
    """Every triangle twice (same vertex indices), and the first 50 again on new vertices."""
    copies = world.corners[:50].reshape(-1, 3)
    doubled = World(world.vertices, np.concatenate([world.triangles, world.triangles]),
                    np.concatenate([world.object_ids, world.object_ids]),
                    list(world.object_names), world.name)
    return _extra(doubled, copies, np.arange(len(copies)).reshape(-1, 3), "copies")


def coplanar_overlap(world: World, count=16, seed=9) -> World:
    """Triangles in the floor plane y = 0 and the wall z = 6, overlapping the existing ones."""
    rng = np.random.default_rng(seed)
    center = rng.uniform([0.5, 0.0, 0.5], [7.5, 0.0, 11.5], size=(count, 3))
    center[count // 2:, 2] = ROOM_SIZE[2] / 2
    center[count // 2:, 1] = rng.uniform(0.5, 2.5, size=count - count // 2)
    angles = rng.uniform(0, 2 * np.pi, size=(count, 1)) + np.array([0, 2.1, 4.2])
    radius = rng.uniform(0.3, 1.5, size=(count, 1))
    offsets = np.zeros((count, 3, 3))
    floor = np.arange(count) < count // 2
    # floor triangles face up (+y): counter-clockwise seen from above
    offsets[floor, :, 0] = (radius * np.cos(angles))[floor]
    offsets[floor, :, 2] = -(radius * np.sin(angles))[floor]
    offsets[~floor, :, 0] = (radius * np.cos(angles))[~floor]
    offsets[~floor, :, 1] = (radius * np.sin(angles))[~floor] * 0.3
    corners = center[:, None] + offsets
    return _extra(world, corners.reshape(-1, 3), np.arange(3 * count).reshape(-1, 3), "coplanar")


def huge_triangle(world: World, factor=100.0) -> World:
    """One triangle `factor` times larger than the world, slanted through it."""
    size = float(np.ptp(world.extent, axis=0).max()) * factor
    center = world.extent.mean(axis=0)
    corners = center + np.array([[-size, -0.2 * size, -size], [size, 0.1 * size, -size],
                                 [0.0, 0.1 * size, size]]) + np.array([0, 0.4, 0])
    return _extra(world, corners, [[0, 1, 2]], "huge")


def single_triangle() -> World:
    """One triangle, the size of the base room's floor, facing up."""
    return World([[0, 0, 0], [8, 0, 12], [8, 0, 0]], [[0, 1, 2]], name="single")


def empty_cell(world: World) -> World:
    """The base world and a far copy of its crate, so partitions have a large empty region."""
    crate = world.subset(np.flatnonzero(world.object_ids == 2))
    far = crate.transformed(1.0, (20.0, 0.0, 30.0))
    return _extra(world, far.vertices, far.triangles, "far_crate")


# Translations and scales of the base world (issue 7).
TRANSLATIONS = {"translate_1e3": 1e3, "translate_1e5": 1e5, "translate_1e7": 1e7}
SCALES = {"scale_1e-4": 1e-4, "scale_1e4": 1e4}


def world_cases() -> list:
    """Every stress world as a StressCase without cameras (see stress_cases for cameras)."""
    base = base_world()
    cases = [StressCase("base", base)]
    for name, shift in TRANSLATIONS.items():
        offset = np.full(3, shift)
        cases.append(StressCase(name, base.transformed(1.0, offset), 1.0, offset))
    for name, factor in SCALES.items():
        cases.append(StressCase(name, base.transformed(factor), factor))
    cases += [StressCase("slivers", slivers(base)), StressCase("zero_area", zero_area(base)),
              StressCase("duplicated", duplicated(base)),
              StressCase("coplanar_overlap", coplanar_overlap(base)),
              StressCase("huge_triangle", huge_triangle(base)),
              StressCase("single_triangle", single_triangle()),
              StressCase("empty_cell", empty_cell(base))]
    for case in cases:
        case.world.name = case.name
    return cases


# ---- cameras -----------------------------------------------------------------------------

def base_cameras(scale=1.0, offset=(0.0, 0.0, 0.0)) -> list:
    """Labelled cameras in base coordinates mapped by scale and offset: (label, Camera) list.

    Ordinary views plus the camera stresses: near 1e-4, far/near 1e7, fov 1 and 170, pitch +-90.
    near and far scale with the world, so a scaled world shows the same image.
    """
    offset = np.asarray(offset, dtype=np.float64)
    spots = [  # label, position, yaw, pitch, fov, near, far
        ("room_a", (4.0, 1.6, 10.5), 0.0, 0.0, 45.0, 0.1, 1000.0),
        ("through_door", (4.0, 1.6, 11.0), 10.0, -5.0, 45.0, 0.1, 1000.0),
        ("room_b", (7.0, 1.5, 1.0), 200.0, 10.0, 45.0, 0.1, 1000.0),
        ("outside", (4.0, 1.5, 30.0), 0.0, 0.0, 45.0, 0.1, 1000.0),
        ("near_1e-4", (4.0, 1.0, 3.4005), 0.0, 0.0, 45.0, 1e-4, 1000.0),
        ("far_near_1e7", (4.0, 1.6, 10.5), 15.0, -10.0, 45.0, 1e-4, 1e3),
        ("fov_1", (4.0, 1.0, 11.5), 0.0, 0.0, 1.0, 0.1, 1000.0),
        ("fov_170", (4.0, 1.5, 9.0), 30.0, 0.0, 170.0, 0.1, 1000.0),
        ("pitch_+90", (4.0, 1.5, 6.0), 0.0, 90.0, 45.0, 0.1, 1000.0),
        ("pitch_-90", (2.0, 2.5, 2.0), 37.0, -90.0, 45.0, 0.1, 1000.0),
    ]
    return [(label, Camera(np.asarray(p) * scale + offset, yaw, pitch, fov,
                           near=near * scale, far=far * scale))
            for label, p, yaw, pitch, fov, near, far in spots]


def partition_cameras(node_bounds, level_start, portal_points=None, world_extent=None,
                      scale=1.0) -> list:
    """Cameras exactly on partition planes, on node corners and on portal planes.

    node_bounds   : (N, 2, 3) float64 boxes of a partition (breadth-first)
    level_start   : (L + 1,) int first node of each level
    portal_points : (P, 3) float64 points on portal polygons, or None
    world_extent  : (2, 3) float64; cameras are kept inside it (default: the root box)
    scale         : world scale, for near/far
    returns list of (label, Camera)
    """
    node_bounds = np.asarray(node_bounds, dtype=np.float64).reshape(-1, 2, 3)
    extent = node_bounds[0] if world_extent is None else np.asarray(world_extent, dtype=np.float64)
    center = extent.mean(axis=0)
    near, far = 0.1 * scale, 1000.0 * scale
    cameras = []
    level1 = node_bounds[level_start[1]:level_start[2]] if len(level_start) > 2 else node_bounds[:0]
    # a child face strictly inside the extent is a partition plane
    faces = level1.reshape(-1, 3)
    inner = (faces > extent[0]) & (faces < extent[1])
    for axis in range(3):
        values = faces[inner[:, axis], axis]
        if len(values):
            eye = center.copy()
            eye[axis] = values[np.argmin(np.abs(values - center[axis]))]
            cameras.append((f"on_plane_{'xyz'[axis]}", Camera(eye, 30.0 * axis, 0.0,
                                                                 near=near, far=far)))
    deep = node_bounds[level_start[-2]:level_start[-1]] if len(level_start) > 1 else node_bounds
    corners = deep.reshape(-1, 3)
    strict = np.all((corners > extent[0]) & (corners < extent[1]), axis=1)
    if strict.any():
        eye = corners[strict][np.argmin(np.linalg.norm(corners[strict] - center, axis=1))]
        cameras.append(("node_corner", Camera(eye, 45.0, -20.0, near=near, far=far)))
    if portal_points is not None and len(portal_points):
        points = np.asarray(portal_points, dtype=np.float64).reshape(-1, 3)
        for k, (eye, yaw) in enumerate(zip([points.mean(axis=0), points[0]], [0.0, 180.0])):
            cameras.append((f"portal_plane_{k}", Camera(eye, yaw, 0.0, near=near, far=far)))
    return cameras


def stress_cases() -> list:
    """Every world case with the base cameras mapped into it (partition cameras come later,
    from the partition built per structure; see partition_cameras)."""
    cases = world_cases()
    for case in cases:
        case.cameras = base_cameras(case.scale, case.offset)
    return cases

"""Per-corner vertex arrays the renderer uploads: position, crease-angle normal, object colour.

Every triangle owns its three corners (vertex 3t+k is corner k of triangle t), so a triangle
keeps its face normal where the surface bends sharply and a smooth normal where it does not,
and batch b of B triangles is simply vertices 3bB .. 3(b+1)B - 1.
"""
from __future__ import annotations

import numpy as np

from ..device.profile import to_fixed

CREASE_DEGREES = 30.0
MAX_FAN = 64


def corner_normals(world, crease_degrees=CREASE_DEGREES) -> np.ndarray:
    """(T, 3, 3) float64 unit normal per triangle corner (crease-angle smoothing).

    A corner's normal is the area-weighted mean of the face normals of the triangles sharing
    its vertex whose normals lie within crease_degrees of its own face normal: curved meshes
    shade smoothly while walls, floors and box edges keep their face normals. Vertices shared
    by more than MAX_FAN triangles (rare fan centres) keep face normals to bound the work.
    """
    face = world.normals
    corners = world.triangles.ravel().astype(np.int64)  # corner c = 3 t + k
    order = np.argsort(corners, kind="stable")
    ends = np.flatnonzero(np.r_[corners[order][1:] != corners[order][:-1], True]) + 1
    starts = np.r_[0, ends[:-1]]
    sizes = ends - starts
    sizes_per_corner = np.repeat(np.where(sizes <= MAX_FAN, sizes, 1), sizes)
    starts_per_corner = np.repeat(np.where(sizes <= MAX_FAN, starts, 0), sizes)
    # Pairs (a, b) of corners on the same vertex, each corner paired with its whole fan.
    a = np.repeat(order, sizes_per_corner)
    offsets = np.arange(len(a)) - np.repeat(np.cumsum(sizes_per_corner) - sizes_per_corner,
                                            sizes_per_corner)
    b = order[np.repeat(starts_per_corner, sizes_per_corner) + offsets]
    big = np.repeat(sizes > MAX_FAN, sizes)[np.argsort(order)]  # per corner, in corner order
    b = np.where(big[a], a, b)  # fan centres: the corner pairs only with itself
    ta, tb = a // 3, b // 3
    keep = np.einsum("pc,pc->p", face[ta], face[tb]) >= np.cos(np.radians(crease_degrees))
    weighted = face[tb[keep]] * world.areas[tb[keep], None]
    summed = np.stack([np.bincount(a[keep], weighted[:, axis], minlength=len(corners))
                       for axis in range(3)], axis=1)
    length = np.linalg.norm(summed, axis=1, keepdims=True)
    fallback = np.repeat(face, 3, axis=0)
    result = np.where(length > 0, summed / np.where(length > 0, length, 1.0), fallback)
    return result.reshape(-1, 3, 3)


def object_colors(object_ids) -> np.ndarray:
    """(T, 4) uint8 RGBA material colour per triangle: one soft hue per object (golden angle)."""
    hue = (0.1 + np.asarray(object_ids, dtype=np.float64) * 0.6180339887) % 1.0
    saturation, value = 0.35, 0.9
    # HSV -> RGB, vectorised.
    sector = np.floor(hue * 6.0)
    f = hue * 6.0 - sector
    p = value * (1 - saturation)
    q = value * (1 - saturation * f)
    t = value * (1 - saturation * (1 - f))
    v = np.full_like(hue, value)
    table = np.stack([np.stack([v, t, np.full_like(hue, p)], 1),
                      np.stack([q, v, np.full_like(hue, p)], 1),
                      np.stack([np.full_like(hue, p), v, t], 1),
                      np.stack([np.full_like(hue, p), q, v], 1),
                      np.stack([t, np.full_like(hue, p), v], 1),
                      np.stack([v, np.full_like(hue, p), q], 1)])  # (6, T, 3)
    rgb = table[sector.astype(np.int64) % 6, np.arange(len(hue))]
    rgba = np.concatenate([rgb, np.ones((len(hue), 1))], axis=1)
    return np.rint(rgba * 255).astype(np.uint8)


def vertex_records(world, profile) -> np.ndarray:
    """(3T,) structured array, one record per corner: position, normal, colour.

    position and normal are float32, or int32 raw 16.16 under fixed16.16 (range-checked,
    ProfileError beyond +-32767). colour is 4 x uint8. The record is VERTEX_BYTES long.
    """
    component = np.int32 if profile.fixed else np.float32
    dtype = np.dtype([("position", component, 3), ("normal", component, 3),
                      ("color", np.uint8, 4)])
    records = np.empty(3 * world.triangle_count, dtype=dtype)
    records["position"] = profile.vertex_positions(world.corners.reshape(-1, 3),
                                                   f"world {world.name!r}")
    normals = corner_normals(world).reshape(-1, 3)
    records["normal"] = to_fixed(normals) if profile.fixed else normals
    records["color"] = np.repeat(object_colors(world.object_ids), 3, axis=0)
    return records


def vertex_format(profile) -> str:
    """moderngl buffer format of vertex_records."""
    return "3i 3i 4f1" if profile.fixed else "3f 3f 4f1"

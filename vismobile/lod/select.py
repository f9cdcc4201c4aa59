"""Per-frame level selection by projected error in pixels, among only what culling kept.

The terrain methods' rule (terrain/tiles.py): a level of object-space error E is good enough
when lambda_b * E / d < tau, with d the distance from the eye to the nearest point of the
object's box and lambda_b the off-axis pixel scale (tiles.pixel_scale), so the error projects
below tau pixels anywhere on the screen. Each object culling kept gets its coarsest good-enough
level; tau <= 0 keeps every object at level 0 (the full-detail frame, bit for bit).

The work is proportional to the triangles culling kept (one numba pass over them with stamp
arrays, a sort of the level triangles drawn), never to the world.
"""
from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

from ..terrain.tiles import pixel_scale
from .chains import LodChains


@dataclass
class Selection:
    """One frame's choice.

    triangles : (S,) int64 sorted ids into the render world (lod/chains.render_world): kept
                originals of objects drawn at level 0, then T + level triangle ids
    objects   : (k,) int64 objects culling kept; levels (k,) int64 their level (0 = full)
    replaced  : originals culling kept that a level replaced; added: level triangles drawn
    """

    triangles: np.ndarray
    objects: np.ndarray
    levels: np.ndarray
    replaced: int = 0
    added: int = 0


class LodSelector:
    """Selects levels for one world's chains at one screen resolution (width, height)."""

    def __init__(self, world, chains: LodChains, resolution):
        self.chains = chains
        self.resolution = tuple(resolution)
        self.object_ids = np.ascontiguousarray(world.object_ids, dtype=np.int32)
        self.t = world.triangle_count
        objects = len(world.object_names)
        # rank[t]: position of t among its object's triangles in ascending id order.
        order = np.argsort(world.object_ids, kind="stable")
        sizes = np.bincount(world.object_ids, minlength=objects)
        rank = np.empty(self.t, np.int32)
        rank[order] = np.arange(self.t) - np.repeat(np.cumsum(sizes) - sizes, sizes)
        self.rank = rank
        counts = np.bincount(chains.level_object, minlength=objects)
        self.first = np.r_[0, np.cumsum(counts)].astype(np.int64)  # entries of each object
        self.numbers = chains.level_numbers().astype(np.int64)
        self.boxes = np.ascontiguousarray(chains.object_bounds, dtype=np.float64)
        self.error = np.ascontiguousarray(chains.level_error, dtype=np.float64)
        # Per-frame stamps (nothing is cleared between frames) and each object's choice.
        self.stamp_object = np.full(objects, -1, np.int32)
        self.choice = np.full(objects, -1, np.int64)
        self.stamp_level = np.full(chains.triangle_count, -1, np.int32)
        self.frame = 0

    @property
    def nbytes(self) -> int:
        """Bytes of the runtime tables beside the stored chains."""
        return int(self.rank.nbytes + self.first.nbytes + self.stamp_object.nbytes
                   + self.choice.nbytes + self.stamp_level.nbytes)

    def select(self, triangles, camera, tau: float) -> Selection:
        """Selection of the culled triangles (sorted unique original ids) seen from camera."""
        ids = np.ascontiguousarray(triangles, dtype=np.int64)
        _, scale = pixel_scale(camera, self.resolution)
        self.frame += 1
        c = self.chains
        out, objects, levels, replaced, added = _select(
            ids, self.object_ids, self.first, self.numbers, self.error, self.boxes,
            np.asarray(camera.eye, dtype=np.float64), float(scale), float(max(tau, 0.0)),
            c.owner, c.owner_start, self.rank, c.extra_start, c.extra_tri, self.t,
            self.stamp_object, self.choice, self.stamp_level, self.frame)
        return Selection(out, objects, levels, int(replaced), int(added))


@numba.njit(cache=True)
def _select(ids, object_ids, first, numbers, error, boxes, eye, scale, tau, owner, owner_start,
            rank, extra_start, extra_tri, t, stamp_object, choice, stamp_level, frame):
    k = len(ids)
    objects = np.empty(k, np.int64)
    n_objects = 0
    for i in range(k):  # each object culling kept: its coarsest level below tau pixels
        o = object_ids[ids[i]]
        if stamp_object[o] == frame:
            continue
        stamp_object[o] = frame
        objects[n_objects] = o
        n_objects += 1
        gap2 = 0.0
        for a in range(3):
            g = max(boxes[o, 0, a] - eye[a], eye[a] - boxes[o, 1, a], 0.0)
            gap2 += g * g
        d = np.sqrt(gap2)
        chosen = -1
        for e in range(first[o], first[o + 1]):  # errors do not decrease along a chain
            if scale * error[e] < tau * d:
                chosen = e
            else:
                break
        choice[o] = chosen
    kept = np.empty(k, np.int64)
    n_kept = 0
    drawn = np.empty(16 + 2 * k, np.int64)
    n_drawn = 0
    replaced = 0
    for i in range(k):
        tri = ids[i]
        e = choice[object_ids[tri]]
        if e < 0:
            kept[n_kept] = tri
            n_kept += 1
            continue
        replaced += 1
        slot = owner_start[e] + rank[tri]
        for j in range(extra_start[slot] - 1, extra_start[slot + 1]):
            level = owner[slot] if j < extra_start[slot] else extra_tri[j]
            if stamp_level[level] == frame:
                continue
            stamp_level[level] = frame
            if n_drawn == len(drawn):
                grown = np.empty(2 * len(drawn), np.int64)
                grown[:n_drawn] = drawn
                drawn = grown
            drawn[n_drawn] = level
            n_drawn += 1
    levels_drawn = np.sort(drawn[:n_drawn]) + t
    out = np.empty(n_kept + n_drawn, np.int64)
    out[:n_kept] = kept[:n_kept]
    out[n_kept:] = levels_drawn
    present = np.sort(objects[:n_objects])
    levels = np.zeros(n_objects, np.int64)
    for i in range(n_objects):
        e = choice[present[i]]
        levels[i] = numbers[e] if e >= 0 else 0
    return out, present, levels, replaced, n_drawn

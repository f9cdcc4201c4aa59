"""Discrete level-of-detail chains of a world's objects, as flat arrays (stored in the .vmp).

Level 0 of every object is its own triangles. Level l >= 1 of an object is another index set
over the world's vertices (the simplifier keeps a subset of them, lod/simplify.py), with its
object-space error (world units). Culling keeps speaking original triangle ids; each original
triangle of an object is tied, per level, to the level triangle nearest to it (and each level
triangle to at least one original), so a level triangle is drawn when culling kept one of the
originals tied to it (lod/select.py).

Arrays (E levels in all, M level triangles, P = sum over levels of the object's triangles):
  triangles    (M, 3) int32  vertex indices of the level triangles, level after level
  level_object (E,) int32    object of each level; levels of an object are contiguous,
                             coarser after finer
  level_start  (E + 1,) int64 level e holds triangles[level_start[e]:level_start[e + 1]]
  level_error  (E,) float64  object-space error of the level (non-decreasing per object)
  owner        (P,) int32    level e's entry for the object's k-th original triangle (k in
                             ascending id order) at owner[owner_start[e] + k]: a level triangle
  owner_start  (E + 1,) int64
  extra_start  (P + 1,) int32 the original in owner slot p is also tied to level triangles
  extra_tri    (Q,) int32    extra_tri[extra_start[p]:extra_start[p + 1]] (those nearest to
                             points halfway to its corners, and those whose spread sample
                             points lie nearest to it)
  object_bounds (O, 2, 3) float64 box of each object's original triangles
In a Partition they are extras named "lod_" + name (Partition.extras; the .vmp stores each as a
CRC-checked section and profile.partition_bytes counts them against the heap).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..world import World

FIELDS = ("triangles", "level_object", "level_start", "level_error", "owner", "owner_start",
          "extra_start", "extra_tri", "object_bounds")
PREFIX = "lod_"


@dataclass(eq=False)
class LodChains:
    """The chains of one world (see the module docstring for every array)."""

    triangles: np.ndarray
    level_object: np.ndarray
    level_start: np.ndarray
    level_error: np.ndarray
    owner: np.ndarray
    owner_start: np.ndarray
    extra_start: np.ndarray
    extra_tri: np.ndarray
    object_bounds: np.ndarray

    @property
    def level_count(self) -> int:
        return len(self.level_object)

    @property
    def triangle_count(self) -> int:
        return len(self.triangles)

    def levels_of(self, obj: int) -> np.ndarray:
        """(k,) int64 level entries of object obj, finest first."""
        return np.flatnonzero(self.level_object == obj)

    def level_numbers(self) -> np.ndarray:
        """(E,) int64 1-based level number of each entry within its object."""
        first = np.r_[True, self.level_object[1:] != self.level_object[:-1]]
        starts = np.maximum.accumulate(np.where(first, np.arange(self.level_count), 0))
        return np.arange(self.level_count) - starts + 1

    @property
    def nbytes(self) -> int:
        return int(sum(getattr(self, name).nbytes for name in FIELDS))

    def to_extras(self) -> dict:
        """{"lod_" + field: array} for Partition.extras."""
        return {PREFIX + name: getattr(self, name) for name in FIELDS}

    @classmethod
    def from_extras(cls, extras) -> "LodChains | None":
        """The chains held in a partition's extras, or None when it holds none."""
        if not extras or PREFIX + "triangles" not in extras:
            return None
        missing = [name for name in FIELDS if PREFIX + name not in extras]
        if missing:
            raise ValueError(f"level-of-detail arrays missing: {', '.join(missing)}")
        return cls(**{name: np.asarray(extras[PREFIX + name]) for name in FIELDS})

    def check(self, world) -> None:
        """ValueError when the arrays do not fit together or do not fit the world."""
        t, v = world.triangle_count, len(world.vertices)
        objects = len(world.object_names)
        e, m = self.level_count, self.triangle_count
        if self.triangles.shape != (m, 3) or (m and (self.triangles.min() < 0
                                                     or self.triangles.max() >= v)):
            raise ValueError("level triangles index outside the world's vertices")
        for name, size in (("level_start", e + 1), ("owner_start", e + 1), ("level_error", e)):
            if getattr(self, name).shape != (size,):
                raise ValueError(f"lod {name} has the wrong length")
        if self.object_bounds.shape != (objects, 2, 3):
            raise ValueError("lod object_bounds do not match the world's objects")
        if e and (self.level_object.min() < 0 or self.level_object.max() >= objects
                  or np.any(np.diff(self.level_object) < 0)):
            raise ValueError("lod levels name unknown objects or are out of order")
        for name, end in (("level_start", m), ("owner_start", len(self.owner))):
            starts = getattr(self, name)
            if starts[0] != 0 or starts[-1] != end or np.any(np.diff(starts) < 0):
                raise ValueError(f"lod {name} is not a range table")
        sizes = np.bincount(world.object_ids, minlength=objects)
        if not np.array_equal(np.diff(self.owner_start), sizes[self.level_object]):
            raise ValueError("lod owner table does not cover each object's triangles")
        if not np.all(np.isfinite(self.level_error)) or np.any(self.level_error < 0):
            raise ValueError("lod errors must be finite and non-negative")
        level_of = np.repeat(np.arange(e), np.diff(self.level_start))
        if len(self.owner):
            owner_level = np.repeat(np.arange(e), np.diff(self.owner_start))
            if self.owner.min() < 0 or self.owner.max() >= m or np.any(
                    level_of[self.owner] != owner_level):
                raise ValueError("lod owners point outside their level")
        extra = self.extra_start
        if (extra.shape != (len(self.owner) + 1,) or extra[0] != 0
                or extra[-1] != len(self.extra_tri) or np.any(np.diff(extra) < 0)):
            raise ValueError("lod extra ties are not a range table over the owner slots")
        if len(self.extra_tri):
            slot_level = np.repeat(np.arange(e), np.diff(self.owner_start))
            tie_level = np.repeat(slot_level, np.diff(extra))
            if (self.extra_tri.min() < 0 or self.extra_tri.max() >= m
                    or np.any(level_of[self.extra_tri] != tie_level)):
                raise ValueError("lod extra ties point outside their level")


def object_bounds(world) -> np.ndarray:
    """(O, 2, 3) float64 box of each object's triangles (empty objects: a NaN box)."""
    objects = len(world.object_names)
    low = np.full((objects, 3), np.inf)
    high = np.full((objects, 3), -np.inf)
    np.minimum.at(low, world.object_ids, world.bounds[:, 0])
    np.maximum.at(high, world.object_ids, world.bounds[:, 1])
    empty = ~np.isfinite(low).all(axis=1)
    low[empty], high[empty] = np.nan, np.nan
    return np.stack([low, high], axis=1)


def render_world(world, chains: LodChains) -> World:
    """The world the renderer draws with LOD: its T triangles (ids 0..T-1, unchanged), then
    the M level triangles as ids T..T+M-1.

    Each level gets its own copy of the vertex array (vertices l*V ..), so the renderer's
    crease normals (render/vertex_data.py, which smooth across shared vertices) are computed
    per level and the original triangles shade exactly as in the world alone.
    """
    if chains is None or not chains.triangle_count:
        return world
    numbers = chains.level_numbers()
    per_triangle = np.repeat(numbers, np.diff(chains.level_start))
    copies = int(numbers.max()) + 1
    v = len(world.vertices)
    vertices = np.concatenate([world.vertices] * copies)
    level_tris = chains.triangles.astype(np.int64) + (per_triangle * v)[:, None]
    ids = np.repeat(chains.level_object, np.diff(chains.level_start))
    return World(vertices, np.concatenate([world.triangles, level_tris]),
                 np.concatenate([world.object_ids, ids]), list(world.object_names), world.name)

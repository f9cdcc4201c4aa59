"""Worlds larger than memory: a triangle world kept in .npy files and memory-mapped.

A world directory holds vertices.npy (V, 3) float32, triangles.npy (T, 3) int32,
object_ids.npy (T,) int32 and world.json (name, object names). It is written piece by piece
(`write_world_dir`) and read through numpy's memory maps, so neither side holds the world in
memory; the out-of-core partitioner (partition/external.py) walks it in triangle chunks.
Unlike `World.from_obj`, nothing is dropped: zero-area triangles stay (the writer's job).
"""
from __future__ import annotations

import hashlib
import json
import os
from pathlib import Path

import numpy as np

from ..files.atomic import atomic_write_bytes, make_dirs, temp_path
from ..errors import WorldError
from .world import World

FILES = ("vertices.npy", "triangles.npy", "object_ids.npy", "world.json")


def write_world_dir(path, parts, name="world", object_names=()) -> tuple:
    """Write a world directory from an iterable of (vertices (v, 3), triangles (t, 3) local to
    the part, object_ids (t,)) parts without holding more than one part in memory.

    Two passes over `parts` (it must be a callable returning a fresh iterator): the first
    counts, the second writes into preallocated memory maps. Files appear atomically (written
    under temporary names, then renamed). Returns (vertex count, triangle count).
    """
    path = make_dirs(path)
    nv = nt = 0
    for v, t, _ in parts():
        nv, nt = nv + len(v), nt + len(t)
    tmp = {name: temp_path(path / name) for name in FILES[:3]}
    open_map = np.lib.format.open_memmap
    vertices = open_map(tmp["vertices.npy"], "w+", np.float32, (nv, 3))
    triangles = open_map(tmp["triangles.npy"], "w+", np.int32, (nt, 3))
    ids = open_map(tmp["object_ids.npy"], "w+", np.int32, (nt,))
    vo = to = 0
    for v, t, o in parts():
        vertices[vo:vo + len(v)] = v
        triangles[to:to + len(t)] = np.asarray(t, dtype=np.int64) + vo
        ids[to:to + len(t)] = o
        vo, to = vo + len(v), to + len(t)
    for array in (vertices, triangles, ids):
        array.flush()
    del vertices, triangles, ids
    for final, temporary in tmp.items():
        os.replace(temporary, path / final)
    atomic_write_bytes(path / "world.json", json.dumps(
        {"name": name, "object_names": list(object_names)}).encode())
    return nv, nt


class MappedWorld:
    """A world whose arrays are memory maps: vertices (V, 3) float32, triangles (T, 3) int32,
    object_ids (T,) int32. It offers what partitioning and culling read (triangle count,
    extent, chunks of corners; `triangle_corners` for any ids); vfc, tbfc, cbfc, cbfc_thesis,
    cone and occlusion run on it; stages that keep per-triangle areas or planes of the whole
    world (occlusion_thesis, portals) need a World."""

    def __init__(self, vertices, triangles, object_ids, object_names=(), name="world",
                 extent=None, digest=None):
        self.vertices, self.triangles, self.object_ids = vertices, triangles, object_ids
        self.object_names = list(object_names)
        self.name = name
        self._extent = None if extent is None else np.asarray(extent, dtype=np.float64)
        self._digest = digest
        self.path = None  # set by open(): workers re-map the directory instead of copying

    def __reduce__(self):
        if self.path is not None:
            return MappedWorld.open, (self.path,)
        return MappedWorld, (np.asarray(self.vertices), np.asarray(self.triangles),
                             np.asarray(self.object_ids), self.object_names, self.name,
                             self._extent, self._digest)

    @classmethod
    def open(cls, path) -> "MappedWorld":
        """Map a world directory. Raises WorldError naming the file when one is missing or
        malformed."""
        path = Path(path)
        arrays = []
        for name, dtype, width in (("vertices.npy", np.float32, 3), ("triangles.npy", np.int32, 3),
                                   ("object_ids.npy", np.int32, 0)):
            try:
                array = np.load(path / name, mmap_mode="r")
            except (OSError, ValueError) as error:
                raise WorldError(path / name, f"cannot map world array: {error}") from None
            shape_ok = array.ndim == (2 if width else 1) and (not width or array.shape[1] == width)
            if array.dtype != dtype or not shape_ok:
                raise WorldError(path / name, f"expected {np.dtype(dtype).name} of shape "
                                              f"{'(n, 3)' if width else '(n,)'}, got "
                                              f"{array.dtype} {array.shape}")
            arrays.append(array)
        if len(arrays[2]) != len(arrays[1]):
            raise WorldError(path / "object_ids.npy", "one object id per triangle expected")
        try:
            info = json.loads((path / "world.json").read_text())
            names, name = list(info["object_names"]), str(info["name"])
        except (OSError, ValueError, KeyError, TypeError) as error:
            raise WorldError(path / "world.json", f"cannot read world description: {error}") from None
        world = cls(*arrays, names, name)
        world.path = str(path)
        return world

    @classmethod
    def of(cls, world: World) -> "MappedWorld":
        """The same interface over an in-memory World (float32 vertices must be exact)."""
        vertices = world.vertices.astype(np.float32)
        if not np.array_equal(vertices, world.vertices):
            raise ValueError("world vertices are not float32 values")
        return cls(vertices, world.triangles, world.object_ids, world.object_names, world.name)

    @property
    def triangle_count(self) -> int:
        return len(self.triangles)

    def chunks(self, size: int):
        """Yield (start, corners (c, 3, 3) float64) for consecutive triangle ranges of `size`."""
        return corner_chunks(self, size)

    @property
    def extent(self) -> np.ndarray:
        """(2, 3) float64 box around every referenced vertex (one chunked pass, then kept)."""
        if self._extent is None:
            low, high = np.full(3, np.inf), np.full(3, -np.inf)
            for _, corners in self.chunks(1 << 20):
                low = np.minimum(low, corners.min(axis=(0, 1)))
                high = np.maximum(high, corners.max(axis=(0, 1)))
            self._extent = np.stack([low, high]) if self.triangle_count else np.zeros((2, 3))
        return self._extent

    def digest(self) -> bytes:
        """World.digest() of the same world (float64 vertices), computed in chunks."""
        if self._digest is None:
            h = hashlib.sha256()
            step = 1 << 20
            for array, dtype in ((self.vertices, "<f8"), (self.triangles, "<i4"),
                                 (self.object_ids, "<i4")):
                for start in range(0, len(array), step):
                    h.update(np.ascontiguousarray(array[start:start + step], dtype).tobytes())
            self._digest = h.digest()
        return self._digest

    def load(self) -> World:
        """The whole world in memory (small worlds: tests compare against in-memory builds)."""
        return World(np.asarray(self.vertices, dtype=np.float64), np.asarray(self.triangles),
                     np.asarray(self.object_ids), list(self.object_names), self.name)


def triangle_corners(world, ids) -> np.ndarray:
    """(n, 3, 3) float64 corners of the triangles `ids` (int array or slice) of a World or a
    MappedWorld, read from its vertices and triangles: the same values as World.corners[ids]."""
    tris = np.asarray(world.triangles[ids])
    return np.asarray(world.vertices)[tris].astype(np.float64, copy=False)


def corner_chunks(world, size: int):
    """Yield (start, corners (c, 3, 3) float64) for consecutive triangle ranges of `size` of a
    World or a MappedWorld: per-triangle tables of any world are built chunk by chunk."""
    for start in range(0, world.triangle_count, size):
        yield start, triangle_corners(world, slice(start, start + size))

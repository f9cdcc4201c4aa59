"""The world model: a triangle soup with per-triangle normals, areas, boxes and object ids."""
from __future__ import annotations

import hashlib
import io
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..files.atomic import atomic_write_bytes  # noqa: F401  (re-exported: older imports)
from ..errors import WorldError

# Triangles whose doubled area is below this fraction of the world's squared extent are dropped.
ZERO_AREA_RELATIVE = 1e-14
# Rows written per np.savetxt call by World.to_obj (a progress step).
OBJ_CHUNK = 200_000


@dataclass(eq=False, repr=False)
class World:
    """Triangles of a scene; every array is indexed by triangle id.

    vertices   : (V, 3) float64
    triangles  : (T, 3) int32, indices into vertices, counter-clockwise = front
    object_ids : (T,) int32, index into object_names
    derived    : corners (T, 3, 3), normals (T, 3) unit (zero for degenerate triangles),
                 areas (T,), bounds (T, 2, 3) per-triangle AABB, centroids (T, 3); all float64
    """

    vertices: np.ndarray
    triangles: np.ndarray
    object_ids: np.ndarray | None = None
    object_names: list = field(default_factory=list)
    name: str = "world"
    # "tjunctions" after world/tjunctions.repair_tjunctions (a .vmp's header records it)
    repair = None

    def __post_init__(self):
        self.vertices = np.ascontiguousarray(self.vertices, dtype=np.float64).reshape(-1, 3)
        self.triangles = np.ascontiguousarray(self.triangles, dtype=np.int32).reshape(-1, 3)
        if self.object_ids is None:
            self.object_ids = np.zeros(len(self.triangles), dtype=np.int32)
        self.object_ids = np.ascontiguousarray(self.object_ids, dtype=np.int32)
        if not self.object_names:
            count = int(self.object_ids.max()) + 1 if len(self.object_ids) else 1
            self.object_names = [f"object{i}" for i in range(count)]
        self._extent = None
        self._derive()

    def _derive(self):
        corners = self.vertices[self.triangles]  # (T, 3, 3)
        self.corners = corners  # kept: stages read it every frame
        self.normals, length = unit_normals(corners)
        self.areas = 0.5 * length
        self.bounds = np.stack([corners.min(axis=1), corners.max(axis=1)], axis=1)  # (T, 2, 3)
        self.centroids = corners.mean(axis=1)

    @property
    def triangle_count(self) -> int:
        return len(self.triangles)

    def __repr__(self) -> str:
        low, high = self.extent
        size = " x ".join(f"{d:.4g}" for d in high - low)
        return (f"World({self.name!r}: {self.triangle_count:,} triangles, "
                f"{len(self.object_names)} objects, {size})")

    @property
    def extent(self) -> np.ndarray:
        """(2, 3) float64 box around every referenced vertex (computed once: np.unique over
        the indices took 107 ms on W2, and the viewer and playback ask on every start)."""
        if self._extent is None:
            if not len(self.triangles):
                self._extent = np.zeros((2, 3))
            else:
                corners = self.corners.reshape(-1, 3)
                self._extent = np.stack([corners.min(axis=0), corners.max(axis=0)])
            self._extent.flags.writeable = False
        return self._extent

    def digest(self) -> bytes:
        """32-byte SHA-256 of the geometry; partition files carry it to refuse a different world."""
        h = hashlib.sha256()
        h.update(np.ascontiguousarray(self.vertices, "<f8").tobytes())
        h.update(np.ascontiguousarray(self.triangles, "<i4").tobytes())
        h.update(np.ascontiguousarray(self.object_ids, "<i4").tobytes())
        return h.digest()

    def subset(self, triangle_ids) -> "World":
        """World of the given triangles only (same vertex array, object names kept)."""
        ids = np.asarray(triangle_ids, dtype=np.int64)
        return World(self.vertices, self.triangles[ids], self.object_ids[ids],
                     list(self.object_names), self.name)

    def transformed(self, scale=1.0, offset=(0.0, 0.0, 0.0)) -> "World":
        """World with vertices scaled about the origin, then translated."""
        v = self.vertices * float(scale) + np.asarray(offset, dtype=np.float64)
        return World(v, self.triangles, self.object_ids, list(self.object_names), self.name)

    def quantized(self, mode: str) -> "World":
        """The world as a device in arithmetic `mode` (float64, float32, fixed16.16) stores it:
        vertices rounded to the mode, triangle ids unchanged (zero-area triangles made by the
        rounding are kept, so ids still match this world).

        Raises ProfileError (arithmetic.check_resolution) when the mode cannot hold or resolve it.
        """
        from ..geometry import arithmetic

        what = f"world {self.name}"
        arithmetic.check_resolution(self.vertices[np.unique(self.triangles)], mode, what)
        vertices = arithmetic.quantize(self.vertices, mode, what)
        return World(vertices, self.triangles, self.object_ids, list(self.object_names),
                     self.name)

    @classmethod
    def concatenate(cls, parts, name="world") -> "World":
        """One world of several, object ids renumbered so names stay unique per part."""
        vertices, triangles, ids, names = [], [], [], []
        offset = 0
        for part in parts:
            vertices.append(part.vertices)
            triangles.append(part.triangles + offset)
            ids.append(part.object_ids + len(names))
            names.extend(part.object_names)
            offset += len(part.vertices)
        return cls(np.concatenate(vertices), np.concatenate(triangles),
                   np.concatenate(ids), names, name)

    # ---- OBJ I/O -------------------------------------------------------------------------
    @classmethod
    def from_obj(cls, path) -> "World":
        """Load an OBJ through trimesh; groups (o/g) become object ids.

        Raises WorldError naming the file (and line) on missing, empty, unparsable, non-finite,
        out-of-range or fully degenerate input. Zero-area triangles are dropped with a warning.
        """
        from ..files.obj import load_obj  # trimesh stays out of the import path of the runtime

        path = Path(path)
        vertices, triangles, object_ids, names = load_obj(path)
        world = cls.from_arrays(vertices, triangles, object_ids, names, path)
        if not path.name.lower().endswith(".gz"):
            world.obj_source_bytes = path.stat().st_size  # obj_bytes: the file as given
        return world

    @classmethod
    def from_file(cls, path) -> "World":
        """Load a mesh file: OBJ, PLY, STL, OFF, glTF or GLB, each optionally gzip-compressed
        (a terrain .vmt too: files.loader.load_world, which sits above both World and terrain/).

        OBJ groups (o/g) and the meshes of a scene (moved by their node transforms) become
        objects. Raises WorldError naming the file on unknown formats and bad input.
        """
        from ..files.meshfile import load_mesh, mesh_format

        path = Path(path)
        if mesh_format(path) == "obj":
            return cls.from_obj(path)
        return cls.from_arrays(*load_mesh(path), path)

    @classmethod
    def from_trimesh(cls, geometry, name="world") -> "World":
        """World of a trimesh.Trimesh (one object) or trimesh.Scene (one object per mesh node,
        moved by the node's transform); zero-area triangles dropped with a warning."""
        from ..files.meshfile import flatten

        vertices, triangles, object_ids, names = flatten(geometry, f"<{name}>")
        world = cls.from_arrays(vertices, triangles, object_ids, names, f"<{name}>")
        world.name = name
        return world

    @classmethod
    def from_arrays(cls, vertices, triangles, object_ids, names, path="<arrays>") -> "World":
        """World from raw arrays, dropping zero-area and repeated triangles with a warning.

        A repeated triangle (the same corners in the same cyclic order) draws nothing new
        but multiplies every structure's references, so only its first copy is kept.
        """
        base = Path(str(path)).name
        base = base[:-3] if base.lower().endswith(".gz") else base  # "cow.obj.gz" -> "cow"
        world = cls(vertices, triangles, object_ids, list(names), Path(base).stem)
        scale = float(np.ptp(world.extent, axis=0).max()) if world.triangle_count else 0.0
        size = max(scale, 1e-300)
        with np.errstate(over="ignore", invalid="ignore"):
            # divided, not squared: a squared scale overflows past 1e154
            keep = world.areas * 2.0 / size / size > ZERO_AREA_RELATIVE
        dropped = int((~keep).sum())
        repeated = _repeated(world.triangles) & keep
        if dropped:
            warnings.warn(f"{path}: dropped {dropped} zero-area triangle(s)", stacklevel=2)
        if repeated.any():
            warnings.warn(f"{path}: dropped {int(repeated.sum())} repeated triangle(s)",
                          stacklevel=2)
        if dropped or repeated.any():
            world = world.subset(np.flatnonzero(keep & ~repeated))
        if world.triangle_count == 0:
            raise WorldError(path, "no triangles left after dropping zero-area ones"
                             if dropped else "no triangles")
        return world

    def to_obj(self, path, digits=None, progress=None) -> None:
        """Write a deterministic OBJ (one `o` record per object), atomically. Coordinates with
        `digits` significant digits; None: exact (6 when those read back to the same doubles,
        else 17). progress: optional callable(done, total) over vertices plus triangles."""
        atomic_write_bytes(path, self.obj_text(digits, progress))

    def obj_bytes(self) -> int:
        """Bytes of the world's OBJ: the file it was read from (an uncompressed OBJ, also
        after a repair), else what to_obj writes (a PVS budget is a share of it)."""
        given = getattr(self, "obj_source_bytes", None)
        return int(given) if given is not None else len(self.obj_text())

    def obj_text(self, digits=None, progress=None) -> bytes:
        """The OBJ file to_obj writes, as bytes (a PVS budget is a share of its size)."""
        buffer = io.StringIO()
        buffer.write(f"# vismobile world {self.name}: {self.triangle_count} triangles\n")
        if digits is None:
            short = np.char.mod("%.6g", self.vertices).astype(np.float64)
            digits = 6 if np.array_equal(short, self.vertices) else 17
        total = len(self.vertices) + len(self.triangles)
        done = 0

        def rows(array, fmt):  # in chunks, so that a long export can say how far it is
            nonlocal done
            for first in range(0, len(array), OBJ_CHUNK):
                np.savetxt(buffer, array[first:first + OBJ_CHUNK], fmt=fmt)
                done += len(array[first:first + OBJ_CHUNK])
                if progress is not None:
                    progress(done, total)

        rows(self.vertices, f"v %.{digits}g %.{digits}g %.{digits}g")
        order = np.argsort(self.object_ids, kind="stable")
        ids = self.object_ids[order]
        starts = np.flatnonzero(np.r_[True, ids[1:] != ids[:-1]]) if len(ids) else []
        ends = list(starts[1:]) + [len(ids)]
        for start, end in zip(starts, ends):
            buffer.write(f"o {self.object_names[ids[start]]}\n")
            rows(self.triangles[order[start:end]] + 1, "f %d %d %d")
        return buffer.getvalue().encode("ascii")


def unit_normals(corners) -> tuple:
    """(normals (T, 3) unit float64, zero for degenerate triangles; doubled areas (T,) float64)
    of corners (T, 3, 3) float64: the World's own arithmetic, so a chunk of a world gets the
    same bits as the whole."""
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        # coordinates past ~1e154 overflow to infinite areas instead of raising
        cross = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
        length = np.linalg.norm(cross, axis=1)
        normals = cross / length[:, None]
    return np.where(length[:, None] > 0, normals, 0.0), length


def _repeated(triangles) -> np.ndarray:
    """(T,) bool: True for every later copy of a triangle (same corners, same cyclic order)."""
    t = np.asarray(triangles, dtype=np.int64)
    if not len(t):
        return np.zeros(0, dtype=bool)
    roll = np.argmin(t, axis=1)
    rows = np.arange(len(t))
    canon = np.stack([t[rows, (roll + k) % 3] for k in range(3)], axis=1)
    _, first = np.unique(canon, axis=0, return_index=True)
    out = np.ones(len(t), dtype=bool)
    out[first] = False
    return out

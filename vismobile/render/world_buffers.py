"""A world uploaded once: one vertex buffer per uint16 batch and one dynamic index buffer."""
from __future__ import annotations

import weakref

import numpy as np
from numba import njit

from ..device.profile import to_fixed
from .batches import batch_count, batch_indices
from .context import gl_context
from .shaders import sources
from .vertex_data import vertex_format, vertex_records

_CACHE = weakref.WeakKeyDictionary()  # world -> {(vertex_format, batch_triangles): WorldBuffers}
_PROGRAMS = {}


def program(kind: str, fmt: str):
    """Cached shader program ("shaded" or "item") for a vertex format."""
    key = (kind, fmt)
    if key not in _PROGRAMS:
        vertex, fragment = sources(kind, fmt)
        _PROGRAMS[key] = gl_context().program(vertex_shader=vertex, fragment_shader=fragment)
    return _PROGRAMS[key]


class WorldBuffers:
    """GL buffers of one world under one profile's vertex format and batch size.

    vbos    : list of nb buffers, batch b holds corners of triangles b*B .. (b+1)*B - 1
    ibo     : dynamic uint16 index buffer sized for every triangle at once
    nbytes  : bytes of all buffers
    """

    def __init__(self, world, profile):
        ctx = gl_context()
        self.world_name = world.name
        self.triangle_count = world.triangle_count
        self.batch_triangles = profile.batch_triangles
        self.format = vertex_format(profile)
        self.vertex_format = profile.vertex_format
        records = vertex_records(world, profile)  # raises ProfileError before any upload
        self.profile = profile
        self._record_dtype = records.dtype
        self._colors = records["color"][::3].copy()  # (T, 4) uint8, for move()
        self.batches = batch_count(self.triangle_count, self.batch_triangles)
        step = 3 * self.batch_triangles
        self.vbos = [ctx.buffer(records[b * step:(b + 1) * step].tobytes())
                     for b in range(self.batches)]
        self.ibo = ctx.buffer(reserve=max(6 * self.triangle_count, 2), dynamic=True)
        self.nbytes = records.nbytes + self.ibo.size
        self._arrays = {}

    def vertex_arrays(self, kind: str) -> list:
        """One vertex array per batch for program kind "shaded", "item" or "flat", sharing
        self.ibo."""
        if kind not in self._arrays:
            ctx = gl_context()
            prog = program(kind, self.vertex_format)
            if kind in ("item", "flat"):
                layout = f"{self.format.split()[0]} 16x"  # skip normal (12 B) and colour (4 B)
                self._arrays[kind] = [
                    ctx.vertex_array(prog, [(vbo, layout, "in_position")], index_buffer=self.ibo,
                                     index_element_size=2) for vbo in self.vbos]
            else:
                self._arrays[kind] = [
                    ctx.vertex_array(prog, [(vbo, self.format, "in_position", "in_normal",
                                             "in_color")], index_buffer=self.ibo,
                                     index_element_size=2) for vbo in self.vbos]
        return self._arrays[kind]

    def move(self, triangles, corners) -> int:
        """Rewrite the records of moved triangles (issue 25: a posed world's moving objects):
        ids (n,) int64, corners (n, 3, 3) float64 where they stand now. Positions in the
        profile's vertex format, face normals (a moving triangle is shaded flat), colours
        kept. One buffer write per run of consecutive ids within a batch; returns the writes.
        Cost: O(n), never the world."""
        ids = np.asarray(triangles, dtype=np.int64).ravel()
        if not len(ids):
            return 0
        corners = np.ascontiguousarray(corners, dtype=np.float64).reshape(-1, 3, 3)
        # A record is 7 four-byte slots: position (3), normal (3), colour (4 x uint8 = 1).
        fixed = self._record_dtype["position"].base == np.int32
        slots = np.empty((3 * len(ids), 7), dtype=np.int32 if fixed else np.float32)
        normals = _face_normals(corners)
        if fixed:
            slots[:, :3] = self.profile.vertex_positions(corners.reshape(-1, 3),
                                                         f"world {self.world_name!r}")
            slots[:, 3:6] = to_fixed(np.repeat(normals, 3, axis=0))
        else:
            slots[:, :3] = corners.reshape(-1, 3)
            slots[:, 3:6] = np.repeat(normals, 3, axis=0)
        slots[:, 6] = np.repeat(self._colors[ids].view(slots.dtype).ravel(), 3)
        batch = ids // self.batch_triangles
        breaks = np.flatnonzero((np.diff(ids) != 1) | (np.diff(batch) != 0)) + 1
        starts, ends = np.r_[0, breaks], np.r_[breaks, len(ids)]
        size = self._record_dtype.itemsize
        data = slots.view(np.uint8).reshape(len(ids), 3 * size)
        for a, b in zip(starts, ends):
            local = int(ids[a] - batch[a] * self.batch_triangles)
            self.vbos[batch[a]].write(data[a:b].tobytes(), offset=3 * local * size)
        return len(starts)

    def upload_indices(self, triangles) -> np.ndarray:
        """Write this frame's uint16 indices; returns (nb + 1,) triangle starts per batch."""
        indices, starts = batch_indices(triangles, self.triangle_count, self.batch_triangles)
        if len(indices):
            self.ibo.write(indices.tobytes())
        return starts


@njit(cache=True, nogil=True)
def _face_normals(corners):
    """(n, 3) float64 unit face normals of corners (n, 3, 3) (zero for degenerate ones)."""
    out = np.zeros((len(corners), 3))
    for t in range(len(corners)):
        ax, ay, az = corners[t, 1, 0] - corners[t, 0, 0], corners[t, 1, 1] - corners[t, 0, 1], \
            corners[t, 1, 2] - corners[t, 0, 2]
        bx, by, bz = corners[t, 2, 0] - corners[t, 0, 0], corners[t, 2, 1] - corners[t, 0, 1], \
            corners[t, 2, 2] - corners[t, 0, 2]
        nx, ny, nz = ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx
        length = np.sqrt(nx * nx + ny * ny + nz * nz)
        if length > 0:
            out[t, 0], out[t, 1], out[t, 2] = nx / length, ny / length, nz / length
    return out


def world_buffers(world, profile) -> WorldBuffers:
    """The world's buffers for this profile, uploaded on first use and kept while world lives."""
    per_world = _CACHE.setdefault(world, {})
    key = (profile.vertex_format, profile.batch_triangles)
    if key not in per_world:
        per_world[key] = WorldBuffers(world, profile)
    return per_world[key]

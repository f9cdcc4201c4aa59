"""A world uploaded once: one vertex buffer per uint16 batch and one dynamic index buffer."""
from __future__ import annotations

import weakref

import numpy as np

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

    def upload_indices(self, triangles) -> np.ndarray:
        """Write this frame's uint16 indices; returns (nb + 1,) triangle starts per batch."""
        indices, starts = batch_indices(triangles, self.triangle_count, self.batch_triangles)
        if len(indices):
            self.ibo.write(indices.tobytes())
        return starts


def world_buffers(world, profile) -> WorldBuffers:
    """The world's buffers for this profile, uploaded on first use and kept while world lives."""
    per_world = _CACHE.setdefault(world, {})
    key = (profile.vertex_format, profile.batch_triangles)
    if key not in per_world:
        per_world[key] = WorldBuffers(world, profile)
    return per_world[key]

"""Persistent per-tile vertex buffers for seed 002's tile quadtree (terrain/tiles.py).

A tile's (P+1)^2 vertices depend only on the tile (level, row, column), not on the frame, so
each is gathered and uploaded once into a slot of one vertex arena and kept there across
frames; only tiles new to the arena are written (glBufferSubData per new tile). The 16 side
templates (uint16 local indices) sit in one static index buffer. A frame is one multi-draw
(glMultiDrawElementsIndirect: per tile its template's range and its slot's base vertex),
standing in for one glDrawElements per tile on an ES 1.1 device (uint16 indices into the
tile's own vertex buffer). When the arena is full the least recently drawn tiles give up their
slots (an LRU with a memory budget: `budget_bytes`).
"""
from __future__ import annotations

import time

import numpy as np

from .context import gl_context, render_target
from .renderer import DrawStats, _set_lights
from .shaders import CLEAR_RGB
from .terrain import TerrainRenderer, terrain_vertices
from .world_buffers import program

RECORD_BYTES = 28  # position 3f, normal 3f, colour 4u1 (render/terrain.py)
DEFAULT_BUDGET = 32 << 20  # vertex arena bytes (about 4,000 tiles of 17^2 vertices)


class TileArena:
    """Draws TileSelections of one TilePyramid from vertex slots that persist across frames."""

    def __init__(self, pyramid, profile, budget_bytes: int = DEFAULT_BUDGET):
        ctx = gl_context()
        self.pyramid = pyramid
        self.profile = profile
        self.heightmap = pyramid.heightmap
        self.fallback = TerrainRenderer(self.heightmap, profile)
        n = pyramid.patch + 1
        self.per_tile = n * n
        total = int(pyramid.offsets[-1])
        self.slots = int(max(1, min(total, budget_bytes // (RECORD_BYTES * self.per_tile))))
        self.vbo = ctx.buffer(reserve=self.slots * self.per_tile * RECORD_BYTES)
        counts = pyramid.template_counts
        self.first = np.r_[0, np.cumsum(3 * counts)[:-1]].astype(np.int64)
        self.counts = (3 * counts).astype(np.int64)
        self.ibo = ctx.buffer(np.concatenate(pyramid.templates).astype(np.uint16).tobytes())
        self.slot_of = np.full(total, -1, np.int64)  # tile (flat id) -> slot
        self.tile_in = np.full(self.slots, -1, np.int64)  # slot -> tile
        self.used = np.zeros(self.slots, np.int64)  # frame a slot was last drawn
        self.frame = 0
        self.indirect = None
        self.vao = None
        self.uploaded_tiles = 0  # last draw's newly written tiles
        self.uploaded_bytes = 0

    def flat_ids(self, selection) -> np.ndarray:
        return self.pyramid.offsets[selection.level] + selection.ti * \
            (1 << selection.level) + selection.tj

    def _place(self, tiles) -> np.ndarray:
        """Slots of this frame's tiles, writing the vertices of those not in the arena."""
        self.frame += 1
        slots = self.slot_of[tiles]
        missing = np.flatnonzero(slots < 0)
        self.used[slots[slots >= 0]] = self.frame
        self.uploaded_tiles = len(missing)
        self.uploaded_bytes = 0
        if not len(missing):
            return slots
        if len(tiles) > self.slots:
            raise ValueError(f"{len(tiles)} tiles drawn at once exceed the arena's "
                             f"{self.slots} slots")
        # Free slots first, then the least recently drawn (never one drawn this frame).
        order = np.argsort(np.where(self.tile_in < 0, -1, self.used), kind="stable")
        take = order[:len(missing)]
        old = self.tile_in[take]
        self.slot_of[old[old >= 0]] = -1
        new_tiles = tiles[missing]
        self.tile_in[take] = new_tiles
        self.slot_of[new_tiles] = take
        self.used[take] = self.frame
        slots[missing] = take
        from ..terrain.tiles import TileSelection, selection_mesh

        level = np.searchsorted(self.pyramid.offsets, new_tiles, side="right") - 1
        local = new_tiles - self.pyramid.offsets[level]
        ti, tj = np.divmod(local, 1 << level)
        rows, cols, _ = selection_mesh(self.pyramid, TileSelection(
            level, ti, tj, np.zeros_like(level), 0, 0, 0))
        records = terrain_vertices(self.heightmap, rows, cols).reshape(len(new_tiles), -1)
        stride = self.per_tile * RECORD_BYTES
        for k, slot in enumerate(take):
            data = records[k].tobytes()
            self.vbo.write(data, offset=int(slot) * stride)
            self.uploaded_bytes += len(data)
        return slots

    def draw(self, selection, camera) -> DrawStats:
        """Write the tiles new to the arena, then draw the selection (shaded) in one
        multi-draw; render_ms covers the gathering, the uploads, the draw and glFinish."""
        ctx = gl_context()
        target = render_target(self.profile.resolution, "rgb")
        ctx.finish()
        start = time.perf_counter()
        slots = self._place(self.flat_ids(selection))
        commands = np.zeros((len(slots), 5), np.uint32)
        commands[:, 0] = self.counts[selection.sides]
        commands[:, 1] = 1
        commands[:, 2] = self.first[selection.sides]
        commands[:, 3] = slots * self.per_tile
        data = commands.tobytes()
        if self.indirect is None or self.indirect.size < len(data):
            if self.indirect is not None:
                self.indirect.release()
            self.indirect = ctx.buffer(reserve=max(len(data), 20 * 1024))
        if data:
            self.indirect.write(data)
        upload_ms = (time.perf_counter() - start) * 1000.0
        target.use()
        ctx.viewport = (0, 0, *self.profile.resolution)
        target.clear(*CLEAR_RGB, 1.0, depth=1.0)
        ctx.depth_func = "<"
        ctx.front_face = "ccw"
        ctx.enable_only(ctx.DEPTH_TEST)
        prog = program("shaded", "float32")
        if self.vao is None:
            self.vao = ctx.vertex_array(
                prog, [(self.vbo, "3f 3f 4f1", "in_position", "in_normal", "in_color")],
                index_buffer=self.ibo, index_element_size=2)
        prog["u_mvp"].write(camera.view_projection().T.astype(np.float32).tobytes())
        _set_lights(prog)
        if len(slots):
            self.vao.render_indirect(self.indirect, count=len(slots))
        ctx.finish()
        return DrawStats((time.perf_counter() - start) * 1000.0, 1, int(selection.triangles),
                         upload_ms)

    def read_rgb(self) -> np.ndarray:
        return self.fallback.read_rgb()

    def release(self) -> None:
        for buffer in (self.vbo, self.ibo, self.indirect, self.vao):
            if buffer is not None:
                buffer.release()

"""Persistent per-tile vertex buffers: seed 002's tiles (TileArena) and blocks of samples for
ROAM's leaves (BlockArena).

A tile's (P+1)^2 vertices depend only on the tile (level, row, column), not on the frame, so
each is gathered and uploaded once into a slot of one vertex arena and kept there across
frames; only tiles new to the arena are written (glBufferSubData per new tile). The 16 side
templates (uint16 local indices) sit in one static index buffer. A frame is one multi-draw
(glMultiDrawElementsIndirect: per tile its template's range and its slot's base vertex),
standing in for one glDrawElements per tile on an ES 1.1 device (uint16 indices into the
tile's own vertex buffer). When the arena is full the least recently drawn tiles give up their
slots (an LRU with a memory budget: `budget_bytes`).

BlockArena does the same for triangles given as sample ids (ROAM's leaves): the map is cut
into blocks of 32x32 cells whose 33^2 vertices are uploaded once into a slot; each frame a
triangle lying within one block goes out as three uint16 indices local to its block (6 bytes,
against 84 for three gathered vertices), one multi-draw for all blocks; the few triangles
spanning blocks (coarse, far away) and any beyond the arena's slots are gathered per frame.
"""
from __future__ import annotations

import time

import numpy as np

from .context import gl_context, render_target
from .renderer import DrawStats, _set_lights
from .shaders import CLEAR_RGB
from .terrain import TerrainRenderer, shaded_kind, terrain_vertices
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
        records = self._records(new_tiles, rows, cols)
        stride = self.per_tile * RECORD_BYTES
        for k, slot in enumerate(take):
            data = records[k].tobytes()
            self.vbo.write(data, offset=int(slot) * stride)
            self.uploaded_bytes += len(data)
        return slots

    def _records(self, tiles, rows, cols) -> np.ndarray:
        """(K, V) vertex records of tiles (flat ids) whose samples are rows, cols (K, V)."""
        return terrain_vertices(self.heightmap, rows, cols).reshape(len(tiles), -1)

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
        _write_commands(self, ctx, commands, 1)
        upload_ms = (time.perf_counter() - start) * 1000.0
        _draw_indirect(self, ctx, target, camera, len(slots))
        return DrawStats((time.perf_counter() - start) * 1000.0, 1, int(selection.triangles),
                         upload_ms)

    def read_rgb(self) -> np.ndarray:
        return self.fallback.read_rgb()

    def release(self) -> None:
        for buffer in (self.vbo, self.ibo, self.indirect, self.vao):
            if buffer is not None:
                buffer.release()


class PagedArena(TileArena):
    """A TileArena whose vertices come from a terrain/paged.PagedTiles (tiles read from disk
    under its memory budget) instead of an in-memory heightmap."""

    def __init__(self, paged, profile, budget_bytes: int = DEFAULT_BUDGET):
        self.paged = paged
        super().__init__(paged.pyramid, profile, budget_bytes)

    def _records(self, tiles, rows, cols) -> np.ndarray:
        return paged_vertices(self.paged.heightmap, np.stack(self.paged.records(tiles)), rows,
                              cols)

    def draw(self, selection, camera) -> DrawStats:
        """As TileArena.draw; tiles new to the arena are read through the page cache."""
        self.paged.current = set()
        return super().draw(selection, camera)


def paged_vertices(stand, raw, rows, cols) -> np.ndarray:
    """Vertex records (position, normal, colour) of samples rows/cols from their paged records
    raw (..., 4) uint8 (uint16 sample, int8 normal x and z; no data: alpha 0)."""
    from ..terrain.paged import NO_DATA
    from .terrain import height_colors

    samples = raw[..., :2].copy().view("<u2")[..., 0].astype(np.float64)
    missing = (raw[..., 2] == NO_DATA) & (raw[..., 3] == NO_DATA)  # no data: alpha 0
    nx = np.where(missing, 0.0, raw[..., 2].view(np.int8) / 127.0)
    nz = np.where(missing, 0.0, raw[..., 3].view(np.int8) / 127.0)
    ny = np.sqrt(np.maximum(1.0 - nx * nx - nz * nz, 0.0))
    normal = np.stack([nx, ny, nz], -1)
    normal /= np.linalg.norm(normal, axis=-1, keepdims=True)
    dtype = np.dtype([("position", np.float32, 3), ("normal", np.float32, 3),
                      ("color", np.uint8, 4)])
    records = np.empty(rows.shape, dtype=dtype)
    y = (stand.z_offset + stand.z_scale * samples).astype(np.float32)
    records["position"] = np.stack([cols * stand.spacing, y, rows * stand.spacing], -1)
    records["normal"] = normal
    records["color"] = height_colors(y, stand.low, stand.high)
    records["color"][..., 3] = np.where(missing, 0, 255)
    return records


class PagedRenderer(TerrainRenderer):
    """Draws sample-id triangles of a paged Röttger terrain (terrain/paged_roettger.py), the
    vertices read from its coarse grid and held pages (gathered each frame)."""

    def __init__(self, paged, profile):
        super().__init__(paged.heightmap, profile)
        self.paged = paged

    def vertices(self, rows, cols, heights=None) -> np.ndarray:
        ids = np.asarray(rows, np.int64) * self.paged.size + np.asarray(cols, np.int64)
        return paged_vertices(self.heightmap, self.paged.vertex_records(ids.ravel()),
                              rows.ravel(), cols.ravel())


BLOCK_CELLS = 32  # cells per block side (33^2 vertices: uint16-indexable)


class BlockArena:
    """Draws (T, 3) sample-id triangles of one heightmap from block vertex slots (module doc)."""

    def __init__(self, heightmap, profile, budget_bytes: int = DEFAULT_BUDGET,
                 cells: int = BLOCK_CELLS):
        ctx = gl_context()
        self.heightmap = heightmap
        self.profile = profile
        self.fallback = TerrainRenderer(heightmap, profile)
        self.cells = int(min(cells, heightmap.size - 1))
        self.side = -(-(heightmap.size - 1) // self.cells)  # blocks per side
        n = self.cells + 1
        self.per_block = n * n
        total = self.side * self.side
        self.slots = int(max(1, min(total, budget_bytes // (RECORD_BYTES * self.per_block))))
        self.vbo = ctx.buffer(reserve=self.slots * self.per_block * RECORD_BYTES)
        self.slot_of = np.full(total, -1, np.int64)
        self.block_in = np.full(self.slots, -1, np.int64)
        self.used = np.zeros(self.slots, np.int64)
        self.frame = 0
        self.ibo = self.indirect = self.vao = None
        self.uploaded_blocks = 0
        self.spilled = 0  # last frame's triangles gathered per frame

    def _grid(self, blocks):
        """rows, cols (K, V) of blocks' vertex grids, clamped at the map's last sample."""
        n = self.cells + 1
        a, b = np.divmod(np.arange(n * n), n)
        bi, bj = np.divmod(blocks, self.side)
        last = self.heightmap.size - 1
        rows = np.minimum(bi[:, None] * self.cells + a[None], last)
        cols = np.minimum(bj[:, None] * self.cells + b[None], last)
        return rows, cols

    def _place(self, blocks) -> np.ndarray:
        """Slots of blocks (-1 for those the arena has no room for this frame)."""
        self.frame += 1
        slots = self.slot_of[blocks]
        self.used[slots[slots >= 0]] = self.frame
        missing = np.flatnonzero(slots < 0)
        free = np.flatnonzero(self.used < self.frame)  # not drawn this frame
        order = free[np.argsort(np.where(self.block_in[free] < 0, -1, self.used[free]),
                                kind="stable")]
        take = order[:len(missing)]
        missing = missing[:len(take)]
        self.uploaded_blocks = len(take)
        if not len(take):
            return slots
        old = self.block_in[take]
        self.slot_of[old[old >= 0]] = -1
        new = blocks[missing]
        self.block_in[take] = new
        self.slot_of[new] = take
        self.used[take] = self.frame
        slots[missing] = take
        rows, cols = self._grid(new)
        records = terrain_vertices(self.heightmap, rows, cols).reshape(len(new), -1)
        stride = self.per_block * RECORD_BYTES
        for k, slot in enumerate(take):
            self.vbo.write(records[k].tobytes(), offset=int(slot) * stride)
        return slots

    def draw(self, triangles, camera) -> DrawStats:
        """Draw (T, 3) int64 sample-id triangles (shaded); render_ms covers the sorting, the
        uploads (new blocks, this frame's indices), the draws and glFinish."""
        ctx = gl_context()
        target = render_target(self.profile.resolution, "rgb")
        ctx.finish()
        start = time.perf_counter()
        t = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
        size, b = self.heightmap.size, self.cells
        r, c = np.divmod(t, size)
        bi = np.minimum(r.min(axis=1) // b, self.side - 1)
        bj = np.minimum(c.min(axis=1) // b, self.side - 1)
        inside = ((r.max(axis=1) - bi * b) <= b) & ((c.max(axis=1) - bj * b) <= b)
        block = bi * self.side + bj
        blocks, counts = np.unique(block[inside], return_counts=True)
        slots = self._place(blocks)
        placed = slots >= 0
        keep = inside.copy()
        keep[inside] = placed[np.searchsorted(blocks, block[inside])]
        spill = t[~keep]
        order = np.argsort(block[keep], kind="stable")
        kept = keep.nonzero()[0][order]
        local = ((r[kept] - bi[kept, None] * b) * (b + 1) + (c[kept] - bj[kept, None] * b))
        indices = local.astype(np.uint16).tobytes()
        blocks, counts, slots = blocks[placed], counts[placed], slots[placed]
        commands = np.zeros((len(blocks), 5), np.uint32)
        commands[:, 0] = 3 * counts
        commands[:, 1] = 1
        commands[:, 2] = 3 * np.r_[0, np.cumsum(counts)[:-1]]
        commands[:, 3] = slots * self.per_block
        if self.ibo is None or self.ibo.size < max(len(indices), 1):
            for old in (self.ibo, self.vao):
                if old is not None:
                    old.release()
            self.ibo = ctx.buffer(reserve=max(2 * len(indices), 1 << 16))
            self.vao = None
        if indices:
            self.ibo.write(indices)
        _write_commands(self, ctx, commands, 2)
        upload_ms = (time.perf_counter() - start) * 1000.0
        _draw_indirect(self, ctx, target, camera, len(blocks))
        ms = (time.perf_counter() - start) * 1000.0
        self.spilled = len(spill)
        calls = 1
        if len(spill):
            extra = self.fallback.draw_samples(spill, camera, "shaded", clear=False)
            ms += extra.render_ms
            calls += extra.draw_batches
        return DrawStats(ms, calls, len(t), upload_ms)

    def read_rgb(self) -> np.ndarray:
        return self.fallback.read_rgb()


def _write_commands(arena, ctx, commands, grow: int) -> None:
    """Upload (N, 5) uint32 indirect draw commands to arena.indirect, reallocated (grow x the
    size, at least 20 KB) when they no longer fit."""
    data = commands.tobytes()
    if arena.indirect is None or arena.indirect.size < len(data):
        if arena.indirect is not None:
            arena.indirect.release()
        arena.indirect = ctx.buffer(reserve=max(grow * len(data), 20 * 1024))
    if data:
        arena.indirect.write(data)


def _draw_indirect(arena, ctx, target, camera, count: int) -> None:
    """Clear target and draw the first count commands of arena.indirect from arena.vbo and
    arena.ibo, shaded and depth-tested (the vertex array made once), then glFinish."""
    target.use()
    ctx.viewport = (0, 0, *arena.profile.resolution)
    target.clear(*CLEAR_RGB, 1.0, depth=1.0)
    ctx.depth_func = "<"
    ctx.front_face = "ccw"
    ctx.enable_only(ctx.DEPTH_TEST)
    prog = program(shaded_kind(arena.heightmap), "float32")
    if arena.vao is None:
        arena.vao = ctx.vertex_array(
            prog, [(arena.vbo, "3f 3f 4f1", "in_position", "in_normal", "in_color")],
            index_buffer=arena.ibo, index_element_size=2)
    prog["u_mvp"].write(camera.view_projection().T.astype(np.float32).tobytes())
    _set_lights(prog)
    if count:
        arena.vao.render_indirect(arena.indirect, count=count)
    ctx.finish()

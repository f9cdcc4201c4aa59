"""Persistent GPU buffers for Pires's cached chunks (terrain/display_lists.py).

One vertex buffer holds every chunk's (P+1)^2 vertex grid (built once: vertex buffers persist
across frames), one index buffer holds a fixed slot per chunk (room for its full-resolution
fans, 2 P^2 triangles of uint16 local indices). Per frame only the slots of chunks whose
version changed are written (glBufferSubData); a reused chunk costs no upload. The visible
chunks are drawn with one multi-draw (glMultiDrawElementsIndirect: per chunk its slot, its
triangle count and its grid's base vertex), which stands in for Pires's one glCallList per
display list (ES 1.1 would issue one glDrawElements per chunk) without Python's per-call
overhead in the figure. Leaves coarser than a chunk go out per frame (few, far away).
Limit: the vertex buffer covers the whole map (31 MB of vertices at 1025^2).
"""
from __future__ import annotations

import time

import numpy as np

from .context import gl_context, render_target
from .renderer import DrawStats, _set_lights
from .shaders import CLEAR_RGB
from .terrain import TerrainRenderer, shaded_kind, terrain_vertices
from .world_buffers import program


class ChunkRenderer:
    """Draws ChunkFrames of one DisplayLists (its chunk grid) at a profile's resolution."""

    def __init__(self, display_lists, profile):
        ctx = gl_context()
        self.lists = display_lists
        self.profile = profile
        hm = display_lists.roettger.heightmap
        self.heightmap = hm
        self.fallback = TerrainRenderer(hm, profile)
        side = 1 << display_lists.chunk_level
        width = display_lists.width
        self.grid = width * width
        a, b = np.divmod(np.arange(self.grid), width)
        ci, cj = np.divmod(np.arange(side * side), side)
        rows = ci[:, None] * display_lists.chunk_cells + a[None]
        cols = cj[:, None] * display_lists.chunk_cells + b[None]
        self.vbo = ctx.buffer(terrain_vertices(hm, rows, cols).tobytes())
        self.slot = 6 * display_lists.chunk_cells ** 2  # indices (uint16) per chunk slot
        self.ibo = ctx.buffer(reserve=2 * self.slot * side * side)
        self.gl_version = np.full(side * side, -1, np.int64)
        self.indirect = ctx.buffer(reserve=20 * side * side)
        self.vaos = {}
        self.uploaded_bytes = 0
        self.upload_ms = 0.0  # last draw's slot and command writes (CPU), within render_ms

    def _vao(self):
        if not self.vaos:
            prog = program(shaded_kind(self.heightmap), "float32")
            layout = [(self.vbo, "3f 3f 4f1", "in_position", "in_normal", "in_color")]
            self.vaos["shaded"] = (prog, gl_context().vertex_array(
                prog, layout, index_buffer=self.ibo, index_element_size=2))
        return self.vaos["shaded"]

    def draw(self, frame, camera) -> DrawStats:
        """Upload the changed chunks' slots, then draw (shaded) every visible chunk and the
        coarse leaves. render_ms covers the uploads, the draws and glFinish."""
        ctx = gl_context()
        target = render_target(self.profile.resolution, "rgb")
        ctx.finish()
        start = time.perf_counter()
        uploaded = 0
        for chunk, local, version in zip(frame.chunks, frame.indices, frame.versions):
            if self.gl_version[chunk] != version:
                data = local.tobytes()
                self.ibo.write(data, offset=2 * self.slot * int(chunk))
                self.gl_version[chunk] = version
                uploaded += len(data)
        commands = np.zeros((len(frame.chunks), 5), np.uint32)
        commands[:, 0] = [3 * len(i) for i in frame.indices]
        commands[:, 1] = 1
        commands[:, 2] = frame.chunks * self.slot
        commands[:, 3] = frame.chunks * self.grid
        self.indirect.write(commands.tobytes())
        uploaded += commands.nbytes
        self.upload_ms = (time.perf_counter() - start) * 1000.0
        target.use()
        ctx.viewport = (0, 0, *self.profile.resolution)
        target.clear(*CLEAR_RGB, 1.0, depth=1.0)
        ctx.depth_func = "<"
        ctx.front_face = "ccw"
        ctx.enable_only(ctx.DEPTH_TEST)
        prog, vao = self._vao()
        prog["u_mvp"].write(camera.view_projection().T.astype(np.float32).tobytes())
        _set_lights(prog)
        if len(frame.chunks):
            vao.render_indirect(self.indirect, count=len(frame.chunks))
        ctx.finish()
        ms = (time.perf_counter() - start) * 1000.0
        if len(frame.coarse):
            extra = self.fallback.draw_samples(frame.coarse, camera, "shaded", clear=False)
            ms += extra.render_ms
        self.uploaded_bytes = uploaded
        return DrawStats(ms, 1 + (len(frame.coarse) > 0), frame.triangles)

    def read_rgb(self) -> np.ndarray:
        return self.fallback.read_rgb()

"""Textured drawing as OpenGL ES 1.1 does it: base-colour textures modulating the lit colour.

Each texture is uploaded with its whole mip chain (world/textures.py: power-of-two sides, at
most the profile's max_texture_size, top levels dropped under memory pressure) and sampled
with GL_LINEAR_MIPMAP_LINEAR / GL_LINEAR and GL_REPEAT. The triangles sit in the vertex buffers
grouped by texture (a permutation of the ids), so a frame binds each texture once per uint16
batch it touches: draw calls = the non-empty (batch, texture) pairs.
"""
from __future__ import annotations

import time

import numpy as np

from .batches import batch_count
from .context import gl_context, render_target
from .renderer import DrawStats, Renderer, _set_lights
from .shaders import CLEAR_RGB, LIGHT_UNIFORMS, LIT_VERTEX, _INPUTS, _TRANSFORM
from .vertex_data import vertex_records

# The shaded vertex shader's lighting (shaders.py) plus the texture coordinates.
TEXTURED_VERTEX = ("#version 330\n{inputs}{transform}\nin vec4 in_color;\nin vec2 in_uv;\n"
                   + LIGHT_UNIFORMS + "smooth out vec4 v_color;\nsmooth out vec2 v_uv;\n"
                   "void main() {{\n" + LIT_VERTEX + "    v_uv = in_uv;\n}}\n")

# GL_MODULATE: fragment = lit colour x texel (the ES 1.1 default texture environment).
TEXTURED_FRAGMENT = """#version 330
smooth in vec4 v_color;
smooth in vec2 v_uv;
uniform sampler2D u_texture;
uniform bool u_textured;
out vec4 f_color;
void main() { f_color = u_textured ? v_color * texture(u_texture, v_uv) : v_color; }
"""

WHITE = np.array([255, 255, 255, 255], np.uint8)


class TexturedRenderer(Renderer):
    """A Renderer whose shaded draws are textured (world.textures); item draws as before."""

    def __init__(self, world, profile):
        super().__init__(world, profile)
        ctx = gl_context()
        textures = world.textures
        self.profile = profile
        self.batch_triangles = profile.batch_triangles
        self.triangle_count = world.triangle_count
        # Triangles grouped by texture (untextured first), ids ascending inside a group.
        texture = textures.texture_of[world.object_ids]
        self.order = np.argsort(texture, kind="stable")
        self.position_of = np.empty_like(self.order)
        self.position_of[self.order] = np.arange(len(self.order))
        self.texture_at = texture[self.order]
        records = vertex_records(world, profile)
        textured = np.repeat(texture >= 0, 3)
        records["color"][textured] = WHITE  # a texture's colour is its texels, lit
        dtype = np.dtype(records.dtype.descr + [("uv", np.float32, 2)])
        full = np.empty(len(records), dtype)
        for name in records.dtype.names:
            full[name] = records[name]
        full["uv"] = textures.uv.reshape(-1, 2)
        full = full.reshape(-1, 3)[self.order].reshape(-1)
        self.batches = batch_count(self.triangle_count, self.batch_triangles)
        step = 3 * self.batch_triangles
        inputs = _INPUTS[profile.vertex_format]
        self.program = ctx.program(
            vertex_shader=TEXTURED_VERTEX.format(inputs=inputs, transform=_TRANSFORM),
            fragment_shader=TEXTURED_FRAGMENT)
        fmt = ("3i 3i 4f1 2f" if profile.fixed else "3f 3f 4f1 2f")
        self.vbos = [ctx.buffer(full[b * step:(b + 1) * step].tobytes())
                     for b in range(self.batches)]
        self.ibo = ctx.buffer(reserve=max(6 * self.triangle_count, 2), dynamic=True)
        self.arrays = [ctx.vertex_array(self.program, [(vbo, fmt, "in_position", "in_normal",
                                                        "in_color", "in_uv")],
                                        index_buffer=self.ibo, index_element_size=2)
                       for vbo in self.vbos]
        self.textures = [self._upload(textures.chain(i, profile.max_texture_size))
                         for i in range(len(textures.images))]
        self.texture_levels = [len(textures.chain(i, profile.max_texture_size))
                               for i in range(len(textures.images))]

    @staticmethod
    def _upload(levels):
        """GL texture of a mip chain (largest first), rows flipped so v = 0 is the bottom."""
        ctx = gl_context()
        h, w = levels[0].shape[:2]
        texture = ctx.texture((w, h), 4, np.ascontiguousarray(levels[0][::-1]).tobytes())
        texture.build_mipmaps(0, len(levels) - 1)  # allocates the levels; ours replace them
        for level, data in enumerate(levels[1:], start=1):
            texture.write(np.ascontiguousarray(data[::-1]).tobytes(), level=level)
        texture.filter = (ctx.LINEAR_MIPMAP_LINEAR, ctx.LINEAR)
        texture.repeat_x = texture.repeat_y = True
        return texture

    def draw(self, triangles, camera, cull_back=False, kind="shaded") -> DrawStats:
        """Draw triangles (sorted unique ids) shaded and textured into the "rgb" target
        (kind "item": the item buffer, as Renderer.draw)."""
        if kind != "shaded":
            return super().draw(triangles, camera, cull_back, kind)
        ctx = gl_context()
        target = render_target(self.profile.resolution, "rgb")
        ctx.finish()
        start = time.perf_counter()
        target.use()
        ctx.viewport = (0, 0, *self.profile.resolution)
        target.clear(*CLEAR_RGB, 1.0, depth=1.0)
        ctx.depth_func = "<"
        ctx.front_face = "ccw"
        ctx.cull_face = "back"
        ctx.enable_only(ctx.DEPTH_TEST | (ctx.CULL_FACE if cull_back else 0))
        prog = self.program
        prog["u_mvp"].write(camera.view_projection().T.astype(np.float32).tobytes())
        _set_lights(prog)
        prog["u_texture"].value = 0
        positions = np.sort(self.position_of[np.asarray(triangles, dtype=np.int64)])
        b = self.batch_triangles
        local = positions % b
        indices = (3 * local[:, None] + np.arange(3)).astype(np.uint16).ravel()
        if len(indices):
            self.ibo.write(indices.tobytes())
        # Runs of one (batch, texture): positions are sorted, so each run is contiguous.
        key = (positions // b) * (len(self.textures) + 1) + (self.texture_at[positions] + 1)
        starts = np.flatnonzero(np.r_[True, key[1:] != key[:-1]]) if len(key) else []
        ends = list(starts[1:]) + [len(key)]
        for first, last in zip(starts, ends):  # a handful of runs, never a loop over triangles
            batch = int(positions[first] // b)
            texture = int(self.texture_at[positions[first]])
            prog["u_textured"].value = texture >= 0
            if texture >= 0:
                self.textures[texture].use(0)
            self.arrays[batch].render(vertices=3 * int(last - first), first=3 * int(first))
        ctx.finish()
        elapsed = (time.perf_counter() - start) * 1000.0
        return DrawStats(elapsed, len(starts), int(len(positions)))


def renderer_for(world, profile) -> Renderer:
    """A TexturedRenderer when the world brings textures (world.textures), else a Renderer."""
    if getattr(world, "textures", None) is not None:
        return TexturedRenderer(world, profile)
    return Renderer(world, profile)

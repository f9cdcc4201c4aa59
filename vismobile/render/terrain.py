"""Draws terrain tiles as an OpenGL ES 1.1 device would: uint16 indices, batches of whole tiles.

Each frame the drawn tiles' vertices are gathered from the heightmap (position, a normal from
the full-resolution samples' central differences, a height colour) into one vertex buffer per
batch of at most 65,535 vertices, with one uint16 index buffer per batch. The full render and
every LOD share this path, so their images differ only by geometry. Positions are float32 on
every profile (terrains span more than GL_FIXED's +-32767 units).
"""
from __future__ import annotations

import time

import numpy as np

from ..device.profile import MAX_INDEX_VERTICES
from .context import gl_context, render_target
from .renderer import SENTINEL, DrawStats, _set_lights
from .shaders import CLEAR_RGB
from .world_buffers import program

ITEM_VERTEX = """#version 330
in vec3 in_position;
uniform mat4 u_mvp;
invariant gl_Position;
void main() { gl_Position = u_mvp * vec4(in_position, 1.0); }
"""
ITEM_FRAGMENT = """#version 330
uniform uint u_first_id;
out uint f_id;
void main() { f_id = u_first_id + uint(gl_PrimitiveID) + 1u; }
"""
# The item buffer of a terrain with holes: the same alpha test as the "cut" program (the
# no-data vertices' alpha 0 interpolated the same way), so ids show exactly the drawn ground.
CUT_ITEM_VERTEX = """#version 330
in vec3 in_position;
in vec4 in_color;
uniform mat4 u_mvp;
invariant gl_Position;
smooth out float v_alpha;
void main() { gl_Position = u_mvp * vec4(in_position, 1.0); v_alpha = in_color.a; }
"""
CUT_ITEM_FRAGMENT = """#version 330
uniform uint u_first_id;
smooth in float v_alpha;
out uint f_id;
void main() {
    if (v_alpha <= 0.5) discard;
    f_id = u_first_id + uint(gl_PrimitiveID) + 1u;
}
"""
_ITEM_PROGRAM = {}


def _item_program(cut: bool = False):
    if cut not in _ITEM_PROGRAM:
        vertex, fragment = (CUT_ITEM_VERTEX, CUT_ITEM_FRAGMENT) if cut else \
            (ITEM_VERTEX, ITEM_FRAGMENT)
        _ITEM_PROGRAM[cut] = gl_context().program(vertex_shader=vertex,
                                                  fragment_shader=fragment)
    return _ITEM_PROGRAM[cut]


def height_colors(heights, low: float, high: float) -> np.ndarray:
    """(..., 4) uint8 hypsometric colours (matplotlib's "terrain" map over [low, high])."""
    from matplotlib import colormaps

    table = np.rint(colormaps["terrain"](np.linspace(0.15, 1.0, 256)) * 255).astype(np.uint8)
    t = (np.asarray(heights, np.float64) - low) / max(high - low, 1e-12)
    return table[np.clip((t * 255).astype(np.int64), 0, 255)]


def terrain_vertices(heightmap, rows, cols, heights=None) -> np.ndarray:
    """(K*V,) records (position 3f, normal 3f, colour 4u1) of the samples rows/cols (K, V).

    heights: (N, N) drawn heights to place the vertices at instead of the samples (a
    geomorphing LOD); normals and colours stay the samples'."""
    h = heightmap.heights
    n = heightmap.size - 1
    r, c = rows.ravel(), cols.ravel()
    # Central differences at full resolution (one-sided at the border).
    dx = (h[r, np.minimum(c + 1, n)] - h[r, np.maximum(c - 1, 0)]) / \
         ((np.minimum(c + 1, n) - np.maximum(c - 1, 0)) * heightmap.spacing)
    dz = (h[np.minimum(r + 1, n), c] - h[np.maximum(r - 1, 0), c]) / \
         ((np.minimum(r + 1, n) - np.maximum(r - 1, 0)) * heightmap.spacing)
    normal = np.stack([-dx, np.ones_like(dx), -dz], axis=1)
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    dtype = np.dtype([("position", np.float32, 3), ("normal", np.float32, 3),
                      ("color", np.uint8, 4)])
    records = np.empty(len(r), dtype=dtype)
    y = h[r, c] if heights is None else heights[r, c]
    records["position"] = np.stack([c * heightmap.spacing, y, r * heightmap.spacing], 1)
    records["normal"] = normal
    low, high = heightmap.bounds()[:, 1]
    records["color"] = height_colors(h[r, c], low, high)
    if heightmap.valid is not None:  # no data: alpha 0, cut by the alpha test (shaded_kind)
        records["color"][:, 3] = np.where(heightmap.valid[r, c], 255, 0)
    return records


def shaded_kind(heightmap) -> str:
    """The program kind that draws a heightmap: "cut" (the alpha test) when it has holes (a
    paged terrain's stand-in says so with `holes`)."""
    holes = heightmap.valid is not None or getattr(heightmap, "holes", False)
    return "cut" if holes else "shaded"


class TerrainRenderer:
    """Renders tile selections of one heightmap at a profile's resolution."""

    def __init__(self, heightmap, profile):
        self.heightmap = heightmap
        self.profile = profile

    def draw(self, rows, cols, triangles, camera, kind="shaded", clear=True) -> DrawStats:
        """Draw K tiles: rows/cols (K, V) sample coordinates, triangles K local (T_k, 3) lists.

        kind "shaded" (RGB) or "item" (ids: triangle index in draw order). Whole tiles go into
        batches of at most 65,535 vertices. render_ms covers vertex gathering, uploads, draws
        and glFinish.
        """
        per_tile = rows.shape[1] if len(rows) else 1
        tiles_per_batch = max(1, MAX_INDEX_VERTICES // per_tile)

        def batches():
            for b0 in range(0, len(rows), tiles_per_batch):
                b1 = min(b0 + tiles_per_batch, len(rows))
                counts = np.array([len(t) for t in triangles[b0:b1]])
                if not counts.sum():
                    continue
                offsets = np.repeat(np.arange(b1 - b0) * per_tile, counts)
                indices = np.concatenate(triangles[b0:b1]) + offsets[:, None]
                yield rows[b0:b1], cols[b0:b1], indices

        return self._render(batches, camera, kind, clear)

    def draw_samples(self, triangles, camera, kind="shaded", clear=True,
                     heights=None) -> DrawStats:
        """Draw (T, 3) triangles given as sample ids (row * N + col), three corners each, in
        batches of 21,845 triangles (65,535 vertices); heights: (N, N) drawn vertex heights
        instead of the samples (geomorphing)."""
        triangles = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
        step = MAX_INDEX_VERTICES // 3

        def batches():
            for t0 in range(0, len(triangles), step):
                part = triangles[t0:t0 + step].ravel()
                rows, cols = np.divmod(part, self.heightmap.size)
                yield rows, cols, np.arange(len(part)).reshape(-1, 3)

        return self._render(batches, camera, kind, clear, heights)

    def draw_mesh_items(self, vertices, triangles, camera, first_id: int) -> DrawStats:
        """Add a triangle mesh (vertices (V, 3), triangles (T, 3)) to the current item buffer
        without clearing it: triangle t gets id first_id + t. Used to put objects on terrain."""
        vertices = np.asarray(vertices, dtype=np.float64)
        triangles = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
        step = MAX_INDEX_VERTICES // 3
        ctx = gl_context()
        target = render_target(self.profile.resolution, "ids")
        ctx.finish()
        start = time.perf_counter()
        target.use()
        ctx.viewport = (0, 0, *self.profile.resolution)
        ctx.depth_func = "<"
        ctx.enable_only(ctx.DEPTH_TEST)
        prog = _item_program()
        prog["u_mvp"].write(camera.view_projection().T.astype(np.float32).tobytes())
        count = 0
        for t0 in range(0, len(triangles), step):
            corners = vertices[triangles[t0:t0 + step].ravel()].astype(np.float32)
            vbo = ctx.buffer(corners.tobytes())
            prog["u_first_id"].value = first_id + t0
            vao = ctx.vertex_array(prog, [(vbo, "3f", "in_position")])
            vao.render(vertices=len(corners))
            vao.release()
            vbo.release()
            count += 1
        ctx.finish()
        return DrawStats((time.perf_counter() - start) * 1000.0, count, len(triangles))

    def _render(self, batches, camera, kind, clear, heights=None) -> DrawStats:
        ctx = gl_context()
        target = render_target(self.profile.resolution, "rgb" if kind == "shaded" else "ids")
        ctx.finish()
        start = time.perf_counter()
        target.use()
        ctx.viewport = (0, 0, *self.profile.resolution)
        if clear:
            if kind == "shaded":
                target.clear(*CLEAR_RGB, 1.0, depth=1.0)
            else:
                target.clear(0.0, 0.0, 0.0, 0.0, depth=1.0)
        ctx.depth_func = "<"
        ctx.front_face = "ccw"
        ctx.enable_only(ctx.DEPTH_TEST)
        cut = shaded_kind(self.heightmap) == "cut"
        prog = program(shaded_kind(self.heightmap), "float32") if kind == "shaded" \
            else _item_program(cut)
        prog["u_mvp"].write(camera.view_projection().T.astype(np.float32).tobytes())
        if kind == "shaded":
            _set_lights(prog)
        count, drawn, first_id = 0, 0, 0
        for rows, cols, indices in batches():
            records = self.vertices(rows, cols, heights)
            indices = indices.astype(np.uint16)
            vbo = ctx.buffer(records.tobytes())
            ibo = ctx.buffer(indices.tobytes())
            if kind == "shaded":
                vao = ctx.vertex_array(prog, [(vbo, "3f 3f 4f1", "in_position", "in_normal",
                                                "in_color")], index_buffer=ibo,
                                       index_element_size=2)
            else:
                prog["u_first_id"].value = first_id
                layout = (vbo, "3f 12x 4f1", "in_position", "in_color") if cut else \
                    (vbo, "3f 16x", "in_position")
                vao = ctx.vertex_array(prog, [layout], index_buffer=ibo, index_element_size=2)
            vao.render(vertices=indices.size)
            first_id += len(indices)
            drawn += len(indices)
            count += 1
            vao.release()
            vbo.release()
            ibo.release()
        ctx.finish()
        return DrawStats((time.perf_counter() - start) * 1000.0, count, drawn)

    def vertices(self, rows, cols, heights=None) -> np.ndarray:
        """Vertex records of samples rows/cols (terrain_vertices; a paged terrain's renderer
        reads them from its pages instead)."""
        return terrain_vertices(self.heightmap, rows, cols, heights)

    def read_rgb(self) -> np.ndarray:
        """(H, W, 3) uint8 image of the last shaded draw, row 0 = top."""
        target = render_target(self.profile.resolution, "rgb")
        data = np.frombuffer(target.read(components=3), dtype=np.uint8)
        return data.reshape(self.profile.height, self.profile.width, 3)[::-1].copy()

    def read_depth(self, kind="shaded") -> np.ndarray:
        """(H, W) float32 window depth in [0, 1] of the last draw, row 0 = top."""
        target = render_target(self.profile.resolution, "rgb" if kind == "shaded" else "ids")
        data = np.frombuffer(target.read(components=1, attachment=-1, dtype="f4"), dtype=np.float32)
        return data.reshape(self.profile.height, self.profile.width)[::-1].copy()

    def read_ids(self) -> np.ndarray:
        """(H, W) uint32 ids of the last item draw, SENTINEL for background, row 0 = top."""
        target = render_target(self.profile.resolution, "ids")
        raw = np.frombuffer(target.read(components=1, dtype="u4"), dtype=np.uint32)
        return raw.reshape(self.profile.height, self.profile.width)[::-1] - np.uint32(1)


def unproject(depth, camera) -> np.ndarray:
    """(H, W, 3) float64 world points of window depths (H, W) (NaN where depth == 1)."""
    height, width = depth.shape
    inverse = np.linalg.inv(camera.view_projection())
    y, x = np.mgrid[0:height, 0:width]
    ndc = np.stack([(x + 0.5) / width * 2 - 1, 1 - (y + 0.5) / height * 2,
                    depth.astype(np.float64) * 2 - 1, np.ones_like(depth, np.float64)], -1)
    world = ndc @ inverse.T
    points = world[..., :3] / world[..., 3:]
    points[depth >= 1.0] = np.nan
    return points


__all__ = ["TerrainRenderer", "terrain_vertices", "height_colors", "unproject", "SENTINEL",
           "shaded_kind"]

"""The View: draws the culled triangles as an OpenGL ES 1.1 fixed pipeline would, and times it.

Per frame: clear, build this frame's uint16 index data with numpy, one write to the dynamic
index buffer, one glDrawElements per non-empty batch, then glFinish; render_ms covers all of
that, upload_ms the index data's build and write within it. GL_CULL_FACE (back faces, counter-clockwise front) is on when cull_back is set.
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from .context import gl_context, render_target
from .shaders import CLEAR_RGB, LIGHT_AMBIENT, LIGHT_DIFFUSE, LIGHT_DIRECTIONS, SCENE_AMBIENT
from .world_buffers import program, world_buffers

SENTINEL = np.uint32(0xFFFFFFFF)


@dataclass(frozen=True)
class DrawStats:
    """render_ms: wall time from clear to glFinish; draw_batches: glDrawElements calls made;
    upload_ms: the part of render_ms spent building and writing the frame's index data (the
    rest is clear, state, draws and glFinish; 0 where a renderer does not split it)."""

    render_ms: float
    draw_batches: int
    triangles: int
    upload_ms: float = 0.0


class Renderer:
    """Draws subsets of one world at one profile's resolution, vertex format and batch size.

    The world is uploaded once (cached per world object, and freed with it: the renderer keeps
    no reference to the world); each draw sends only the given ids. Cameras are used as given:
    pass one whose aspect is profile.aspect to fill the screen.
    """

    def __init__(self, world, profile):
        self.profile = profile
        self.buffers = world_buffers(world, profile)

    def move(self, triangles, corners) -> int:
        """Moved triangles (ids (n,), corners (n, 3, 3)) drawn where they stand from now on
        (WorldBuffers.move); the world's other triangles stay as uploaded. Returns writes."""
        return self.buffers.move(triangles, corners)

    def draw(self, triangles, camera, cull_back=False, kind="shaded",
             clear: bool = True) -> DrawStats:
        """Draw triangles (sorted unique ids) into the "shaded" (RGB) or "item" (ids) target;
        clear=False draws over what is there (objects Z-buffered into a terrain)."""
        ctx = gl_context()
        target = render_target(self.profile.resolution, "rgb" if kind == "shaded" else "ids")
        vertex_arrays = self.buffers.vertex_arrays(kind)
        prog = program(kind, self.profile.vertex_format)
        ctx.finish()  # nothing queued from earlier work is charged to this frame
        start = time.perf_counter()
        target.use()
        ctx.viewport = (0, 0, *self.profile.resolution)
        if not clear:
            pass
        elif kind == "shaded":
            target.clear(*CLEAR_RGB, 1.0, depth=1.0)
        else:
            target.clear(0.0, 0.0, 0.0, 0.0, depth=1.0)  # id 0 = background
        ctx.depth_func = "<"
        ctx.front_face = "ccw"
        ctx.cull_face = "back"
        ctx.enable_only(ctx.DEPTH_TEST | (ctx.CULL_FACE if cull_back else 0))
        prog["u_mvp"].write(camera.view_projection().T.astype(np.float32).tobytes())
        if kind == "shaded":
            _set_lights(prog)
        upload = time.perf_counter()
        starts = self.buffers.upload_indices(triangles)
        upload = time.perf_counter() - upload
        counts = np.diff(starts)
        batches = np.flatnonzero(counts)
        for batch in batches:  # a handful of batches, never a loop over triangles
            if kind == "item":
                prog["u_first_id"].value = int(batch) * self.buffers.batch_triangles
            vertex_arrays[batch].render(vertices=3 * int(counts[batch]),
                                        first=3 * int(starts[batch]))
        ctx.finish()
        elapsed = (time.perf_counter() - start) * 1000.0
        return DrawStats(elapsed, int(len(batches)), int(starts[-1] - starts[0]),
                         upload * 1000.0)

    def read_rgb(self) -> np.ndarray:
        """(H, W, 3) uint8 image of the last shaded draw, row 0 = top."""
        target = render_target(self.profile.resolution, "rgb")
        data = np.frombuffer(target.read(components=3), dtype=np.uint8)
        return data.reshape(self.profile.height, self.profile.width, 3)[::-1].copy()

    def read_ids(self) -> np.ndarray:
        """(H, W) uint32 ids of the last item draw, SENTINEL for background, row 0 = top."""
        target = render_target(self.profile.resolution, "ids")
        raw = np.frombuffer(target.read(components=1, dtype="u4"), dtype=np.uint32)
        # Stored as id + 1 over a cleared 0, so 0 - 1 wraps to the sentinel.
        return (raw.reshape(self.profile.height, self.profile.width)[::-1] - np.uint32(1))

    def render_rgb(self, triangles, camera, cull_back=False) -> np.ndarray:
        """(H, W, 3) uint8 shaded frame of the triangles (sorted unique int ids), as draw()."""
        self.draw(triangles, camera, cull_back, "shaded")
        return self.read_rgb()


def _set_lights(prog) -> None:
    prog["u_light_dir"].write(LIGHT_DIRECTIONS.astype(np.float32).tobytes())
    prog["u_light_diffuse"].write(np.repeat(LIGHT_DIFFUSE, 3).astype(np.float32).tobytes())
    prog["u_light_ambient"].write(np.repeat(LIGHT_AMBIENT, 3).astype(np.float32).tobytes())
    prog["u_scene_ambient"].value = SCENE_AMBIENT


def render_rgb(world, triangles, camera, profile, cull_back=False) -> np.ndarray:
    """(H, W, 3) uint8 shaded image of the given triangles at the profile's resolution, seen
    through `camera` with the profile's aspect (so a 640x480 image is not stretched)."""
    from ..device.profile import get_profile

    profile = get_profile(profile)
    return Renderer(world, profile).render_rgb(triangles, camera.with_(aspect=profile.aspect),
                                               cull_back)

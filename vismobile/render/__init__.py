"""The View: a headless OpenGL (EGL) renderer limited to what OpenGL ES 1.1 draws.

Only this package imports moderngl. Public names:
- Renderer(world, profile).draw / render_rgb: shaded frames with render_ms (glFinish);
- item_buffer(world, triangles, camera, profile, cull_back), ItemBufferRenderer: triangle ids;
- render_rgb(world, triangles, camera, profile, cull_back): (H, W, 3) uint8;
- SENTINEL: the item buffer's background id; RenderError.
"""
from .context import RenderError, gl_context
from .item_buffer import ItemBufferRenderer, item_buffer, item_buffer_renderer
from .renderer import SENTINEL, DrawStats, Renderer, render_rgb

__all__ = ["RenderError", "gl_context", "ItemBufferRenderer", "item_buffer",
           "item_buffer_renderer", "SENTINEL", "DrawStats", "Renderer", "render_rgb"]

"""The item buffer: which triangle covers each pixel, the ground truth of every error measure.

It shares the shaded renderer's vertex buffers, uint16 batches, invariant transform and depth
format, so a pixel shows triangle t here exactly when the shaded image shows t there.
"""
from __future__ import annotations

import weakref

import numpy as np

from .renderer import SENTINEL, Renderer

_RENDERERS = weakref.WeakKeyDictionary()  # world -> {profile: ItemBufferRenderer}


class ItemBufferRenderer:
    """Reusable item-buffer renderer of one world at one profile (uploads the world once)."""

    def __init__(self, world, profile):
        self.renderer = Renderer(world, profile)

    def render(self, triangles, camera, cull_back=False) -> np.ndarray:
        """(H, W) uint32 id of the nearest triangle per pixel, SENTINEL (0xFFFFFFFF) for none.

        triangles : (K,) int ids to draw (all of them for the full-world truth)
        cull_back : GL_CULL_FACE on back faces, as when a backface stage is active
        Row 0 is the top of the image; H, W = profile.height, profile.width.
        """
        self.renderer.draw(triangles, camera, cull_back, "item")
        return self.renderer.read_ids()

    def visible(self, triangles, camera, cull_back=False) -> np.ndarray:
        """Sorted unique ids of the triangles covering at least one pixel."""
        ids = np.unique(self.render(triangles, camera, cull_back))
        return ids[ids != SENTINEL].astype(np.int64)


def item_buffer_renderer(world, profile) -> ItemBufferRenderer:
    """Cached ItemBufferRenderer per world object and profile."""
    per_world = _RENDERERS.setdefault(world, {})
    if profile not in per_world:
        per_world[profile] = ItemBufferRenderer(world, profile)
    return per_world[profile]


def item_buffer(world, triangles, camera, profile, cull_back=False) -> np.ndarray:
    """(H, W) uint32 triangle ids (SENTINEL = background) of `triangles` seen from camera.

    triangles may be None for the whole world. Rendered at profile.resolution, row 0 = top.
    """
    if triangles is None:
        triangles = np.arange(world.triangle_count)
    return item_buffer_renderer(world, profile).render(triangles, camera, cull_back)

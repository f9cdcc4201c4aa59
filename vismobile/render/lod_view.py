"""Drawing with level of detail, and its image error against the full-detail frame.

A LodView draws the render world (lod/chains.render_world: the world's triangles, then every
level's) so a frame may mix original and level triangles. Per frame it selects the levels
among what culling kept (timed: lod_ms), draws the full-detail frame of the same culled
triangles as the reference, then the level-of-detail frame (timed: render_ms, the frame the
device shows), and measures PSNR, the largest pixel difference and the fraction changed.
"""
from __future__ import annotations

import time
from dataclasses import dataclass

from ..lod import LodSelector, image_error, render_world
from .renderer import DrawStats, Renderer


@dataclass
class LodFrame:
    """drawn: the LOD draw; selection: lod.Selection; lod_ms: selection wall time;
    full_triangles: what the full-detail frame sends; error: image_error() of the two."""

    drawn: DrawStats
    selection: object
    lod_ms: float
    full_triangles: int
    error: dict


class LodView:
    """Draws one world's culled frames at tau pixels of error, and the full-detail reference."""

    def __init__(self, world, chains, profile, tau: float, reference: bool = True):
        self.world = world
        self.tau = float(tau)
        self.reference = reference
        self.renderer = Renderer(render_world(world, chains), profile)
        self.selector = LodSelector(world, chains, profile.resolution)

    def draw(self, triangles, camera, cull_back=False) -> LodFrame:
        """Select, draw the reference (when self.reference) and the LOD frame, compare."""
        start = time.perf_counter()
        selection = self.selector.select(triangles, camera, self.tau)
        lod_ms = (time.perf_counter() - start) * 1000.0
        reference = None
        if self.reference:
            self.renderer.draw(triangles, camera, cull_back)
            reference = self.renderer.read_rgb()
        drawn = self.renderer.draw(selection.triangles, camera, cull_back)
        error = {}
        if reference is not None:
            error = image_error(reference, self.renderer.read_rgb())
        return LodFrame(drawn, selection, lod_ms, int(len(triangles)), error)

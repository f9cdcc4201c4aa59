"""A renderer's moving objects posed per frame (issue 25): the objects' matrices at t, their
vertices (only theirs) and one vertex-record rewrite of their triangles (Renderer.move)."""
from __future__ import annotations

import time


class Poser:
    """Moves a renderer's moving objects to their pose at time t: the objects' matrices, their
    vertices (only theirs), and one vertex-record rewrite of their triangles (Renderer.move).
    Cost O(moving triangles) per frame, never the world."""

    def __init__(self, animated, renderer):
        self.animated, self.renderer = animated, renderer
        self.count = len(animated.motion)

    def pose(self, t) -> float:
        """Draw the moving objects as they stand at t from now on; returns the wall ms."""
        start = time.perf_counter()
        a = self.animated
        vertices = a.posed_vertices(a.matrices(t))
        self.renderer.move(a.moving_triangles, vertices[a.local_triangles])
        return (time.perf_counter() - start) * 1000.0


class PosedRenderer:
    """A Renderer of an AnimatedWorld's rest world whose draw poses the moving objects at the
    camera's `time` first (a camera without one draws the pose last set). Every draw poses
    again: the world's GL buffers are shared by its renderers (the item buffer's too), so
    another may have moved them since. Other attributes are the renderer's."""

    def __init__(self, animated, renderer):
        self.poser = Poser(animated, renderer)
        self.renderer = renderer

    def __getattr__(self, name):
        return getattr(self.renderer, name)

    def pose(self, at) -> float:
        """Pose at time `at` (None: leave the buffers as they are); returns the wall ms."""
        return 0.0 if at is None else self.poser.pose(at)

    def draw(self, triangles, camera, cull_back=False, kind="shaded", **options):
        self.pose(getattr(camera, "time", None))
        return self.renderer.draw(triangles, camera, cull_back, kind, **options)

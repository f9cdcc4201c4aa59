"""A renderer's moving objects posed per frame (issue 25): the objects' matrices at t, their
vertices (only theirs) and one vertex-record rewrite of their triangles (Renderer.move)."""
from __future__ import annotations

import time

import numpy as np


class Poser:
    """Moves a renderer's moving objects to their pose at time t: the objects' matrices, their
    vertices (only theirs), and one vertex-record rewrite of their triangles (Renderer.move).
    Cost O(moving triangles) per frame, never the world; O(the drawn ones' triangles) when
    told which triangles the frame draws."""

    def __init__(self, animated, renderer):
        self.animated, self.renderer = animated, renderer
        self.count = len(animated.motion)
        self._track_of = None  # (T,) int64 moving object (track) of each triangle, -1 static
        self.posed = 0  # moving objects posed by the last pose()

    def pose(self, t, triangles=None) -> float:
        """Draw the moving objects as they stand at t from now on; with `triangles` (the world
        ids this frame draws) only the moving objects among them (the others are not drawn:
        their records keep an older pose until a frame draws them). Returns the wall ms."""
        start = time.perf_counter()
        a = self.animated
        matrices = a.matrices(t)
        if triangles is None:
            vertices = a.posed_vertices(matrices)
            self.renderer.move(a.moving_triangles, vertices[a.local_triangles])
            self.posed = self.count
            return (time.perf_counter() - start) * 1000.0
        if self._track_of is None:
            track_of = np.full(a.world.triangle_count, -1, dtype=np.int64)
            track_of[a.moving_triangles] = np.repeat(np.arange(self.count),
                                                     np.diff(a.tri_start))
            self._track_of = track_of
        tracks = self._track_of[np.asarray(triangles, dtype=np.int64)]
        tracks = np.unique(tracks[tracks >= 0])
        self.posed = len(tracks)
        if len(tracks):
            vertices = a.posed_vertices(matrices, tracks)
            first, last = a.tri_start[tracks], a.tri_start[tracks + 1]
            lengths = last - first
            local = np.repeat(first - np.cumsum(lengths) + lengths, lengths) + \
                np.arange(int(lengths.sum()))
            self.renderer.move(a.moving_triangles[local], vertices[a.local_triangles[local]])
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

"""Animated scenes in the commands (issue 25): which motion a world argument brings, and moving
the renderer's copy of the moving objects to each frame's pose.

A world moves when it is given `--motion FILE.json` (files/motionfile.py, paths attached to its
objects by name), when it is a thesis world with a motion file (W7: scenes/thesis.motion_path),
or when it is a .glb/.gltf file whose first animation moves some of its nodes. Frame f of a
trajectory shows the scene at t = f / fps (fps 30 unless --fps says otherwise).
"""
from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from ..errors import VisMobileError

DEFAULT_FPS = 30.0


def open_animated(text, world, motion=None):
    """The AnimatedWorld of a world argument `text` whose World is `world`, or None when
    nothing in it moves (module docstring). WorldError names a bad motion or glTF file."""
    from ..world.animated import AnimatedWorld

    if motion is not None:
        return AnimatedWorld.from_motion_file(world, Path(motion))
    from ..scenes.lookup import is_thesis_world

    if is_thesis_world(text):
        from ..scenes.thesis import motion_path

        path = motion_path(str(text).strip().lower())
        return None if path is None else AnimatedWorld.from_motion_file(world, path)
    if Path(str(text)).suffix.lower() in (".glb", ".gltf"):
        animated = AnimatedWorld.from_gltf(Path(str(text)))
        return animated if len(animated.motion) else None
    return None


def check_fps(fps) -> float:
    """fps as a float in (0, 1e4], else VisMobileError (the --fps option)."""
    try:
        value = float(fps)
    except (TypeError, ValueError):
        raise VisMobileError(f"--fps must be a number, got {fps!r}") from None
    if not np.isfinite(value) or not 0.0 < value <= 1e4:
        raise VisMobileError(f"--fps must be in (0, 10000], got {fps}")
    return value


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

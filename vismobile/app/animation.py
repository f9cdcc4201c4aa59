"""Animated scenes in the commands (issue 25): which motion a world argument brings, and moving
the renderer's copy of the moving objects to each frame's pose.

A world moves when it is given `--motion FILE.json` (files/motionfile.py, paths attached to its
objects by name), when it is a thesis world with a motion file (W7: scenes/thesis.motion_path),
or when it is a .glb/.gltf file whose first animation moves some of its nodes. Frame f of a
trajectory shows the scene at t = f / fps (fps 30 unless --fps says otherwise).
"""
from __future__ import annotations

import numpy as np

from ..errors import VisMobileError
from ..render.posed import Poser  # noqa: F401  (the commands' import)
from ..scenes.lookup import animated_world as open_animated  # noqa: F401

DEFAULT_FPS = 30.0


def check_fps(fps) -> float:
    """fps as a float in (0, 1e4], else VisMobileError (the --fps option)."""
    try:
        value = float(fps)
    except (TypeError, ValueError):
        raise VisMobileError(f"--fps must be a number, got {fps!r}") from None
    if not np.isfinite(value) or not 0.0 < value <= 1e4:
        raise VisMobileError(f"--fps must be in (0, 10000], got {fps}")
    return value

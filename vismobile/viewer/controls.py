"""The thesis's joystick (SPEC §1, Device Controller): up/down translate forward/back along the
heading, left/right rotate about the vertical; PageUp/PageDown change height; mouse look.

A pose is a (5,) float64 array x, y, z, yaw, pitch (degrees), the trajectory CSV's columns.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

PITCH_LIMIT = 89.0  # keeps the camera basis defined (the view never points straight up)


@dataclass(frozen=True)
class Speeds:
    """move: units per second; turn and look: degrees per second; mouse: degrees per pixel."""

    move: float = 2.0
    turn: float = 90.0
    climb: float = 1.0
    look: float = 45.0
    mouse: float = 0.25

    @classmethod
    def for_extent(cls, extent) -> "Speeds":
        """Speeds that cross the world's largest side in about 20 s."""
        size = float(np.ptp(np.asarray(extent, dtype=np.float64), axis=0).max())
        size = size if size > 0 else 1.0
        return cls(move=size / 20.0, climb=size / 40.0)


def step_pose(pose, held, dt: float, speeds: Speeds) -> np.ndarray:
    """(5,) pose after dt seconds with the held actions (a set of keys.HELD values).

    Forward/back move along the heading in the horizontal plane (pitch does not lift the
    camera), as the thesis's joystick walks; opposite keys cancel.
    """
    x, y, z, yaw, pitch = np.asarray(pose, dtype=np.float64)
    drive = ("forward" in held) - ("back" in held)
    turn = ("turn_left" in held) - ("turn_right" in held)
    climb = ("rise" in held) - ("sink" in held)
    look = ("look_up" in held) - ("look_down" in held)
    yaw = (yaw + turn * speeds.turn * dt) % 360.0
    heading = np.radians(yaw)
    distance = drive * speeds.move * dt
    # Camera convention (camera.py): yaw 0 looks toward -z, positive yaw turns left (to -x).
    x -= np.sin(heading) * distance
    z -= np.cos(heading) * distance
    y += climb * speeds.climb * dt
    pitch = float(np.clip(pitch + look * speeds.look * dt, -PITCH_LIMIT, PITCH_LIMIT))
    return np.array([x, y, z, yaw, pitch])


def mouse_look(pose, dx: float, dy: float, speeds: Speeds) -> np.ndarray:
    """(5,) pose turned by a mouse drag of (dx, dy) pixels: right turns right, up looks up."""
    pose = np.array(pose, dtype=np.float64)
    pose[3] = (pose[3] - dx * speeds.mouse) % 360.0
    pose[4] = float(np.clip(pose[4] + dy * speeds.mouse, -PITCH_LIMIT, PITCH_LIMIT))
    return pose


def overview_pose(extent) -> np.ndarray:
    """(5,) pose outside the world's box, on its +z side at mid height, looking at its centre."""
    low, high = np.asarray(extent, dtype=np.float64)
    centre = (low + high) / 2.0
    size = float((high - low).max()) or 1.0
    return np.array([centre[0], centre[1], high[2] + 0.6 * size, 0.0, 0.0])

"""The thesis's trajectory menu: record the camera path, save it as the project's trajectory
CSV (vismobile.trajectory), load one and play it back with pause and single steps."""
from __future__ import annotations

import numpy as np

from ..world.trajectory import Trajectory


class Recorder:
    """Collects one pose per frame while on; poses: (F, 5) float64 x, y, z, yaw, pitch."""

    def __init__(self):
        self.on = False
        self._poses = []

    def start(self) -> None:
        """Start a new recording (drops the previous one)."""
        self.on = True
        self._poses = []

    def stop(self) -> None:
        self.on = False

    def add(self, pose) -> None:
        """Append a pose when recording."""
        if self.on:
            self._poses.append(np.array(pose, dtype=np.float64).reshape(5))

    def __len__(self) -> int:
        return len(self._poses)

    @property
    def poses(self) -> np.ndarray:
        return np.array(self._poses, dtype=np.float64).reshape(-1, 5)

    def trajectory(self, fov=45.0, aspect=240 / 320) -> Trajectory:
        """The recording as a Trajectory (no waypoints). ValueError when nothing was recorded."""
        if not self._poses:
            raise ValueError("nothing recorded")
        return Trajectory(self.poses, {}, fov=fov, aspect=aspect)

    def save(self, path) -> Trajectory:
        """Write the recording to path (trajectory CSV, atomic) and return it."""
        trajectory = self.trajectory()
        trajectory.save(path)
        return trajectory


class Player:
    """Plays a Trajectory one frame per update; paused, it moves only by step()."""

    def __init__(self, trajectory: Trajectory):
        self.trajectory = trajectory
        self.frame = 0
        self.paused = False
        self.labels = np.array(sorted(trajectory.waypoints, key=trajectory.waypoints.get),
                               dtype=object)
        self.marks = np.array([trajectory.waypoints[label] for label in self.labels],
                              dtype=np.int64)

    def __len__(self) -> int:
        return len(self.trajectory)

    @property
    def finished(self) -> bool:
        return self.frame >= len(self) - 1

    def pose(self) -> np.ndarray:
        """(5,) pose of the current frame."""
        return self.trajectory.poses[self.frame].copy()

    def advance(self) -> None:
        """Next frame unless paused; stays on the last frame."""
        if not self.paused:
            self.frame = min(self.frame + 1, len(self) - 1)

    def step(self, frames: int) -> None:
        """Move by frames (negative: back), clamped to the path."""
        self.frame = int(np.clip(self.frame + int(frames), 0, len(self) - 1))

    def nearest_waypoint(self):
        """(label, frames from here: negative = still ahead) of the nearest waypoint, or None."""
        if not len(self.marks):
            return None
        offsets = self.frame - self.marks
        nearest = int(np.argmin(np.abs(offsets)))
        return str(self.labels[nearest]), int(offsets[nearest])

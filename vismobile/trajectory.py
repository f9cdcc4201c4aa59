"""Recorded camera paths: CSV `frame,x,y,z,yaw,pitch`, with named waypoints."""
from __future__ import annotations

import io
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .camera import Camera
from .errors import TrajectoryError
from .world import atomic_write_bytes

HEADER = "frame,x,y,z,yaw,pitch"


@dataclass(eq=False)
class Trajectory:
    """Per-frame camera poses.

    poses     : (F, 5) float64 columns x, y, z, yaw, pitch (degrees)
    waypoints : {label: frame index}, e.g. {"A": 56}; stored in the CSV as `# waypoint A 56`
    """

    poses: np.ndarray
    waypoints: dict = field(default_factory=dict)
    fov: float = 45.0
    aspect: float = 240 / 320
    near: float = 0.1
    far: float = 1000.0

    def __post_init__(self):
        self.poses = np.asarray(self.poses, dtype=np.float64).reshape(-1, 5)

    def __len__(self) -> int:
        return len(self.poses)

    def camera(self, frame: int, aspect: float | None = None) -> Camera:
        """The Camera at one frame (the trajectory's aspect unless given)."""
        x, y, z, yaw, pitch = self.poses[frame]
        return Camera((x, y, z), yaw, pitch, self.fov, self.aspect if aspect is None else aspect,
                      self.near, self.far)

    def cameras(self, aspect: float | None = None, frames=None):
        """Iterate Cameras over all frames (or the given frame indices)."""
        for frame in range(len(self)) if frames is None else frames:
            yield self.camera(int(frame), aspect)

    def __iter__(self):
        return self.cameras()

    @classmethod
    def load(cls, path, **camera) -> "Trajectory":
        """Read a trajectory CSV; TrajectoryError naming the file and line on bad input."""
        path = Path(path)
        if not path.is_file():
            raise TrajectoryError(f"{path}: no such trajectory file")
        lines = path.read_text(errors="replace").splitlines()
        waypoints = {}
        rows = []
        header_seen = False
        for number, line in enumerate(lines, start=1):
            text = line.strip()
            if not text:
                continue
            if text.startswith("#"):
                parts = text[1:].split()
                if len(parts) == 3 and parts[0] == "waypoint" and parts[2].isdigit():
                    waypoints[parts[1]] = int(parts[2])
                continue
            if not header_seen:
                if text.replace(" ", "") != HEADER:
                    raise TrajectoryError(f"{path}:{number}: expected header {HEADER!r}")
                header_seen = True
                continue
            try:
                values = [float(v) for v in text.split(",")]
            except ValueError:
                raise TrajectoryError(f"{path}:{number}: not a number") from None
            if len(values) != 6 or not np.isfinite(values).all():
                raise TrajectoryError(f"{path}:{number}: need 6 finite values")
            if int(values[0]) != len(rows):
                raise TrajectoryError(f"{path}:{number}: frame {int(values[0])} out of sequence")
            rows.append(values[1:])
        if not rows:
            raise TrajectoryError(f"{path}: no frames")
        return cls(np.array(rows), waypoints, **camera)

    def save(self, path) -> None:
        """Write the CSV (waypoint comments, header, one pose a line), atomically."""
        buffer = io.StringIO()
        for label, frame in sorted(self.waypoints.items(), key=lambda item: item[1]):
            buffer.write(f"# waypoint {label} {frame}\n")
        buffer.write(HEADER + "\n")
        table = np.column_stack([np.arange(len(self)), self.poses])
        np.savetxt(buffer, table, fmt=["%d", "%.4f", "%.4f", "%.4f", "%.3f", "%.3f"],
                   delimiter=",")
        atomic_write_bytes(path, buffer.getvalue().encode("ascii"))

"""Recorded camera paths: CSV `frame,x,y,z,yaw,pitch,waypoint`, one pose a line.

The waypoint column holds a label (A, B, ...) on the frames the thesis names, empty elsewhere,
so plain CSV readers (numpy.genfromtxt(names=True), pandas, spreadsheets) read the file. The
older form, `frame,x,y,z,yaw,pitch` after `# waypoint A 56` comment lines, still loads.
"""
from __future__ import annotations

import io
import itertools
import re
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .camera import Camera
from ..errors import TrajectoryError
from .world import atomic_write_bytes

HEADER = "frame,x,y,z,yaw,pitch,waypoint"
OLD_HEADER = "frame,x,y,z,yaw,pitch"  # waypoints in `# waypoint A 56` comments
# Bounds that keep a hostile file from costing gigabytes or overflowing the camera's float math.
MAX_FRAMES = 200_000
MAX_POSITION = 1e12
MAX_ANGLE = 1e9
MAX_LINE = 4096
_WAYPOINT = re.compile(r"#\s*waypoint\s+(\S+)\s+(\S+)\s*", re.ASCII)
_LABEL = re.compile(r"[A-Za-z0-9_.-]{1,40}", re.ASCII)


@dataclass(eq=False)
class Trajectory:
    """Per-frame camera poses.

    poses     : (F, 5) float64 columns x, y, z, yaw, pitch (degrees)
    waypoints : {label: frame index}, e.g. {"A": 56}; stored in the CSV's waypoint column
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

    def __repr__(self) -> str:
        if not len(self.poses):
            return "Trajectory(0 frames)"
        low, high = self.poses[:, :3].min(axis=0), self.poses[:, :3].max(axis=0)
        marks = ", ".join(f"{k}@{v}" for k, v in list(self.waypoints.items())[:4])
        more = ", ..." if len(self.waypoints) > 4 else ""
        box = ", ".join(f"{a:.4g}..{b:.4g}" for a, b in zip(low, high))
        return (f"Trajectory({len(self.poses):,} frames, eye in ({box})"
                + (f", waypoints {marks}{more}" if marks else "") + ")")

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
    def load(cls, path, limit=None, **camera) -> "Trajectory":
        """Read a trajectory CSV, lazily: with `limit` only the first `limit` frames are read.

        Without a limit a file of more than MAX_FRAMES frames is refused (pass a limit);
        positions must lie within +-MAX_POSITION and angles within +-MAX_ANGLE degrees; lines
        are at most MAX_LINE characters. TrajectoryError naming the file and line on bad input.
        """
        path = Path(path)
        if limit is not None and (isinstance(limit, bool) or int(limit) < 1):
            raise TrajectoryError(f"{path}: frame limit must be at least 1, got {limit}")
        from ..files.limits import regular_file

        regular_file(path, lambda p, why: TrajectoryError(f"{p}: {why}"))  # no FIFO, no device
        try:
            with open(path, "rb") as handle:
                waypoints, rows = _read(path, handle, limit)
        except OSError as error:
            raise TrajectoryError(f"{path}: cannot read: {error.strerror or error}") from None
        if not rows:
            raise TrajectoryError(f"{path}: no frames")
        return cls(np.array(rows), waypoints, **camera)

    def save(self, path) -> None:
        """Write the CSV (header, one pose a line, waypoint labels in the last column),
        atomically. A waypoint beyond the path is left out with a warning; TrajectoryError for
        a label that is not 1-40 of [A-Za-z0-9_.-] or two waypoints on one frame."""
        labels = [""] * len(self)
        for label, frame in self.waypoints.items():
            if not 0 <= int(frame) < len(self):
                warnings.warn(f"{path}: waypoint {str(label)[:40]!r} at frame {frame} is beyond "
                              f"the {len(self)} frames and is not written", stacklevel=2)
                continue
            if not _LABEL.fullmatch(str(label)) or labels[int(frame)]:
                raise TrajectoryError(f"{path}: waypoint {str(label)[:40]!r} at frame {frame} "
                                      f"cannot be written (path of {len(self)} frames)")
            labels[int(frame)] = str(label)
        table = io.StringIO()
        np.savetxt(table, np.column_stack([np.arange(len(self)), self.poses]),
                   fmt=["%d", "%.4f", "%.4f", "%.4f", "%.3f", "%.3f"], delimiter=",")
        lines = table.getvalue().splitlines()
        text = "".join(f"{line},{label}\n" for line, label in zip(lines, labels))
        atomic_write_bytes(path, (HEADER + "\n" + text).encode("ascii"))


PITCH_AMPLITUDE = 85.0  # degrees: the pitched paths look nearly straight up and down
PITCH_PERIOD = 150  # frames per up-and-down sweep (5 s at 30 fps)
TURN_PERIOD = 420  # frames per full turn of the head (never a multiple of the pitch period)


def pitch_sweep(trajectory: Trajectory, amplitude: float = PITCH_AMPLITUDE,
                period: int = PITCH_PERIOD, turn: int | None = TURN_PERIOD) -> Trajectory:
    """The same path, the camera looking up and down and around: pitch = amplitude
    sin(2 pi f / period), starting level, and (unless turn is None) yaw turned by 360 f / turn
    degrees, so it looks down slopes and at objects' tops from every side. Positions,
    waypoints and camera settings kept."""
    if not 0.0 < amplitude < 90.0 or period < 2 or (turn is not None and turn < 2):
        raise ValueError(f"need 0 < amplitude < 90, period >= 2 and turn >= 2 or None, got "
                         f"{amplitude}, {period}, {turn}")
    poses = trajectory.poses.copy()
    frames = np.arange(len(poses))
    poses[:, 4] = amplitude * np.sin(2.0 * np.pi * frames / period)
    if turn is not None:
        poses[:, 3] = np.mod(poses[:, 3] + 360.0 * frames / turn + 180.0, 360.0) - 180.0
    return Trajectory(poses, dict(trajectory.waypoints), trajectory.fov, trajectory.aspect,
                      trajectory.near, trajectory.far)


def _read(path, handle, limit):
    """(waypoints, rows) of an open trajectory file, reading no further than `limit` frames."""
    waypoints, rows = {}, []
    header_seen, labelled = False, False
    for number in itertools.count(1):
        raw = handle.readline(MAX_LINE + 1)
        if not raw:
            break
        if len(raw) > MAX_LINE and not raw.endswith(b"\n"):
            raise TrajectoryError(f"{path}:{number}: line longer than {MAX_LINE} characters")
        text = raw.decode("utf-8", errors="replace").strip()
        if not text:
            continue
        if text.startswith("#"):
            match = _WAYPOINT.fullmatch(text)
            if match:
                if not re.fullmatch(r"\d{1,9}", match[2], re.ASCII):
                    raise TrajectoryError(f"{path}:{number}: waypoint frame must be a whole "
                                          f"number below 10**9, got {match[2][:20]!r}")
                waypoints[match[1]] = int(match[2])
            continue
        if not header_seen:
            if text.replace(" ", "") not in (HEADER, OLD_HEADER):
                raise TrajectoryError(f"{path}:{number}: expected header {HEADER!r} "
                                      f"(or {OLD_HEADER!r})")
            header_seen, labelled = True, text.replace(" ", "") == HEADER
            continue
        if limit is not None and len(rows) >= limit:
            break
        if len(rows) >= MAX_FRAMES:
            raise TrajectoryError(f"{path}:{number}: more than {MAX_FRAMES:,} frames; pass a "
                                  "frame limit to read the first ones")
        if labelled:
            text, _, label = text.rpartition(",")
            label = label.strip()
            if label:
                if not _LABEL.fullmatch(label):
                    raise TrajectoryError(f"{path}:{number}: waypoint label must be 1-40 of "
                                          f"A-Z a-z 0-9 _ . -, got {label[:20]!r}")
                waypoints[label] = len(rows)
        rows.append(_pose(path, number, text, len(rows)))
    return waypoints, rows


def _pose(path, number, text, expected):
    """[x, y, z, yaw, pitch] of one CSV row, or TrajectoryError naming the line."""
    try:
        values = [float(v) for v in text.split(",")]
    except ValueError:
        raise TrajectoryError(f"{path}:{number}: not a number") from None
    if len(values) != 6 or not np.isfinite(values).all():
        raise TrajectoryError(f"{path}:{number}: need 6 finite values")
    if values[0] != expected:
        raise TrajectoryError(f"{path}:{number}: frame {values[0]:.15g} out of sequence "
                              f"(expected {expected})")
    if max(map(abs, values[1:4])) > MAX_POSITION:
        raise TrajectoryError(f"{path}:{number}: position beyond +-{MAX_POSITION:g}")
    if max(map(abs, values[4:6])) > MAX_ANGLE:
        raise TrajectoryError(f"{path}:{number}: angle beyond +-{MAX_ANGLE:g} degrees")
    return values[1:]


FRAME_SELECTION_HELP = ("all, stride:N (every Nth frame) or sample:N (N evenly spaced frames "
                        "plus the waypoints)")


def select_frames(selection, count: int, waypoints=None) -> list:
    """Frame numbers (sorted, unique) of a selection over `count` frames: "all", "stride:N"
    or "sample:N" (N evenly spaced frames plus the waypoints' frames). ValueError otherwise."""
    text = str(selection or "all").strip().lower()
    match = re.fullmatch(r"(stride|sample):([1-9]\d{0,8})", text)
    if text != "all" and not match:
        raise ValueError(f"bad frame selection {text[:40]!r}: use {FRAME_SELECTION_HELP}")
    if text == "all":
        frames = np.arange(count)
    elif match[1] == "stride":
        frames = np.arange(0, count, int(match[2]))
    else:
        frames = np.linspace(0, count - 1, min(int(match[2]), count)).round().astype(int)
        frames = np.concatenate([frames, [f for f in (waypoints or {}).values() if 0 <= f < count]])
    return sorted(set(int(f) for f in frames))

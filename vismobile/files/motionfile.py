"""The JSON motion file: keyframe paths attached by object name to the objects of any world
(world/animated.py AnimatedWorld.from_motion_file; format in docs/dynamic.md).

    {"fps": 30,
     "objects": {"car_03": {"times": [0, 2, 4],
                            "translation": [[0, 0, 0], [10, 0, 0], [10, 0, 8]],
                            "rotation": [[0, 0, 0, 1], [0, 0.7071, 0, 0.7071], [0, 1, 0, 0]],
                            "scale": [[1, 1, 1], [1, 1, 1], [1, 1, 1]],
                            "interpolation": "linear", "loop": true, "pivot": [5, 0, 2]}}}

times are seconds, strictly increasing; translation is the move from the rest pose, rotation
quaternions (x, y, z, w) turn about the pivot (default: the object's rest box centre), scale
about it too; each channel is optional and has one row per time. Read within MAX_BYTES, every
value checked, so a bad file is one WorldError naming it (and never a traceback).
"""
from __future__ import annotations

import json
import math

from ..errors import WorldError
from .limits import read_bytes

MAX_BYTES = 64 << 20
MAX_OBJECTS = 1 << 20
MAX_KEYS = 1 << 22  # over the whole file
KEYS = {"times", "translation", "rotation", "scale", "interpolation", "loop", "pivot"}
WIDTH = {"translation": 3, "rotation": 4, "scale": 3}


def _number(value, path, where) -> float:
    if isinstance(value, int) and not isinstance(value, bool) and abs(value) > 10 ** 30:
        raise WorldError(path, f"{where}: an integer beyond +-1e30")
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise WorldError(path, f"{where}: expected a finite number, got {str(value)[:40]!r}")
    if abs(value) > 1e30:
        raise WorldError(path, f"{where}: {value:g} beyond +-1e30")
    return float(value)


def _rows(values, count, width, path, where) -> list:
    if not isinstance(values, list) or len(values) != count:
        raise WorldError(path, f"{where}: expected {count} rows (one per time)")
    out = []
    for i, row in enumerate(values):
        if not isinstance(row, list) or len(row) != width:
            raise WorldError(path, f"{where}[{i}]: expected {width} numbers")
        out.append([_number(v, path, f"{where}[{i}]") for v in row])
    return out


def read_motion(path) -> tuple:
    """(fps float, {object name: {"translation": (times, rows) or absent, "rotation": ...,
    "scale": ..., "interpolation": str, "loop": bool, "pivot": [x, y, z] or None}}) of a JSON
    motion file. Raises WorldError naming the file on anything malformed."""
    data = read_bytes(path, MAX_BYTES, what="motion file")
    try:
        doc = json.loads(data.decode("utf-8"))
    except (UnicodeDecodeError, ValueError, RecursionError) as error:
        raise WorldError(path, f"not a JSON motion file ({str(error)[:80]})") from None
    if not isinstance(doc, dict) or not isinstance(doc.get("objects"), dict):
        raise WorldError(path, 'expected a JSON object with an "objects" object')
    extra = sorted(set(doc) - {"fps", "objects"})
    if extra:
        raise WorldError(path, f"unknown key(s) {', '.join(map(repr, extra[:5]))}; "
                               "expected fps, objects")
    fps = _number(doc.get("fps", 30), path, "fps")
    if not 0 < fps <= 1000:
        raise WorldError(path, f"fps {fps:g} outside (0, 1000]")
    objects = doc["objects"]
    if len(objects) > MAX_OBJECTS:
        raise WorldError(path, f"{len(objects):,} objects, over the limit of {MAX_OBJECTS:,}")
    out, keys = {}, 0
    for name, entry in objects.items():
        where = f"objects[{name[:40]!r}]"
        if not isinstance(entry, dict):
            raise WorldError(path, f"{where}: expected an object")
        unknown = sorted(set(entry) - KEYS)
        if unknown:
            raise WorldError(path, f"{where}: unknown key(s) {', '.join(map(repr, unknown[:5]))};"
                                   f" expected {', '.join(sorted(KEYS))}")
        times = entry.get("times")
        if not isinstance(times, list) or not times:
            raise WorldError(path, f"{where}: \"times\" must be a non-empty list of seconds")
        keys += len(times)
        if keys > MAX_KEYS:
            raise WorldError(path, f"more than {MAX_KEYS:,} keys")
        times = [_number(t, path, f"{where}.times") for t in times]
        if any(b <= a for a, b in zip(times, times[1:])):
            raise WorldError(path, f"{where}.times must be strictly increasing")
        parsed = {}
        for channel, width in WIDTH.items():
            if channel in entry:
                rows = _rows(entry[channel], len(times), width, path, f"{where}.{channel}")
                if channel == "rotation" and any(sum(v * v for v in r) < 1e-24 for r in rows):
                    raise WorldError(path, f"{where}.rotation: a zero quaternion")
                parsed[channel] = (times, rows)
        if not parsed:
            raise WorldError(path, f"{where}: no translation, rotation or scale")
        interpolation = entry.get("interpolation", "linear")
        if interpolation not in ("linear", "step"):
            raise WorldError(path, f"{where}.interpolation {str(interpolation)[:20]!r}; valid: "
                                   "linear, step")
        loop = entry.get("loop", False)
        if not isinstance(loop, bool):
            raise WorldError(path, f"{where}.loop must be true or false")
        pivot = entry.get("pivot")
        if pivot is not None:
            pivot = _rows([pivot], 1, 3, path, f"{where}.pivot")[0]
        out[str(name)] = dict(parsed, interpolation=interpolation, loop=loop, pivot=pivot)
    return fps, out

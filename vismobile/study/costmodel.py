"""This machine's frame-cost model (fitted), and the calibration rows of the device model.

CostModel, this machine, fitted from stage counters (hardware-independent) to measured ms:
  cull_ms   ~ c0 + a * nodes_visited + b * plane_tests + c * triangles_tested
  render_ms ~ r0 + d * triangles_sent + e * draw_batches   (fitted apart with GL_CULL_FACE on)
  Coefficients are non-negative (Lawson-Hanson NNLS) and fitted in the same process that uses
  them, so they describe this machine; the model prices configurations from counters alone.
The device model (the iPaq and the N82: DeviceModel, fit_device, cull_cycles) lives one level
down, in vismobile/device/costmodel.py, so playback uses it too; it is re-exported here. This module
adds calibration_rows and CALIBRATION_ROWS: our counters for the thesis's configurations, which
the device figures are fitted to.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..device.costmodel import (CULL_OPERATIONS, DEVICES, DeviceModel, best_device_fit,  # noqa: F401
                         cull_cycles, design, device_counters, device_model, fit_device, label,
                         nnls)

CULL_FEATURES = ("nodes_visited", "plane_tests", "triangles_tested")
RENDER_FEATURES = ("triangles_sent", "draw_batches")


def fit_linear(rows, ms, names) -> tuple:
    """({"constant": .., name: ..}, rms residual ms) of a non-negative fit ms ~ design(rows)."""
    ms = np.asarray(ms, float)
    if len(rows) == 0:
        return dict.fromkeys(("constant",) + tuple(names), 0.0), float("nan")
    matrix = design(rows, names)
    scale = np.maximum(np.abs(matrix).max(axis=0), 1e-12)  # comparable column magnitudes
    coefficients = nnls(matrix / scale, ms) / scale
    residual = float(np.sqrt(np.mean((matrix @ coefficients - ms) ** 2)))
    return dict(zip(("constant",) + tuple(names), map(float, coefficients))), residual


@dataclass
class CostModel:
    """Fitted ms per unit of each counter: `cull`, `render` (no GL_CULL_FACE), `render_back`."""

    cull: dict = field(default_factory=dict)
    render: dict = field(default_factory=dict)
    render_back: dict = field(default_factory=dict)
    residual: dict = field(default_factory=dict)

    @classmethod
    def fit(cls, cull_rows, cull_ms, render_rows, render_ms, render_back=None) -> "CostModel":
        """Fit from counter dicts and (N,) measured ms; render rows with a true "cull_back" key
        go to the GL_CULL_FACE model (which falls back to the other when it has no rows)."""
        model = cls()
        model.cull, model.residual["cull"] = fit_linear(cull_rows, cull_ms, CULL_FEATURES)
        render_ms = np.asarray(render_ms, float)
        back = np.array([bool(row.get("cull_back", False)) for row in render_rows], dtype=bool)
        rows = list(render_rows)
        model.render, model.residual["render"] = fit_linear(
            [r for r, b in zip(rows, back) if not b], render_ms[~back], RENDER_FEATURES)
        if back.any():
            model.render_back, model.residual["render_back"] = fit_linear(
                [r for r, b in zip(rows, back) if b], render_ms[back], RENDER_FEATURES)
        else:
            model.render_back = dict(model.render)
        if not (~back).any():
            model.render = dict(model.render_back)
        return model

    def cull_ms(self, stats: dict) -> float:
        return _apply(self.cull, stats, CULL_FEATURES)

    def render_ms(self, stats: dict, cull_back: bool = False) -> float:
        return _apply(self.render_back if cull_back else self.render, stats, RENDER_FEATURES)

    def render_saving_ms(self, removed_triangles: float, removed_batches: float = 0.0,
                         cull_back: bool = False) -> float:
        """Render time saved by not sending this many triangles and batches."""
        coefficients = self.render_back if cull_back else self.render
        return (coefficients.get("triangles_sent", 0.0) * removed_triangles
                + coefficients.get("draw_batches", 0.0) * removed_batches)

    def describe(self) -> str:
        def text(coefficients):
            return ", ".join(f"{k} {v * (1e3 if k != 'constant' else 1):.3g}"
                             + (" us" if k != "constant" else " ms")
                             for k, v in coefficients.items())
        return (f"cull: {text(self.cull)}\nrender: {text(self.render)}\n"
                f"render with GL_CULL_FACE: {text(self.render_back)}")

    def to_dict(self) -> dict:
        return {"cull": self.cull, "render": self.render, "render_back": self.render_back,
                "residual_ms": self.residual}


def _apply(coefficients: dict, stats: dict, names) -> float:
    return coefficients.get("constant", 0.0) + sum(
        coefficients.get(name, 0.0) * float(stats.get(name, 0)) for name in names)


def calibration_rows(points, worlds_dir=None, cache_dir=None, frames="sample:24",
                     profile_name="ipaq-hx2490b") -> list:
    """Mean device counters (device_counters) of our run of each (world, structure, culling,
    ...) point of thesis.DEVICE_POINTS, over a frame selection of the world's thesis path."""
    from ..device.profile import get_profile
    from ..world.trajectory import Trajectory
    from . import engine
    from .matrix import cull_stages, frame_indices
    from .thesis import trajectory_for

    profile = get_profile(profile_name)
    rows = []
    for world_name, structure, cull, *_ in points:
        world = engine.load_world(world_name, worlds_dir)
        trajectory = Trajectory.load(trajectory_for(world_name))
        partition, _ = engine.load_structure(world, structure, cache_dir)
        culler = engine.make_culler(partition, cull_stages(cull))
        per_frame = [device_counters(culler.cull(trajectory.camera(f, profile.aspect)),
                                     culler.tree)
                     for f in frame_indices(frames, len(trajectory), trajectory.waypoints)]
        names = sorted({k for row in per_frame for k in row})
        rows.append({k: float(np.mean([row.get(k, 0) for row in per_frame])) for k in names})
    return rows


# Our counters for the thesis's configurations (thesis.DEVICE_POINTS["ipaq-hx2490b"], in its
# order; the N82's points are the first six), means over sample:24 frames of each world's path,
# from `calibration_rows` (tools/sweep.py --fit-device prints them afresh). The profiles'
# DeviceCost render figures are fit_device of these rows; tests/study/test_costmodel.py checks
# that the two agree.
CALIBRATION_COLUMNS = ("triangles_sent", "nodes_drawn", "leaves_drawn", "draw_batches",
                       "nodes_visited", "plane_tests", "triangles_tested", "refs_gathered")
CALIBRATION_ROWS = [dict(zip(CALIBRATION_COLUMNS, values)) for values in (
    (1012.4, 328.6, 466.7, 137.7, 636.5, 1139.6, 4316.5, 4316.5),  # w1 octree:4 vfc+bfc+cbfc
    (10046.4, 966.3, 2071.9, 1637.6, 1829.6, 2532.5, 20557.5, 20557.5),  # w2 octree:5 vfc+bfc+cbfc
    (11675.1, 965.3, 2077.2, 1868.3, 1825.0, 2525.4, 22831.0, 22831.0),  # w3 octree:5 vfc+cbfc
    (2625.5, 962.5, 2063.9, 264.0, 1823.5, 2525.6, 10617.2, 10617.2),  # w4 octree:5 vfc+cbfc
    (585.8, 7.4, 7.4, 201.9, 37.0, 186.0, 0.0, 706.7),  # w5 grid vfc
    (1280.2, 187.5, 224.9, 256.6, 378.1, 807.0, 3411.0, 3411.0),  # w6 octree:4 vfc+cbfc
    (6199.0, 1.0, 1.0, 1.0, 0.0, 0.0, 0.0, 0.0),  # w1 octree:4 none
)]

"""Frame-cost models: counters -> ms, on this machine (fitted) or on a thesis device (priced).

CostModel, this machine, fitted from stage counters (hardware-independent) to measured ms:
  cull_ms   ~ c0 + a * nodes_visited + b * plane_tests + c * triangles_tested
  render_ms ~ r0 + d * triangles_sent + e * draw_batches   (fitted apart with GL_CULL_FACE on)
  Coefficients are non-negative (Lawson-Hanson NNLS) and fitted in the same process that uses
  them, so they describe this machine; the model prices configurations from counters alone.
DeviceModel, the iPaq or the N82 (figures in profile.DeviceCost):
  render_ms = base + per triangle * triangles_sent + per call * draw calls, fitted by
  fit_device to the thesis's own device frame times (thesis.DEVICE_POINTS) on our counters for
  the same configurations (CALIBRATION_ROWS);
  cull_ms = cull_cycles(counters) / clock, cycles per operation estimated (CULL_OPERATIONS).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

CULL_FEATURES = ("nodes_visited", "plane_tests", "triangles_tested")
RENDER_FEATURES = ("triangles_sent", "draw_batches")


def nnls(matrix: np.ndarray, target: np.ndarray, iterations: int = 200) -> np.ndarray:
    """(K,) float64 x >= 0 minimising |matrix @ x - target| (Lawson and Hanson 1974)."""
    a = np.asarray(matrix, float)
    b = np.asarray(target, float)
    k = a.shape[1]
    x = np.zeros(k)
    passive = np.zeros(k, dtype=bool)
    for _ in range(iterations):
        gradient = a.T @ (b - a @ x)
        candidates = ~passive & (gradient > 1e-12 * (np.abs(gradient).max() + 1e-300))
        if not candidates.any():
            break
        passive[np.argmax(np.where(candidates, gradient, -np.inf))] = True
        for _ in range(k + 1):
            z = np.zeros(k)
            z[passive] = np.linalg.lstsq(a[:, passive], b, rcond=None)[0]
            if (z[passive] > 0).all():
                x = z
                break
            # Step back toward x until the first passive coefficient reaches zero.
            falling = passive & (z <= 0)
            alpha = np.min(x[falling] / np.maximum(x[falling] - z[falling], 1e-300))
            x = x + alpha * (z - x)
            passive &= x > 1e-15
            x[~passive] = 0.0
    return x


def design(rows, names) -> np.ndarray:
    """(N, 1 + len(names)) float64: a constant column, then each counter of each row dict."""
    table = np.array([[float(row.get(name, 0.0)) for name in names] for row in rows],
                     dtype=float).reshape(len(rows), len(names))
    return np.column_stack([np.ones(len(rows)), table])


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


# ---- the device model: what a frame costs on the thesis's devices ---------------------------
#
# Cull work is priced from the Culler's counters, not from our numpy wall time: numpy on a
# ~3 GHz x86 shares nothing with scalar C++ on a 520 MHz PXA270 (no FPU: every float operation
# is a call into the compiler's software-float library, ~40-60 cycles) or a 332 MHz ARM11
# (VFP11 hardware float, ~2-6 cycles with its load and pipeline stalls). Per counter: the float
# operations and the integer cycles a scalar C++ loop spends on one unit of it, assuming a warm
# 32 KB data cache (a miss to SDRAM costs ~50 cycles more, folded into the node visit):
#   nodes_visited    : 0 float, 60 int  (load 6 bounds, child loop and stack; one cache miss)
#   plane_tests      : 7 float, 10 int  (p-vertex by the plane's sign mask: 3 mul, 3 add,
#                                        1 compare)
#   triangles_tested : 0 float, 12 int  (CBFC: a precomputed region id, a table lookup)
#   refs_gathered    : 0 float, 8 int   (load a reference, frame-stamp dedup, append an index)
#   occlusion.nodes_tested   : 150 float, 50 int (project 8 box corners, scan the depth rect)
#   occlusion.occluders      : 60 float, 40 int  (project and set up one occluder triangle)
#   occlusion.pixels_covered : 0 float, 12 int   (fixed-point depth raster, per pixel written)
#   portals.portals_tested   : 80 float, 40 int  (project 4 corners, clip the screen rect)
#   portals.cells_visited    : 0 float, 40 int
#   cone.clusters_tested     : 8 float, 10 int   (cone axis dot view vector, compare)
# The thesis gives no cull timings of its own, so these are estimates, not fits: they make
# culling 0.2-3% of a modelled iPaq frame, consistent with its time-triangle correlations of
# +0.87..+0.98 (frame time is almost all rendering).
CULL_OPERATIONS = {
    "nodes_visited": (0, 60),
    "plane_tests": (7, 10),
    "triangles_tested": (0, 12),
    "refs_gathered": (0, 8),
    "occlusion.nodes_tested": (150, 50),
    "occlusion.occluders": (60, 40),
    "occlusion.pixels_covered": (0, 12),
    "portals.portals_tested": (80, 40),
    "portals.cells_visited": (0, 40),
    "cone.clusters_tested": (8, 10),
}


def cull_cycles(stats: dict, float_op_cycles: float) -> float:
    """CPU cycles of one frame's culling on a device, from its counters (CULL_OPERATIONS)."""
    return sum(float(stats.get(name, 0)) * (floats * float_op_cycles + ints)
               for name, (floats, ints) in CULL_OPERATIONS.items())


def device_counters(result, tree) -> dict:
    """The Culler's numeric counters plus two the device model reads:
    refs_gathered (references the draw nodes hold: 0 when the root is drawn whole, which a
    device runtime draws straight from its vertex buffer) and leaves_drawn (non-empty leaves
    under the draw nodes)."""
    stats = {k: v for k, v in result.stats.items() if isinstance(v, (int, float))}
    nodes = np.asarray(result.nodes, dtype=np.int64)
    whole = len(nodes) == 1 and nodes[0] == 0
    stats["refs_gathered"] = 0 if whole or not len(nodes) else \
        int((tree.ref_end[nodes] - tree.ref_start[nodes]).sum())
    stats["leaves_drawn"] = 1 if whole else int(np.count_nonzero(
        tree.nonempty[tree.leaf_order[tree.leaves_under(nodes)]])) if len(nodes) else 0
    return stats


class DeviceModel:
    """Frame time of a configuration on a device (profile.cost), from counters alone.

    render ms = base + per triangle x triangles_sent + per call x draw calls (the profile's
    call_counter); GL_CULL_FACE is priced as neutral: the thesis found the iPaq's driver
    back-face culling sometimes slowed rendering, and no figure of its own isolates the effect.
    cull ms = cull_cycles(counters) / clock.
    """

    kind = "device"

    def __init__(self, profile):
        if profile.cost is None:
            raise ValueError(f"profile {profile.name} has no device cost figures")
        self.profile = profile.name
        self.cost = profile.cost

    def cull_ms(self, stats: dict) -> float:
        return cull_cycles(stats, self.cost.float_op_cycles) / (self.cost.clock_mhz * 1e3)

    def render_ms(self, stats: dict, cull_back: bool = False) -> float:
        c = self.cost
        triangles = float(stats.get("triangles_sent", 0))
        return (c.render_base_ms + c.render_triangle_us * 1e-3 * triangles
                + c.render_call_us * 1e-3 * float(stats.get(c.call_counter, 0)))

    def frame_ms(self, stats: dict, cull_back: bool = False) -> float:
        return self.cull_ms(stats) + self.render_ms(stats, cull_back)

    def render_saving_ms(self, removed_triangles: float, removed_calls: float = 0.0,
                         cull_back: bool = False) -> float:
        return (self.cost.render_triangle_us * removed_triangles
                + self.cost.render_call_us * removed_calls) * 1e-3

    def describe(self) -> str:
        c = self.cost
        calls = (f" + {c.render_call_us:.1f} us per draw call ({c.call_counter})"
                 if c.render_call_us else "")
        return (f"device model {self.profile}: render ms = {c.render_base_ms:.1f} + "
                f"{c.render_triangle_us:.2f} us per triangle sent{calls}; GL_CULL_FACE neutral\n"
                f"cull ms = counters x cycles per operation / {c.clock_mhz:g} MHz, "
                f"{c.float_op_cycles:g} cycles per float operation (costmodel.CULL_OPERATIONS)\n"
                f"source: {c.source}")

    def to_dict(self) -> dict:
        from dataclasses import asdict

        return {"kind": self.kind, "profile": self.profile, **asdict(self.cost),
                "cull_operations": {k: list(v) for k, v in CULL_OPERATIONS.items()}}


def fit_device(rows, target_ms, float_op_cycles: float, clock_mhz: float,
               call_counter=None) -> dict:
    """Fit render ms = base + per triangle x triangles_sent [+ per call x call_counter] to a
    device's frame times, after taking off each row's modelled cull time.

    rows      : list of counter dicts (means over frames) of the device's measured configurations
    target_ms : (N,) the device's mean ms per frame for them
    Returns {"base_ms", "triangle_us", "call_us", "call_counter", "fit_error", "loo_error",
    "loo_max", "predicted_ms"}: errors are mean |predicted - target| / target over the rows,
    and over each row predicted by a fit without it (leave-one-out).
    """
    target = np.asarray(target_ms, float)
    cull = np.array([cull_cycles(r, float_op_cycles) for r in rows]) / (clock_mhz * 1e3)
    names = ["triangles_sent"] + ([call_counter] if call_counter else [])
    matrix = design(rows, names)
    scale = np.maximum(np.abs(matrix).max(axis=0), 1e-12)

    def solve(keep):
        return nnls(matrix[keep] / scale, target[keep] - cull[keep]) / scale

    everything = np.ones(len(rows), dtype=bool)
    coefficients = solve(everything)
    predicted = matrix @ coefficients + cull
    held_out = []
    for i in range(len(rows)):
        keep = everything.copy()
        keep[i] = False
        held_out.append(abs(matrix[i] @ solve(keep) + cull[i] - target[i]) / target[i])
    return {"base_ms": float(coefficients[0]), "triangle_us": float(coefficients[1] * 1e3),
            "call_us": float(coefficients[2] * 1e3) if call_counter else 0.0,
            "call_counter": call_counter,
            "fit_error": float(np.mean(np.abs(predicted - target) / target)),
            "loo_error": float(np.mean(held_out)), "loo_max": float(np.max(held_out)),
            "predicted_ms": predicted.tolist()}


def best_device_fit(rows, target_ms, float_op_cycles, clock_mhz,
                    call_counters=("nodes_drawn", "leaves_drawn", "draw_batches")) -> tuple:
    """(chosen fit, every fit): triangles alone, or with one draw-call counter, chosen by the
    lowest leave-one-out error (a second term must earn its place on held-out points)."""
    fits = [fit_device(rows, target_ms, float_op_cycles, clock_mhz)]
    fits += [fit_device(rows, target_ms, float_op_cycles, clock_mhz, name)
             for name in call_counters]
    return min(fits, key=lambda f: f["loo_error"]), fits


def calibration_rows(points, worlds_dir="worlds", cache_dir=None, frames="sample:24",
                     profile_name="ipaq-hx2490b") -> list:
    """Mean device counters (device_counters) of our run of each (world, structure, culling,
    ...) point of thesis.DEVICE_POINTS, over a frame selection of the world's thesis path."""
    from ..profile import get_profile
    from ..trajectory import Trajectory
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

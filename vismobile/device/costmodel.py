"""The device cost model: one frame's counters -> ms on the thesis's iPaq or N82.

The one place every device figure comes from (tune, the compare runs and report, play's summary
and HUD). A figure is either "measured here" (wall time on this machine) or "<device> model"
(label()): never mixed silently.

render ms = base + per triangle x triangles_sent + per call x draw calls; the render figures
  (profile.DeviceCost) are fit_device of the thesis's own device frame times
  (study/thesis.DEVICE_POINTS) on our counters for the same configurations;
cull ms = cull_cycles(counters) / clock, cycles per operation estimated (CULL_OPERATIONS).
"""
from __future__ import annotations

from functools import lru_cache

import numpy as np

from .profile import PROFILES, get_profile
from ..stats import summarize

# Profiles with device cost figures, in the thesis's order (Table 5.1).
DEVICES = tuple(name for name, profile in PROFILES.items() if profile.cost is not None)
SHORT_NAMES = {"ipaq-hx2490b": "iPaq hx2490b", "nokia-n82": "Nokia N82"}
MEASURED = "measured here"


def device_name(device: str) -> str:
    """Short human name of a device profile ("iPaq hx2490b")."""
    return SHORT_NAMES.get(device, device)


def label(device=None) -> str:
    """How a figure was obtained: "measured here" (None) or "<device> model"."""
    return MEASURED if device is None else f"{device_name(device)} model"


@lru_cache(maxsize=None)
def device_model(device: str) -> "DeviceModel":
    """The DeviceModel of a device profile name (ValueError when it has no cost figures)."""
    return DeviceModel(get_profile(device))


def frame_model_ms(rows, device: str) -> np.ndarray:
    """(F,) modelled frame ms on a device of F per-frame counter dicts (device_counters)."""
    model = device_model(device)
    return np.array([model.frame_ms(row) for row in rows], dtype=np.float64)


def model_block(rows, devices=DEVICES) -> dict:
    """{device: {"label", "frame_ms": mean/median/p95, "fps"}} of per-frame counter rows,
    for summaries (play's summary.json, a compare run's summary)."""
    block = {}
    for device in devices:
        ms = frame_model_ms(rows, device)
        mean = float(ms.mean()) if len(ms) else float("nan")
        block[device] = {"label": label(device), "frame_ms": summarize(ms),
                         "fps": 1000.0 / mean if mean > 0 else None}
    return block


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
#   occlusion.candidate_nodes: 0 float, 40 int   (visit a node for its listed candidates)
#   occlusion.candidates     : 25 float, 20 int  (score one: facing, distance, frustum sphere)
#   portals.portals_tested   : 80 float, 40 int  (project 4 corners, clip the screen rect)
#   portals.cells_visited    : 0 float, 40 int
#   cone.clusters_tested     : 8 float, 10 int   (cone axis dot view vector, compare)
#   horizon.pieces           : 0 float, 60 int   (one band x slice cast: 4 corners of
#                                                 the piece, a min-pyramid read of 1-4 cells)
#   horizon.nodes_tested     : 0 float, 120 int  (8 corners to slopes, bands compared)
#   horizon.triangles_tested : 0 float, 200 int  (3 corners grown by the margin, bands compared)
#   horizon.triangles_centre_tested: 0 float, 80 int (with the screen: 3 corners projected,
#                                                 16.16 divides, the centres in their box)
#   pvs.cells_tested         : 0 float, 12 int   (the eye against one view cell's box: 6
#                                                 16.16 compares, as a device would store it)
#   pvs.ids_decoded          : 0 float, 4 int    (a cache miss: per triangle, its pattern
#                                                 id read, the cell's bit looked up, written)
#   pvs.triangles_tested     : 0 float, 4 int    (one keep-table byte per gathered triangle)
#   (the bake itself is offline: it costs no frame, only memory, Profile.estimate_memory)
#   (the horizon priced as its 16.16 kernels, integer multiply-high and divide, as seed 001 ran
#   it on FPU-less devices; horizon.pieces counts the pieces cast, up to the early stops)
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
    "occlusion.candidate_nodes": (0, 40),
    "occlusion.candidates": (25, 20),
    "portals.portals_tested": (80, 40),
    "portals.cells_visited": (0, 40),
    "cone.clusters_tested": (8, 10),
    "horizon.pieces": (0, 60),
    "horizon.nodes_tested": (0, 120),
    "horizon.triangles_tested": (0, 200),
    "horizon.triangles_centre_tested": (0, 80),
    "pvs.cells_tested": (0, 12),
    "pvs.ids_decoded": (0, 4),
    "pvs.triangles_tested": (0, 4),
}


def cull_cycles(stats: dict, float_op_cycles: float) -> float:
    """CPU cycles of one frame's culling on a device, from its counters (CULL_OPERATIONS)."""
    return sum(float(stats.get(name, 0)) * (floats * float_op_cycles + ints)
               for name, (floats, ints) in CULL_OPERATIONS.items())


def device_counters(result, tree=None) -> dict:
    """The Culler's numeric counters plus two the device model reads:
    refs_gathered (references the draw nodes hold: 0 when the root is drawn whole, which a
    device runtime draws straight from its vertex buffer) and leaves_drawn (non-empty leaves
    under the draw nodes). A result without draw nodes, or no tree (no partition: the whole
    world), is one draw call of the whole vertex buffer."""
    stats = {k: v for k, v in result.stats.items()
             if isinstance(v, (int, float)) and not isinstance(v, bool)}
    nodes = np.asarray(getattr(result, "nodes", [0]), dtype=np.int64)
    whole = tree is None or (len(nodes) == 1 and nodes[0] == 0)
    if tree is None:
        stats.setdefault("nodes_drawn", 1)
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

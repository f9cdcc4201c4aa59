"""Numerical-stability stress suite (issue 7): every stress world x structure x conservative stage
set x arithmetic mode, checked against the item buffer.

For each case and mode the device's view is emulated: the world's vertices and the camera are
rounded to the mode (culling/precision.py; a ProfileError there is the clear refusal the issue
asks for). The partition is built on the rounded world and the float64 Culler culls it from the
rounded camera, once plainly ("raw") and once with frustum planes inflated by the mode's bound
("inflated", precision.conservative_camera). A false negative is a triangle that the item
buffer shows but the culler dropped, against two truths: the rounded world seen by the rounded
camera, and the float64 world seen by the float64 camera. Item buffers are rendered relative
to the eye (float64 subtraction first), so float32 on the GPU does not blur the truth itself.
The device's own plane tests are replayed in the mode (arithmetic.box_certainly_outside) on every
visible triangle's box: "device" false negatives count those it would wrongly call outside.

Usage: .venv/bin/python tools/stress.py [--quick] [--cases a,b] [--modes m] [--out FILE.md]
Prints the mode x case table (markdown) for the README.
"""
from __future__ import annotations

import argparse
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from vismobile.world.camera import Camera  # noqa: E402
from vismobile.culling import BACKFACE_STAGES, Culler  # noqa: E402
from vismobile.culling import precision  # noqa: E402
from vismobile.errors import ProfileError  # noqa: E402
from vismobile.geometry import arithmetic  # noqa: E402
from vismobile.partition import partition  # noqa: E402
from vismobile.device.profile import get_profile  # noqa: E402
from vismobile.render import SENTINEL, item_buffer  # noqa: E402
from vismobile.scenes.stress import partition_cameras, stress_cases  # noqa: E402

STRUCTURES = {"grid": dict(auto=True, cells=64), "octree": dict(depth=3),
              "portal": dict(depth=1), "bsp": dict()}
# Conservative stage sets; each needs cull_back in the truth when a backface stage is in it.
STAGE_SETS = ("vfc", "vfc_thesis", "vfc,cbfc", "vfc,cone", "vfc,tbfc", "vfc,occlusion",
              "occlusion_thesis",
              "portals")
BACKFACE = set(BACKFACE_STAGES)
PROFILE = get_profile("nokia-n82", "float32")  # 240 x 320, the thesis devices' screen


@dataclass
class Cell:
    """Results of one (mode, case) over all structures, stage sets and cameras."""

    runs: int = 0
    refused: str = ""
    crashes: list = field(default_factory=list)
    nans: int = 0
    fn_raw: int = 0          # false negatives, raw culling, against either truth
    fn_inflated: int = 0     # false negatives with inflated planes
    fn_device: int = 0       # visible triangles the device's own plane test calls outside
    fn_examples: list = field(default_factory=list)
    max_error: float = 0.0   # largest |device plane distance - exact| seen
    max_ratio: float = 0.0   # largest error / bound
    vertex_error: float = 0.0
    margin: float = 0.0
    time_raw: list = field(default_factory=list)
    time_inflated: list = field(default_factory=list)
    sent_raw: int = 0
    sent_inflated: int = 0
    inflate_s: float = 0.0   # median seconds of one conservative_planes call (the hook's cost)


def visible_ids(world, camera, cull_back) -> np.ndarray:
    """Sorted ids the item buffer shows, rendered relative to the eye (float64 shift first)."""
    local = world.transformed(1.0, -camera.eye)
    at_origin = Camera((0.0, 0.0, 0.0), camera.yaw, camera.pitch, camera.fov, camera.aspect,
                       camera.near, camera.far)
    ids = np.unique(item_buffer(local, None, at_origin, PROFILE, cull_back=cull_back))
    return ids[ids != SENTINEL].astype(np.int64)


def plane_errors(camera, world, ids, mode) -> tuple:
    """(max |device - exact| plane distance, max error / bound) over the triangles' corners."""
    if not len(ids):
        return 0.0, 0.0
    planes = camera.frustum_planes()
    points = world.corners[ids].reshape(-1, 3)
    values, bounds = arithmetic.plane_distance(planes, points, mode)
    exact = (points.astype(np.longdouble) @ planes[:, :3].T.astype(np.longdouble)
             + planes[:, 3].astype(np.longdouble))
    error = np.abs(values.astype(np.longdouble) - exact).astype(np.float64)
    return float(error.max()), float((error / bounds).max())


def run_case(case, mode, cell, structures, stage_sets, repeats=3):
    """Fill cell with the results of one stress case in one mode."""
    try:
        world_m = case.world.quantized(mode)
    except ProfileError as error:
        cell.refused = str(error)
        return
    used = np.unique(case.world.triangles)
    planes = case.cameras[0][1].frustum_planes()
    scale = precision.world_scale(world_m.vertices[used])
    times = []
    for _ in range(200):
        start = time.perf_counter()
        precision.conservative_planes(planes, mode, scale)
        times.append(time.perf_counter() - start)
    cell.inflate_s = float(np.median(times))
    cell.vertex_error = max(cell.vertex_error, float(np.abs(
        world_m.vertices[used] - case.world.vertices[used]).max()))
    for kind in structures:
        try:
            part = partition(world_m, kind, **STRUCTURES[kind])
        except Exception as error:  # a crash is a result here, recorded with its message
            cell.crashes.append(f"{kind} build: {type(error).__name__}: {error}")
            continue
        portals = part.extras.get("portal_vertices")
        cameras = case.cameras + partition_cameras(part.node_bounds, part.level_start, portals,
                                                   None, case.scale)
        for label, camera in cameras:
            try:
                cam_m = precision.quantize_camera(camera, mode)
            except ProfileError as error:
                cell.refused = cell.refused or f"camera {label}: {error}"
                continue
            scale = precision.world_scale(world_m.vertices[used], cam_m)
            wide = precision.conservative_camera(cam_m, mode, scale)
            cell.margin = max(cell.margin, wide.margin)
            truths = {}
            for back in (False, True):
                truths[back] = np.union1d(visible_ids(case.world, camera, back),
                                          visible_ids(world_m, cam_m, back))
            try:
                err, ratio = plane_errors(cam_m, world_m, truths[False], mode)
                cell.max_error, cell.max_ratio = max(cell.max_error, err), max(cell.max_ratio,
                                                                              ratio)
                inflated = precision.conservative_planes(cam_m.frustum_planes(), mode, scale)
                out = arithmetic.box_certainly_outside(inflated, world_m.bounds[truths[False]],
                                                       mode)
                cell.fn_device += int(out.sum())
            except ProfileError as error:
                cell.refused = cell.refused or f"plane test {label}: {error}"
            for stages in stage_sets:
                if stages == "portals" and kind != "portal":
                    continue
                back = bool(BACKFACE & set(stages.split(",")))
                truth = truths[back]
                try:
                    culler = Culler(part, stages)
                    for use, times, attr in ((cam_m, cell.time_raw, "raw"),
                                             (wide, cell.time_inflated, "inflated")):
                        best = np.inf
                        for _ in range(repeats):
                            start = time.perf_counter()
                            result = culler.cull(use)
                            best = min(best, time.perf_counter() - start)
                        times.append(best)
                        sent = np.asarray(result.triangles)
                        missing = np.setdiff1d(truth, sent)
                        setattr(cell, f"fn_{attr}", getattr(cell, f"fn_{attr}") + len(missing))
                        setattr(cell, f"sent_{attr}", getattr(cell, f"sent_{attr}") + len(sent))
                        if len(missing) and len(cell.fn_examples) < 8:
                            cell.fn_examples.append(f"{attr} {kind} {stages} {label}: "
                                                    f"{missing[:5].tolist()}")
                        cell.nans += int(any(np.isnan(float(v)) for v in result.stats.values()
                                             if isinstance(v, (int, float))))
                    cell.runs += 1
                except ProfileError as error:
                    cell.refused = cell.refused or f"{kind} {stages}: {error}"
                except Exception as error:
                    cell.crashes.append(f"{kind} {stages} {label}: {type(error).__name__}: "
                                        f"{error}")


def table(cells, cases, modes) -> str:
    """Markdown table: one row per case, one column group per mode."""
    head = "| case | " + " | ".join(modes) + " |"
    rows = [head, "|" + " --- |" * (len(modes) + 1)]
    for case in cases:
        entries = []
        for mode in modes:
            c = cells[mode, case]
            if c.refused and not c.runs:
                entries.append("refused (ProfileError)")
                continue
            text = (f"FN {c.fn_raw}/{c.fn_inflated}/{c.fn_device}; err {c.max_error:.2g} "
                    f"({c.max_ratio:.2f} of bound)")
            if c.time_raw:
                raw, wide = 1e6 * np.median(c.time_raw), 1e6 * np.median(c.time_inflated)
                extra = c.sent_inflated / max(c.sent_raw, 1) - 1.0
                text += (f"; cull {raw:.0f}/{wide:.0f} us, inflation {1e6 * c.inflate_s:.1f} us"
                         f", +{100 * extra:.1f}% sent")
            if c.crashes:
                text += f"; {len(c.crashes)} crash(es)"
            if c.nans:
                text += f"; {c.nans} NaN"
            if c.refused:
                text += "; some cameras refused"
            entries.append(text)
        rows.append(f"| {case} | " + " | ".join(entries) + " |")
    return "\n".join(rows)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", help="comma list of case names (default: all)")
    parser.add_argument("--modes", default=",".join(arithmetic.MODES))
    parser.add_argument("--structures", default=",".join(STRUCTURES))
    parser.add_argument("--stages", default=";".join(STAGE_SETS),
                        help="stage sets separated by ';', e.g. 'vfc;vfc,cbfc'")
    parser.add_argument("--quick", action="store_true", help="octree and vfc only")
    parser.add_argument("--out", help="also write the table and details to this markdown file")
    args = parser.parse_args(argv)
    modes = args.modes.split(",")
    structures = ["octree"] if args.quick else args.structures.split(",")
    stage_sets = ["vfc"] if args.quick else args.stages.split(";")
    cases = [c for c in stress_cases() if not args.cases or c.name in args.cases.split(",")]
    cells = {}
    start = time.perf_counter()
    for case in cases:
        for mode in modes:
            cells[mode, case.name] = cell = Cell()
            run_case(case, mode, cell, structures, stage_sets)
            print(f"{case.name:18s} {mode:10s} runs {cell.runs:4d} FN raw {cell.fn_raw} "
                  f"inflated {cell.fn_inflated} device {cell.fn_device} crashes "
                  f"{len(cell.crashes)} {'refused' if cell.refused else ''}"
                  f" [{time.perf_counter() - start:.0f} s]", file=sys.stderr, flush=True)
    names = [c.name for c in cases]
    text = table(cells, names, modes)
    details = []
    for (mode, name), c in cells.items():
        for line in ([f"refused: {c.refused}"] if c.refused else []) + c.crashes[:5] \
                + c.fn_examples:
            details.append(f"- {name} / {mode}: {line}")
        details.append(f"- {name} / {mode}: vertex error {c.vertex_error:.3g}, "
                       f"margin {c.margin:.3g}, runs {c.runs}")
    print(text)
    print("\nFN = false negatives raw / inflated / device plane test; err = largest plane-test "
          "error of the mode vs exact (and its share of the rigorous bound); cull = median cull "
          "time raw / inflated; inflation = one conservative_planes call; sent = extra "
          "triangles sent because of the inflation.")
    if args.out:
        from vismobile.world.world import atomic_write_bytes
        body = text + "\n\nDetails:\n" + "\n".join(details) + "\n"
        atomic_write_bytes(args.out, body.encode())
    bad = sum(len(c.crashes) + c.nans + c.fn_inflated + c.fn_device for c in cells.values())
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())

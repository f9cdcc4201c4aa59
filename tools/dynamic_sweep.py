"""Conservativeness sweep on an animated world (issue 25 target 1): W2 with N moving instances
(each at most 1,000 triangles), every conservative combination of tests/culling/
test_conservative.py (COMBOS, with its stage options) on an octree and a portal octree, from
random cameras at random times and cameras looking at a moving object, against the item buffer
of the frame's pose; optionally in the device's float32 and fixed16.16 vertex formats (the
three buffers of render/device_view.py).

    .venv/bin/python tools/dynamic_sweep.py [--instances 1000] [--frames 12]
        [--modes float64,float32,fixed16.16] [--structures octree,portal] [--seed 3]
        [--rows portal:float64,portal:float32] [--combos K]

Prints one markdown row per structure and mode: frames, culls, visible triangles (moving ones
among them), dropped triangles (must be 0), seconds. --rows runs only the listed
structure:mode rows (instead of every --structures x --modes); --combos K a seeded sample of K
of the combinations (default all): the full sweep at 1,000 instances takes hours on a shared
machine, one row of 12 frames 10-60 minutes, so a row with --frames 4 --combos 8 fits in
minutes.
"""
from __future__ import annotations

import argparse
import importlib.util
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from vismobile.culling import Culler, device_options, parse_stages  # noqa: E402
from vismobile.culling.culler import BACKFACE_STAGES  # noqa: E402
from vismobile.device.profile import get_profile  # noqa: E402
from vismobile.partition import partition  # noqa: E402
from vismobile.render import SENTINEL, item_buffer  # noqa: E402
from vismobile.render.device_view import device_buffers, shown_ids  # noqa: E402
from vismobile.scenes import build_world  # noqa: E402
from vismobile.scenes.animated import animated_instances  # noqa: E402
from vismobile.world.camera import Camera  # noqa: E402

PROFILE = "ipaq-hx2490b"
STRUCTURES = {"octree": {"depth": 4}, "portal": {"depth": 1}}
MODES = ("float64", "float32", "fixed16.16")


def combos() -> tuple:
    spec = importlib.util.spec_from_file_location(
        "conservative", ROOT / "tests" / "culling" / "test_conservative.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.COMBOS, module.OPTIONS


def frames(animated, count, seed, aspect) -> list:
    """(camera, t): alternately a random camera in the world's box and one 2.5 units from a
    random moving object, looking at it."""
    rng = np.random.default_rng(seed)
    low, high = animated.world.extent
    out = []
    for i in range(count):
        t = float(rng.uniform(0, 10))
        if i % 2:
            box = animated.bounds_at(t)[1][rng.integers(len(animated.motion))]
            yaw = rng.uniform(0, 360)
            forward = np.array([-np.sin(np.radians(yaw)), 0.0, -np.cos(np.radians(yaw))])
            eye = np.clip(box.mean(axis=0) - 2.5 * forward, low, high)
            out.append((Camera(eye, yaw=yaw, pitch=rng.uniform(-20, 20), aspect=aspect), t))
        else:
            out.append((Camera(rng.uniform(low, high), yaw=rng.uniform(0, 360),
                               pitch=rng.uniform(-60, 60), aspect=aspect), t))
    return out


def sweep(part, shots, mode, all_combos, options) -> dict:
    profile = get_profile(PROFILE) if mode == "float64" else get_profile(PROFILE, mode)
    device = device_options(profile) if mode != "float64" else {}
    cullers = {}
    for combo in all_combos:
        if "portals" in combo and part.kind != "portal":
            continue
        extra = options.get(combo, {})
        stage_options = {k: v for k, v in device.items() if k != "arithmetic"}
        merged = {k: {**stage_options.get(k, {}), **extra.get(k, {})}
                  for k in set(stage_options) | set(extra)}
        cullers[combo] = Culler(part, combo, device.get("arithmetic", "float64"), **merged)
    row = {"frames": len(shots), "culls": 0, "visible": 0, "moving": 0, "dropped": 0,
           "worst": ""}
    for cam, t in shots:
        posed = part.animated.posed(t)
        truth = {}
        for combo, culler in cullers.items():
            back = bool(set(BACKFACE_STAGES) & set(parse_stages(combo)))
            if back not in truth:
                if mode == "float64":
                    ids = np.unique(item_buffer(posed, None, cam, profile, cull_back=back))
                    truth[back] = ids[ids != SENTINEL].astype(np.int64)
                else:
                    truth[back] = shown_ids(device_buffers(posed, cam, profile, back))
                row["visible"] += len(truth[back])
                row["moving"] += int(part.animated.moving_mask[truth[back]].sum())
            missing = np.setdiff1d(truth[back], culler.cull(cam, time=t).triangles)
            row["culls"] += 1
            if len(missing):
                row["dropped"] += len(missing)
                row["worst"] = row["worst"] or f"{combo} t={t:.2f} {cam}"
    return row


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--instances", type=int, default=1000)
    parser.add_argument("--frames", type=int, default=12)
    parser.add_argument("--modes", default="float64,float32,fixed16.16")
    parser.add_argument("--seed", type=int, default=3)
    parser.add_argument("--structures", default="octree,portal")
    parser.add_argument("--rows", default=None,
                        help="structure:mode pairs, comma-separated (instead of the product)")
    parser.add_argument("--combos", type=int, default=None,
                        help="a seeded sample of this many combinations (default all)")
    args = parser.parse_args(argv)
    all_combos, options = combos()
    if args.rows is None:
        rows = [(kind, mode) for kind in args.structures.split(",")
                for mode in args.modes.split(",")]
    else:
        rows = [tuple(pair.split(":", 1)) for pair in args.rows.split(",")]
    for row in rows:
        if len(row) != 2 or row[0] not in STRUCTURES or row[1] not in MODES:
            parser.error(f"bad row {':'.join(row)!r}: structure:mode with structure in "
                         f"{', '.join(STRUCTURES)} and mode in {', '.join(MODES)}")
    if args.combos is not None:
        if not 1 <= args.combos <= len(all_combos):
            parser.error(f"--combos must be in 1..{len(all_combos)}")
        pick = np.random.default_rng(args.seed).choice(len(all_combos), args.combos,
                                                        replace=False)
        all_combos = [all_combos[i] for i in sorted(pick)]
    animated = animated_instances(build_world("w2"), args.instances, seed=args.seed)
    shots = frames(animated, args.frames, args.seed, get_profile(PROFILE).aspect)
    print(f"W2 + {args.instances:,} moving instances ({int(animated.moving_mask.sum()):,} moving "
          f"triangles), {len(all_combos)} combinations\n")
    print("| structure | mode | frames | culls | visible (moving) | dropped | seconds |")
    print("| --- | --- | ---: | ---: | ---: | ---: | ---: |")
    failed = 0
    parts = {}
    for kind, mode in rows:
        if kind not in parts:
            parts[kind] = partition(animated, kind, **STRUCTURES[kind])
        start = time.perf_counter()
        row = sweep(parts[kind], shots, mode, all_combos, options)
        failed += row["dropped"]
        print(f"| {kind} | {mode} | {row['frames']} | {row['culls']} | {row['visible']:,} "
              f"({row['moving']:,}) | {row['dropped']} | {time.perf_counter() - start:.0f} |"
              + (f" {row['worst']}" if row["worst"] else ""), flush=True)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())

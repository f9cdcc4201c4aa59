"""Moving objects as occluders (issue 25, culling/moving_occluders.py): triangles `occlusion`
sends with the moving objects offering occluders (posed at the frame's time) against the same
Culler without them, on W2 with N moving instances along W2's indoor path (bench_dynamic's
frames) and on W7's path with its doors on their schedule (every --step-th frame); the ms
medians of both, interleaved; optionally (--check K) the triangles dropped on every K-th frame
against the item buffer of the frame's pose (must be 0).

    .venv/bin/python tools/bench_moving_occluders.py [--instances 1000] [--frames 120]
        [--step 10] [--stages "vfc,occlusion;vfc,occlusion,tbfc"] [--check 0]
        [--worlds w2,w7]

Prints one markdown row per world and stages: frames, triangles sent summed with and without
moving occluders and their ratio, the moving and static triangles among them, moving occluders
rasterised a frame (median), ms medians and their ratio, dropped (on the checked frames).
"""
from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tools"))

from bench_dynamic import frames_of  # noqa: E402
from vismobile.culling import BACKFACE_STAGES, Culler, parse_stages  # noqa: E402
from vismobile.device.profile import get_profile  # noqa: E402
from vismobile.partition import partition  # noqa: E402
from vismobile.render import SENTINEL, item_buffer  # noqa: E402
from vismobile.scenes import build_world  # noqa: E402
from vismobile.scenes.animated import animated_instances  # noqa: E402
from vismobile.scenes.thesis import write_motion  # noqa: E402
from vismobile.world.animated import AnimatedWorld  # noqa: E402
from vismobile.world.trajectory import Trajectory  # noqa: E402

PROFILE = get_profile("ipaq-hx2490b")
FPS = 30.0


def scenes(names, instances, frames, step, folder) -> list:
    """(label, animated partition, [(camera, t)]) per world."""
    out = []
    if "w2" in names:
        animated = animated_instances(build_world("w2"), instances, seed=1)
        out.append((f"W2 + {instances:,} instances, octree:5", partition(animated, "octree:5"),
                    frames_of(frames)))
    if "w7" in names:
        path = folder / "w7_scheduled.json"
        write_motion("w7", path, doors="scheduled")
        animated = AnimatedWorld.from_motion_file(build_world("w7"), path)
        trajectory = Trajectory.load(ROOT / "trajectories" / "hybrid.csv")
        shots = [(trajectory.camera(f, PROFILE.aspect), f / FPS)
                 for f in range(0, len(trajectory), step)]
        out.append(("W7 path, portal:2", partition(animated, "portal", depth=2), shots))
    return out


def run(part, shots, stages, check) -> dict:
    on, off = Culler(part, stages), Culler(part, stages)
    for stage in off.stages:
        if stage.name == "occlusion":
            stage.extra_occluders = None
    for camera, t in shots[:5]:  # warm-up: numba's compiles
        on.cull(camera, time=t)
        off.cull(camera, time=t)
    moving_mask = part.animated.moving_mask
    rows = {"sent": [0, 0], "moving": [0, 0], "ms": ([], []), "occluders": [], "dropped": 0,
            "checked": 0}
    back = bool(set(BACKFACE_STAGES) & set(parse_stages(stages)))
    for k, (camera, t) in enumerate(shots):
        pair = (on, off) if k % 2 else (off, on)  # alternate which goes first
        results = {}
        for culler in pair:
            start = time.perf_counter_ns()
            results[culler is on] = culler.cull(camera, time=t)
            rows["ms"][culler is off].append((time.perf_counter_ns() - start) / 1e6)
        for i, result in enumerate((results[True], results[False])):
            rows["sent"][i] += len(result.triangles)
            rows["moving"][i] += int(moving_mask[result.triangles].sum())
        rows["occluders"].append(results[True].stats.get("occlusion.moving_occluders", 0))
        if check and k % check == 0:
            ids = np.unique(item_buffer(part.animated.posed(t), None, camera, PROFILE,
                                        cull_back=back))
            truth = ids[ids != SENTINEL]
            rows["dropped"] += len(np.setdiff1d(truth, results[True].triangles))
            rows["checked"] += 1
    return rows


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--instances", type=int, default=1000)
    parser.add_argument("--frames", type=int, default=120)
    parser.add_argument("--step", type=int, default=10)
    parser.add_argument("--stages", default="vfc,occlusion;vfc,occlusion,tbfc")
    parser.add_argument("--check", type=int, default=0, help="check drops every K-th frame")
    parser.add_argument("--worlds", default="w2,w7")
    args = parser.parse_args(argv)
    print("| world | stages | frames | sent with / without moving occluders | ratio | moving "
          "sent with / without | static sent with / without | moving occluders a frame | ms "
          "with / without | ms ratio | dropped (frames checked) |")
    print("|" + " --- |" * 11)
    with tempfile.TemporaryDirectory() as folder:
        for label, part, shots in scenes(args.worlds.split(","), args.instances, args.frames,
                                         args.step, Path(folder)):
            for stages in args.stages.split(";"):
                r = run(part, shots, stages, args.check)
                (s1, s0), (m1, m0) = r["sent"], r["moving"]
                ms1, ms0 = np.median(r["ms"][0]), np.median(r["ms"][1])
                print(f"| {label} | `{stages}` | {len(shots)} | {s1:,} / {s0:,} | "
                      f"{s1 / s0:.3f}x | {m1:,} / {m0:,} | {s1 - m1:,} / {s0 - m0:,} | "
                      f"{np.median(r['occluders']):.0f} | {ms1:.2f} / {ms0:.2f} | "
                      f"{ms1 / ms0:.2f}x | {r['dropped']} ({r['checked']}) |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())

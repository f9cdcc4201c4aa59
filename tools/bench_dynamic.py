"""Dynamic-structure benchmark (issue 25): W2 with N moving instances of the shipped models
(each at most 1,000 triangles: decimated, shared), the frame's dynamic update plus `vfc`
(Culler.cull(camera, time=t) over the AnimatedPartition: matrices, boxes, BVH refit or rebuild,
the BVH frustum walk, the static octree's vfc, the merge) against the static `vfc` on plain W2,
interleaved frame by frame in one process along W2's path (t = frame / 30; four runs of consecutive frames).

    .venv/bin/python tools/bench_dynamic.py [--instances 1000,10000] [--frames 120]
        [--structure octree:5] [--rounds 3] [--stages vfc] [--out runs/bench_dynamic.md]

Prints a markdown table: per N the median ms of the static vfc, of "update + vfc" (the static
vfc plus the dynamic half's decisions: pose, refit, BVH frustum walk, the objects to draw) and of
the full cull (also listing every moving triangle id drawn and merging them with the static
ones), their ratios to the static vfc (of the medians, and the median per-frame ratio), posing
every object (what a frame would cost without the swept boxes), the candidates (swept boxes
in the frustum), moving objects in the frustum, BVH nodes visited, objects swept anew per frame
and BVH rebuilds (hardware-independent). Numba's first compiles are
warmed up before anything is timed.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from vismobile.culling import Culler  # noqa: E402
from vismobile.partition import partition  # noqa: E402
from vismobile.scenes import build_world  # noqa: E402
from vismobile.scenes.animated import animated_instances  # noqa: E402
from vismobile.world.trajectory import Trajectory  # noqa: E402

FPS = 30.0


def frames_of(count: int, segments: int = 4) -> list:
    """(camera, t) of `count` frames of W2's indoor path: `segments` runs of consecutive frames
    (a played path: the objects move 1/30 s between frames) starting at evenly spaced frames."""
    trajectory = Trajectory.load(ROOT / "trajectories" / "indoor.csv")
    run = max(count // segments, 1)
    starts = np.linspace(0, len(trajectory) - run, segments).round().astype(int)
    picks = [int(s) + k for s in starts for k in range(run)]
    return [(trajectory.camera(f), f / FPS) for f in picks]


def timed(function) -> float:
    start = time.perf_counter_ns()
    function()
    return (time.perf_counter_ns() - start) / 1e6


def update_and_walk(moving, planes, t, tol) -> int:
    """The dynamic half's decisions alone: pose (sweeps and refits when intervals end), the
    BVH frustum walk, the candidates posed and tested: the objects to draw, not their ids.
    planes: the frame's, which the Culler computes once for both halves (the static vfc timed
    beside it computes them)."""
    moving.pose(t)
    return len(moving.in_frustum(planes, tol)[0])


def bench(static, dynamic, frames, rounds) -> dict:
    """Interleaved per-frame times (ms), the order turning per frame and round: static vfc,
    the full dynamic cull, and static vfc + the dynamic half's decisions (update_and_walk)."""
    s_ms, d_ms, u_ms, parts = [], [], [], []
    moving = dynamic.moving
    tol = float(dynamic.tree.tol)
    for r in range(rounds):
        for k, (camera, t) in enumerate(frames):
            planes = np.ascontiguousarray(camera.frustum_planes())
            runs = {"s": lambda: static.cull(camera), "d": lambda: dynamic.cull(camera, time=t),
                    "u": lambda: (static.cull(camera), update_and_walk(moving, planes, t, tol))}
            order = "sdu"[(r + k) % 3:] + "sdu"[:(r + k) % 3]
            got = {key: timed(runs[key]) for key in order}
            s_ms.append(got["s"])
            d_ms.append(got["d"])
            u_ms.append(got["u"])
    stats = {"objects_in_frustum": [], "nodes": [], "rebuilds": 0, "sent": [], "swept": 0,
             "candidates": []}
    for camera, t in frames:  # untimed: the counters, and the dynamic half alone
        result = dynamic.cull(camera, time=t)
        stats["objects_in_frustum"].append(result.stats.get("moving.objects_sent", 0))
        stats["nodes"].append(result.stats.get("moving.nodes_visited", 0))
        stats["rebuilds"] += result.stats.get("moving.rebuilds", 0)
        stats["swept"] += result.stats.get("moving.swept", 0)
        stats["candidates"].append(result.stats.get("moving.candidates", 0))
        stats["sent"].append(result.stats["triangles_sent"])
    for camera, t in frames:
        parts.append(timed(lambda: (moving.pose(t), moving._exact(moving._all))))
    s, d, u = np.array(s_ms), np.array(d_ms), np.array(u_ms)
    return {"static": float(np.median(s)), "dynamic": float(np.median(d)),
            "ratio": float(np.median(d) / np.median(s)), "frame_ratio": float(np.median(d / s)),
            "update": float(np.median(u)), "update_ratio": float(np.median(u) / np.median(s)),
            "update_p95": float(np.percentile(u, 95)),
            "pose": float(np.median(parts)),
            "in_frustum": float(np.median(stats["objects_in_frustum"])),
            "nodes": float(np.median(stats["nodes"])), "rebuilds": stats["rebuilds"],
            "swept": stats["swept"] / len(frames),
            "candidates": float(np.median(stats["candidates"])),
            "sent": float(np.median(stats["sent"]))}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--instances", default="1000,10000")
    parser.add_argument("--frames", type=int, default=120)
    parser.add_argument("--structure", default="octree:5")
    parser.add_argument("--stages", default="vfc")
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--out", default=None)
    args = parser.parse_args(argv)
    w2 = build_world("w2")
    static = Culler(partition(w2, args.structure), args.stages)
    frames = frames_of(args.frames)
    rows = []
    for n in [int(v) for v in args.instances.split(",")]:
        start = time.perf_counter()
        animated = animated_instances(w2, n, seed=1)
        made = time.perf_counter() - start
        start = time.perf_counter()
        dynamic = Culler(partition(animated, args.structure), args.stages)
        built = time.perf_counter() - start
        for camera, t in frames[:10]:  # warm-up: numba's compiles, caches
            static.cull(camera)
            dynamic.cull(camera, time=t)
        result = bench(static, dynamic, frames, args.rounds)
        moving = int(animated.moving_mask.sum())
        rows.append((n, moving, made, built, result))
        print(f"N={n}: {result}", file=sys.stderr)
    lines = [f"W2 ({w2.triangle_count:,} triangles), {args.structure}, `{args.stages}`, "
             f"{args.frames} frames of the indoor path x {args.rounds} rounds, interleaved",
             "",
             "| instances | moving triangles | static vfc ms | update + vfc ms | p95 | ratio "
             "| full cull ms | ratio of medians | per-frame ratio | posing all ms | candidates "
             "| objects in frustum | BVH nodes visited | swept a frame | rebuilds | sent | world s "
             "| partition + culler s |",
             "|" + " --- |" * 18]
    for n, moving, made, built, r in rows:
        lines.append(f"| {n:,} | {moving:,} | {r['static']:.3f} | {r['update']:.3f} | "
                     f"{r['update_p95']:.3f} | "
                     f"{r['update_ratio']:.2f}x | {r['dynamic']:.3f} | "
                     f"{r['ratio']:.2f}x | {r['frame_ratio']:.2f}x | {r['pose']:.3f} | "
                     f"{r['candidates']:.0f} | {r['in_frustum']:.0f} | {r['nodes']:.0f} | "
                     f"{r['swept']:.1f} | {r['rebuilds']} | "
                     f"{r['sent']:,.0f} | {made:.1f} | {built:.1f} |")
    text = "\n".join(lines)
    print(text)
    if args.out:
        Path(args.out).parent.mkdir(parents=True, exist_ok=True)
        Path(args.out).write_text(text + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())

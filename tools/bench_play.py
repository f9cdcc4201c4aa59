"""Benchmark: a thesis world played along its trajectory at the iPaq profile, end to end.

Usage: .venv/bin/python tools/bench_play.py [--world w1] [--trajectory trajectories/indoor.csv]
       [--structure octree:4] [--cull vfc,bfc,cbfc [--cull ...]] [--profile ipaq-hx2490b]
       [--out runs/bench_play] [--fixed-check]

Prints the wall time of the whole run (world build + partition + playback), and from
summary.json the mean/median/p95 ms per frame, fps, triangles sent and the Pearson
correlation, for each --cull given; then the same path with no culling and no partition in this
process (render-all), as the baseline the thesis compares against ("culling saved N%"), and
each configuration's mean frame time as a speed-up over it. The frame-time view: per
configuration the median frame split into cull, upload (index data built and written) and draw
(clear, draws, glFinish), and the cull's median when interleaved with rendering (the played
frames) against the same cameras culled back to back by a fresh culler in this process.
--llvmpipe-threads (default 0) sets Mesa's LP_NUM_THREADS for this process, before the GL
context exists: 0 draws in the calling thread, as the device's one core does; "mesa" keeps
Mesa's worker threads, which sleep during the cull and cost about 2.3 ms to wake for a frame's
draw on this loaded 2-core machine, whatever it draws (docs/culling-performance.md).
--fixed-check renders waypoint
item buffers of all six worlds in fixed16.16 and float32 and reports how many pixels agree
(or the ProfileError a world raises).
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from vismobile.errors import ProfileError  # noqa: E402
from vismobile.app.playback import load_scene, make_culler, play  # noqa: E402
from vismobile.culling import parse_stages  # noqa: E402
from vismobile.device.profile import get_profile  # noqa: E402
from vismobile.world.trajectory import Trajectory  # noqa: E402

INDOOR = {"w1", "w2", "w3", "w4"}


def run(world, trajectory, structure, cull, profile, out):
    start = time.perf_counter()
    scene = load_scene(world, structure)
    built = time.perf_counter() - start
    result = play(scene, trajectory, cull, profile, out, progress=True)
    wall = time.perf_counter() - start
    result.summary["back_to_back_cull_ms"] = back_to_back(scene, trajectory, cull, profile)
    return wall, built, result.summary


def back_to_back(scene, trajectory, cull, profile) -> float:
    """Median ms of the same cameras culled back to back (no render between) by a fresh
    culler, after an untimed warm-up on three of them; nan without culling."""
    if scene.partition is None:
        return float("nan")
    culler = make_culler(scene, parse_stages(cull), profile)
    cameras = [trajectory.camera(f, profile.aspect) for f in range(len(trajectory))]
    for camera in cameras[:3]:
        culler.cull(camera)
    times = np.empty(len(cameras))
    for k, camera in enumerate(cameras):
        start = time.perf_counter()
        culler.cull(camera)
        times[k] = time.perf_counter() - start
    return float(np.median(times) * 1000.0)


def split(label, s) -> str:
    """The frame-time view of one run: median cull, upload and draw, and the cull's cost
    interleaved with rendering against back to back."""
    cull, upload, draw = (s[k]["median"] for k in ("cull_ms", "upload_ms", "draw_ms"))
    b2b = s.get("back_to_back_cull_ms", float("nan"))
    ratio = cull / b2b if b2b == b2b and b2b > 0 else float("nan")
    return (f"{label:<28} frame split (medians): cull {cull:6.3f} + upload {upload:6.3f} + "
            f"draw {draw:6.3f} ms; cull back to back {b2b:6.3f} ms, interleaved / back to back "
            f"{ratio:4.2f}x")


def line(label, wall, built, s):
    r = s["pearson_frame_ms_triangles"]
    return (f"{label:<28} wall {wall:6.1f} s (build {built:4.1f} s)  frame ms mean "
            f"{s['frame_ms']['mean']:6.2f} median {s['frame_ms']['median']:6.2f} p95 "
            f"{s['frame_ms']['p95']:6.2f}  cull {s['cull_ms']['median']:5.2f}  render "
            f"{s['render_ms']['median']:5.2f}  fps {s['fps']:6.1f}  triangles "
            f"{s['triangles_sent']['mean']:8,.0f}  batches {s['draw_batches']['mean']:.1f}  "
            f"r {'n/a' if r is None else f'{r:+.2f}'}")


def fixed_check(profile_name):
    from vismobile.render import item_buffer
    from vismobile.scenes import build_world

    float_profile = get_profile(profile_name, "float32")
    fixed_profile = get_profile(profile_name, "fixed16.16")
    for name in ("w1", "w2", "w3", "w4", "w5", "w6"):
        world = build_world(name)
        path = ROOT / "trajectories" / ("indoor.csv" if name in INDOOR else "outdoor.csv")
        trajectory = Trajectory.load(path)
        largest = float(np.abs(world.extent).max())
        try:
            differ, pixels = 0, 0
            for frame in sorted(trajectory.waypoints.values()):
                camera = trajectory.camera(frame, float_profile.aspect)
                a = item_buffer(world, None, camera, float_profile, cull_back=True)
                b = item_buffer(world, None, camera, fixed_profile, cull_back=True)
                differ, pixels = differ + int((a != b).sum()), pixels + a.size
            print(f"fixed16.16 {name}: {world.triangle_count:,} triangles, largest |coordinate| "
                  f"{largest:,.1f}: item buffer differs from float32 on {differ} of {pixels:,} "
                  f"pixels over {len(trajectory.waypoints)} waypoints")
        except ProfileError as error:
            print(f"fixed16.16 {name}: refused: {error}")
    moved = build_world("w5").transformed(1.0, (40_000.0, 0.0, 0.0))
    try:
        item_buffer(moved, None, Trajectory.load(ROOT / "trajectories/outdoor.csv").camera(0),
                    fixed_profile)
        print("fixed16.16 w5 moved by 40,000: NOT refused")
    except ProfileError as error:
        print(f"fixed16.16 w5 moved by 40,000: refused: {error}")


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--world", default="w1")
    parser.add_argument("--trajectory", type=Path, default=ROOT / "trajectories" / "indoor.csv")
    parser.add_argument("--structure", default="octree:4")
    parser.add_argument("--cull", action="append", default=None,
                        help="stages; repeat to compare several (default vfc,bfc,cbfc)")
    parser.add_argument("--profile", default="ipaq-hx2490b")
    parser.add_argument("--out", type=Path, default=ROOT / "runs" / "bench_play")
    parser.add_argument("--no-baseline", action="store_true")
    parser.add_argument("--fixed-check", action="store_true")
    parser.add_argument("--llvmpipe-threads", default="0",
                        choices=["mesa"] + [str(n) for n in range(17)],
                        help="Mesa's LP_NUM_THREADS: 0 (default) draws in the calling thread; "
                             "mesa keeps Mesa's default worker threads")
    args = parser.parse_args(argv)
    if args.llvmpipe_threads == "mesa":
        os.environ.pop("LP_NUM_THREADS", None)
    else:  # read by Mesa when the GL context is made (the first draw below)
        os.environ["LP_NUM_THREADS"] = args.llvmpipe_threads
    print(f"llvmpipe threads: {os.environ.get('LP_NUM_THREADS', 'Mesa default')}")

    trajectory = Trajectory.load(args.trajectory)
    profile = get_profile(args.profile)
    report = {}
    culls = args.cull or ["vfc,bfc,cbfc"]
    runs = []
    for cull in culls:
        wall, built, summary = run(args.world, trajectory, args.structure, cull, profile,
                                   args.out / ("culled" if len(culls) == 1 else
                                               "culled_" + cull.replace(",", "+")))
        print(line(f"{args.world} {args.structure} {cull}", wall, built, summary))
        print(split(f"{args.world} {args.structure} {cull}", summary))
        report["culled" if len(culls) == 1 else f"culled {cull}"] = {
            "wall_s": wall, "build_s": built, **summary}
        runs.append((cull, summary))
    if not args.no_baseline:
        wall0, built0, base = run(args.world, trajectory, "none", "none", profile,
                                  args.out / "none")
        print(line(f"{args.world} none (baseline)", wall0, built0, base))
        print(split(f"{args.world} none (baseline)", base))
        report["baseline"] = {"wall_s": wall0, "build_s": built0, **base}
        for cull, summary in runs:
            saved = 1 - summary["frame_ms"]["mean"] / base["frame_ms"]["mean"]
            sent = summary["triangles_sent"]["mean"] / base["triangles_sent"]["mean"]
            speed = base["frame_ms"]["mean"] / summary["frame_ms"]["mean"]
            print(f"{cull}: culling saved {100 * saved:.0f}% of the mean frame time "
                  f"({speed:.2f}x render-all); sends {100 * sent:.1f}% of the triangles")
            report.setdefault("speedup", {})[cull] = speed
            if len(runs) == 1:
                report["saved_fraction"] = saved
    print(f"end to end: {wall:.1f} s for {summary['frames']} frames at "
          f"{profile.width}x{profile.height} ({'under' if wall < 120 else 'OVER'} 2 minutes)")
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "bench.json").write_text(json.dumps(report, indent=2, sort_keys=True) + "\n")
    if args.fixed_check:
        fixed_check(args.profile)


if __name__ == "__main__":
    main()

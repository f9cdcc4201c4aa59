"""Out-of-core octree at scale: build a world directory's octree streamed (chunks on --jobs
processes, external sort), then cull along a path with the .vmp memory-mapped; wall times and
peak resident memory (RSS) of each phase.

Usage: nice -n 19 .venv/bin/python tools/bench_outofcore.py --world out/big20m
       [--depth 5] [--jobs 2] [--chunk 524288] [--frames 60] [--out out/big20m.vmp]
       [--skip-build] [--cull vfc vfc,tbfc vfc,cbfc vfc,cone] [--results DIR]
       [--occlusion candidates=8,occluders=512,rounds=3]
Make the world first with tools/make_big_world.py. The build's peak RSS is reported for this
process and for the largest worker; each --cull stage list runs in a fresh process
(`--cull-only`) so its peak RSS and its prepare time (Culler set-up: the stages' per-triangle
and per-node tables) are its own. Cameras: the W2 indoor path moved to the centre tile,
--frames evenly spaced frames, profile iPaq (FOV 45, far plane 1000, 240 x 320). Each run's
figures are also written to DIR/<vmp name>.cull.<stages>[.<options>].json (default DIR: beside
the .vmp). --occlusion passes options to the occlusion stage (DepthBufferOcclusion's keywords).

Occlusion on the mapped 20 M world (docs/scale.md, "Occlusion on the mapped world"): it keeps
nothing per triangle; its node lists are read from the file (stored by the out-of-core build,
8 a node) or, for older files, computed at prepare in one pass over the references; its frames
follow what is seen. The octree must be deep enough for its leaves to offer room-sized
occluders (depth 7 for the 616 m world: `vismobile partition DIR --depth 7 --jobs 2`, or
--depth 7 here). Measured there: --occlusion candidates=8,occluders=512,rounds=3 5.0 ms CPU a
frame, 42,712 sent (vfc 7.3 ms, 1.93 M), peak RSS 1.76 GB.
"""
from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tools"))

from vismobile.world.mapped import MappedWorld  # noqa: E402
from vismobile.partition.external import CHUNK, build_octree_file  # noqa: E402


def peak_mb(who=resource.RUSAGE_SELF) -> float:
    return resource.getrusage(who).ru_maxrss / 1024.0


def cpu_s() -> float:
    """User + system CPU seconds of this process and its finished children: on a shared
    machine this, not the wall time, is what the work cost."""
    return sum(r.ru_utime + r.ru_stime for r in (resource.getrusage(resource.RUSAGE_SELF),
                                                 resource.getrusage(resource.RUSAGE_CHILDREN)))


def build(args) -> dict:
    world = MappedWorld.open(args.world)
    start, cpu = time.perf_counter(), cpu_s()
    stats = build_octree_file(world, args.out, depth=args.depth, chunk=args.chunk, jobs=args.jobs)
    stats.update({"triangles": world.triangle_count, "wall_s": time.perf_counter() - start,
                  "cpu_s": cpu_s() - cpu, "load": os.getloadavg()[0],
                  "peak_rss_mb": peak_mb(), "worker_peak_rss_mb": peak_mb(resource.RUSAGE_CHILDREN)})
    return stats


def cull(args) -> dict:
    from make_big_world import layout, tile_offset

    from vismobile.culling import Culler
    from vismobile.partition.store import map_partition
    from vismobile.device.profile import get_profile
    from vismobile.world.trajectory import Trajectory

    import_rss_mb = peak_mb()  # the interpreter and its imports, before anything is mapped
    start = time.perf_counter()
    partition = map_partition(args.out)
    map_s = time.perf_counter() - start
    tiles = json.loads((Path(args.world) / "world.json").read_text())["name"]
    tiles = int(tiles[3:]) if tiles.startswith("big") else 1
    columns = int(np.ceil(np.sqrt(tiles)))
    centre = tile_offset((columns // 2) * columns + columns // 2 if tiles > 1 else 0, columns)
    track = Trajectory.load(ROOT / "trajectories" / "indoor.csv")
    poses = track.poses.copy()
    poses[:, :3] += centre
    track = Trajectory(poses, track.waypoints)
    aspect = get_profile("ipaq-hx2490b").aspect
    frames = np.linspace(0, len(track) - 1, args.frames).round().astype(int)
    start, cpu0 = time.perf_counter(), time.process_time()
    culler = Culler(partition, args.cull[0], **stage_options(args))
    setup_s, setup_cpu_s = time.perf_counter() - start, time.process_time() - cpu0
    setup_rss_mb = peak_mb()
    times, cpu, sent = [], [], []
    keys = ("occlusion.pixels_covered", "occlusion.occluders", "occlusion.candidates",
            "occlusion.candidate_nodes", "nodes_visited", "triangles_tested")
    stats = {k: [] for k in keys}
    for f in frames:
        camera = track.camera(int(f), aspect)
        t0, c0 = time.perf_counter(), time.process_time()
        result = culler.cull(camera)
        times.append((time.perf_counter() - t0) * 1e3)
        cpu.append((time.process_time() - c0) * 1e3)
        sent.append(len(result.triangles))
        for k in keys:
            stats[k].append(result.stats.get(k, 0))
    occlusion = [s for s in culler.stages if s.name == "occlusion"]
    counters = {}
    if occlusion:  # node passes' work and the buffer's coverage, means over the frames
        counters = {k: float(np.mean(v)) for k, v in stats.items()}
    return {"stages": args.cull[0], "options": args.occlusion, **counters,
            "import_rss_mb": import_rss_mb, "map_s": map_s,
            "culler_setup_s": setup_s, "culler_setup_cpu_s": setup_cpu_s,
            "setup_peak_rss_mb": setup_rss_mb, "first_frame_ms": times[0],
            "median_ms": statistics.median(times[1:] or times), "max_ms": max(times),
            "median_cpu_ms": statistics.median(cpu[1:] or cpu), "load": os.getloadavg()[0],
            "mean_sent": float(np.mean(sent)), "max_sent": int(max(sent)),
            "frames": len(frames), "peak_rss_mb": peak_mb()}


def stage_options(args) -> dict:
    """Culler keyword options from --occlusion "key=value,..." (values read as JSON: numbers,
    true/false, null), e.g. {"occlusion": {"candidates": 8}}; {} when not given."""
    if not args.occlusion:
        return {}
    options = {}
    for item in args.occlusion.split(","):
        key, _, value = item.partition("=")
        try:
            options[key.strip()] = json.loads(value)
        except ValueError:
            raise ValueError(f"--occlusion: {item!r} is not key=value with a JSON value") from None
    return {"occlusion": options}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--world", type=Path, default=ROOT / "out" / "big20m")
    parser.add_argument("--out", type=Path, default=None)
    parser.add_argument("--depth", type=int, default=5)
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--chunk", type=int, default=CHUNK)
    parser.add_argument("--frames", type=int, default=60)
    parser.add_argument("--skip-build", action="store_true")
    parser.add_argument("--cull", nargs="+", default=["vfc"], metavar="STAGES",
                        help="stage lists to cull with, one fresh process each (vfc vfc,tbfc ...)")
    parser.add_argument("--results", type=Path, default=None,
                        help="folder for the per-run JSON (default: beside the .vmp)")
    parser.add_argument("--occlusion", default="", metavar="KEY=VALUE,...",
                        help="occlusion stage options, e.g. candidates=8,occluders=512,rounds=3")
    parser.add_argument("--cull-only", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    args.out = args.out or args.world.with_suffix(".vmp")
    from vismobile.culling import parse_stages

    try:
        for stages in args.cull:
            parse_stages(stages)
        stage_options(args)
    except ValueError as error:
        print(f"bench_outofcore: {error}", file=sys.stderr)
        return 2
    results = args.results or args.out.parent
    results.mkdir(parents=True, exist_ok=True)  # a --results folder may not exist yet
    if args.cull_only:
        text = json.dumps(cull(args))
        label = args.cull[0].replace(",", "+")
        if args.occlusion:
            label += "." + args.occlusion.replace("=", "").replace(",", "_")
        (results / f"{args.out.stem}.cull.{label}.json").write_text(text + "\n")
        print(text)
        return 0
    if not args.skip_build:
        stats = build(args)
        print(f"build: {stats['triangles']:,} triangles, octree {args.depth}, {args.jobs} jobs: "
              f"{stats['wall_s']:.1f} s wall, {stats['cpu_s']:.1f} s CPU (load "
          f"{stats['load']:.1f}), {stats['nodes']:,} nodes, {stats['references']:,} refs, "
              f"{stats['bytes'] / 2**20:.0f} MB file; peak RSS {stats['peak_rss_mb']:.0f} MB "
              f"(largest worker {stats['worker_peak_rss_mb']:.0f} MB)")
        print("  phases: " + ", ".join(f"{k} {v:.1f} s" for k, v in stats["seconds"].items()))
    for stages in args.cull:
        command = [sys.executable, __file__, "--cull-only", "--world", str(args.world), "--out",
                   str(args.out), "--frames", str(args.frames), "--cull", stages,
                   "--results", str(results), "--occlusion", args.occlusion]
        result = json.loads(subprocess.run(command, check=True, capture_output=True,
                                           text=True).stdout.splitlines()[-1])
        print(f"cull ({stages}, mapped): RSS after imports {result['import_rss_mb']:.0f} MB, "
              f"map + verify {result['map_s']:.1f} s, culler set-up "
              f"{result['culler_setup_s']:.2f} s ({result['culler_setup_cpu_s']:.2f} s CPU, peak "
              f"RSS after it {result['setup_peak_rss_mb']:.0f} MB), first frame "
              f"{result['first_frame_ms']:.1f} ms, median {result['median_ms']:.2f} ms, max "
              f"{result['max_ms']:.1f} ms over {result['frames']} frames (median CPU "
              f"{result['median_cpu_ms']:.2f} ms, load {result['load']:.1f}); mean sent "
              f"{result['mean_sent']:,.0f} (max {result['max_sent']:,}); peak RSS "
              f"{result['peak_rss_mb']:.0f} MB", flush=True)
        if "occlusion.pixels_covered" in result:
            print("  occlusion, means a frame: " + ", ".join(
                f"{k.split('.')[-1]} {v:,.0f}" for k, v in result.items()
                if k in ("occlusion.pixels_covered", "occlusion.occluders",
                         "occlusion.candidate_nodes", "nodes_visited", "triangles_tested")),
                flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())

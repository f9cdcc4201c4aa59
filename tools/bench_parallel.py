"""Parallel octree build: speed-up of the chunked build (partition/external.py) on 1 and N
worker processes, its serial fraction by phase, and an Amdahl projection for 64 cores.

Usage: nice -n 19 .venv/bin/python tools/bench_parallel.py --world out/big2m [--depth 5]
       [--jobs 2] [--runs 3] [--chunk 262144] [--in-memory]
Make the world with tools/make_big_world.py --triangles 2000000 --out out/big2m. Prints the
median wall and CPU time per job count (the files are checked byte-identical), the phases,
and S(n) = T1 / (serial + parallel / n) from the CPU seconds of each phase at 1 job: on a
shared machine wall-time ratios follow the other processes' load, CPU seconds do not.
--in-memory also times octree.build on the loaded world (the serial in-memory baseline).
"""
from __future__ import annotations

import argparse
import os
import resource
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from vismobile.world.mapped import MappedWorld  # noqa: E402
from vismobile.partition.external import build_octree_file  # noqa: E402

PARALLEL_PHASES = ("extent", "chunks", "scatter")


def cpu_s() -> float:
    """CPU seconds of this process and its reaped children (the workers of finished builds)."""
    return sum(r.ru_utime + r.ru_stime for r in (resource.getrusage(resource.RUSAGE_SELF),
                                                 resource.getrusage(resource.RUSAGE_CHILDREN)))


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--world", type=Path, required=True)
    parser.add_argument("--depth", type=int, default=5)
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--chunk", type=int, default=1 << 18)
    parser.add_argument("--in-memory", action="store_true")
    args = parser.parse_args(argv)
    world = MappedWorld.open(args.world)
    rows = {}
    (ROOT / "out").mkdir(exist_ok=True)
    with tempfile.TemporaryDirectory(dir=ROOT / "out") as tmp:
        files = {}
        for jobs in (1, args.jobs):
            runs = []
            for run in range(args.runs):
                out = Path(tmp) / f"j{jobs}.vmp"
                start, cpu = time.perf_counter(), cpu_s()
                stats = build_octree_file(world, out, args.depth, args.chunk, jobs)
                runs.append((time.perf_counter() - start, cpu_s() - cpu, stats))
            files[jobs] = out.read_bytes()
            runs.sort(key=lambda r: r[0])
            rows[jobs] = runs[len(runs) // 2]
        same = files[1] == files[args.jobs]
    wall1, cpu1, stats1 = rows[1]
    walln, cpun, _ = rows[args.jobs]
    # At 1 job every phase runs in this process: its CPU seconds split the work exactly.
    phase_cpu = stats1["cpu_seconds"]
    parallel = sum(phase_cpu[p] for p in PARALLEL_PHASES)
    serial = sum(phase_cpu.values()) - parallel
    overhead = cpun - cpu1  # spawning workers, shipping tasks: CPU the parallel run adds
    print(f"{world.triangle_count:,} triangles, octree {args.depth}, {stats1['chunks']} chunks "
          f"of {args.chunk:,}, {stats1['references']:,} refs; median of {args.runs}; load "
          f"average {os.getloadavg()[0]:.1f}; files byte-identical: {same}")
    for jobs, (wall, cpu, stats) in rows.items():
        print(f"  {jobs} job(s): {wall:.2f} s wall, {cpu:.2f} s CPU (all processes); phases "
              "(wall s): " + ", ".join(f"{k} {v:.2f}" for k, v in stats["seconds"].items()))
    print(f"  measured wall speed-up on {args.jobs} jobs: {wall1 / walln:.2f}x")
    print(f"  CPU at 1 job: serial phases {serial:.2f} s, parallel phases {parallel:.2f} s "
          f"(serial fraction {serial / (serial + parallel):.1%}); {args.jobs} jobs add "
          f"{overhead:.2f} s CPU")
    for n in (args.jobs, 64):
        ideal = (serial + parallel) / (serial + parallel / n)
        with_overhead = (serial + parallel) / (serial + (parallel + overhead) / n)
        print(f"  Amdahl from CPU seconds, {n} dedicated cores: {ideal:.2f}x "
              f"({with_overhead:.2f}x counting the workers' start-up)")
    if args.in_memory:
        from vismobile.partition import octree

        loaded = world.load()
        start = time.perf_counter()
        octree.build(loaded, args.depth)
        print(f"  in-memory octree.build (serial baseline): {time.perf_counter() - start:.2f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())

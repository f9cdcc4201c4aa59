"""Parallel octree build: speed-up of the chunked build (partition/external.py) on 1 and N
worker processes, its serial fraction by phase, and an Amdahl projection for 64 cores.

Usage: nice -n 19 .venv/bin/python tools/bench_parallel.py --world out/big2m [--depth 5]
       [--jobs 2] [--runs 3] [--chunk 262144] [--in-memory]
Make the world with tools/make_big_world.py --triangles 2000000 --out out/big2m. Prints the
median wall time per job count (the files are checked byte-identical), the phases, and
S(n) = T1 / (serial + parallel / n) with the serial and parallel seconds measured at 1 job.
--in-memory also times octree.build on the loaded world (the serial in-memory baseline).
"""
from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from vismobile.mapped import MappedWorld  # noqa: E402
from vismobile.partition.external import build_octree_file  # noqa: E402

PARALLEL_PHASES = ("extent", "chunks", "scatter")


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
            times, phases = [], []
            for run in range(args.runs):
                out = Path(tmp) / f"j{jobs}.vmp"
                start = time.perf_counter()
                stats = build_octree_file(world, out, args.depth, args.chunk, jobs)
                times.append(time.perf_counter() - start)
                phases.append(stats["seconds"])
            files[jobs] = out.read_bytes()
            best = phases[times.index(statistics.median(times))] if args.runs % 2 else phases[0]
            rows[jobs] = (statistics.median(times), best, stats)
        same = files[1] == files[args.jobs]
    t1, phases1, stats = rows[1]
    tn = rows[args.jobs][0]
    parallel = sum(phases1[p] for p in PARALLEL_PHASES)
    serial = t1 - parallel
    print(f"{world.triangle_count:,} triangles, octree {args.depth}, {stats['chunks']} chunks of "
          f"{args.chunk:,}, {stats['references']:,} refs; median of {args.runs}")
    for jobs, (t, ph, _) in rows.items():
        print(f"  {jobs} job(s): {t:.2f} s  (" + ", ".join(f"{k} {v:.2f}" for k, v in ph.items())
              + ")")
    print(f"  speed-up on {args.jobs} jobs: {t1 / tn:.2f}x; files byte-identical: {same}")
    print(f"  serial part at 1 job: {serial:.2f} s of {t1:.2f} s ({serial / t1:.1%}); "
          f"Amdahl: {args.jobs} cores {t1 / (serial + parallel / args.jobs):.2f}x, "
          f"64 cores {t1 / (serial + parallel / 64):.1f}x")
    if args.in_memory:
        from vismobile.partition import octree

        loaded = world.load()
        start = time.perf_counter()
        octree.build(loaded, args.depth)
        print(f"  in-memory octree.build (serial baseline): {time.perf_counter() - start:.2f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())

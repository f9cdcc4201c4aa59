"""The comparison sweep on one process, a local pool and a Dask LocalCluster: wall times.

Usage: nice -n 19 .venv/bin/python tools/bench_sweep.py [--worlds w1,w5]
       [--structures octree:3,bsp] [--cull thesis] [--frames sample:8] [--workers 2]
Partitions and ground truths are prepared (cached) first, so each mode times the runs alone;
each mode writes to its own results folder. The Dask row counts the cluster's start-up
separately. Prints the wall seconds and each mode's ratio to the single process.
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

from vismobile.study import distributed  # noqa: E402
from vismobile.study.matrix import expand  # noqa: E402
from vismobile.study.runner import Context, prepare, run_matrix  # noqa: E402


def cpu_s() -> float:
    """CPU seconds of this process and its reaped children (pool workers, Dask nannies and
    their workers once the cluster is closed)."""
    return sum(r.ru_utime + r.ru_stime for r in (resource.getrusage(resource.RUSAGE_SELF),
                                                 resource.getrusage(resource.RUSAGE_CHILDREN)))


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--worlds", default="w1,w5")
    parser.add_argument("--structures", default="octree:3,bsp")
    parser.add_argument("--cull", default="thesis")
    parser.add_argument("--profiles", default="ipaq-hx2490b")
    parser.add_argument("--frames", default="sample:8")
    parser.add_argument("--workers", type=int, default=2)
    args = parser.parse_args(argv)
    specs = expand(args.worlds, args.structures, args.cull, args.profiles, args.frames)
    (ROOT / "out").mkdir(exist_ok=True)
    with tempfile.TemporaryDirectory(dir=ROOT / "out") as tmp:
        tmp = Path(tmp)

        def context(name):
            return Context(ROOT, tmp / name, ROOT / "worlds", tmp / "cache")

        warm = context("warm")
        for spec in {(s.world, s.structure): s for s in specs}.values():
            prepare(("structure", spec, warm.as_tuple()))
        for spec in {(s.world, s.profile, s.frames, s.truth_cull_back): s for s in specs}.values():
            prepare(("truth", spec, warm.as_tuple()))
        rows = []
        start, cpu = time.perf_counter(), cpu_s()
        run_matrix(specs, context("single"), processes=1, progress=False)
        rows.append(("single process", time.perf_counter() - start, 0.0, cpu_s() - cpu))
        start, cpu = time.perf_counter(), cpu_s()
        run_matrix(specs, context("pool"), processes=args.workers, progress=False)
        rows.append((f"local pool, {args.workers} processes", time.perf_counter() - start, 0.0,
                     cpu_s() - cpu))
        start, cpu = time.perf_counter(), cpu_s()
        client, cluster = distributed.open_client("dask", args.workers)
        up = time.perf_counter() - start
        try:
            start = time.perf_counter()
            run_matrix(specs, context("dask"), progress=False, scheduler=client)
            wall = time.perf_counter() - start
        finally:
            client.close()
            cluster.close()
        rows.append((f"Dask LocalCluster, {args.workers} workers", wall, up, cpu_s() - cpu))
    single = rows[0][1]
    print(f"{len(specs)} runs ({args.worlds}; {args.structures}; {args.cull}; {args.frames}); "
          f"load average {os.getloadavg()[0]:.1f}")
    print("| mode | wall s | start-up s | single / mode | CPU s (all processes, with start-up) |")
    print("| --- | ---: | ---: | ---: | ---: |")
    for name, seconds, up, cpu in rows:
        print(f"| {name} | {seconds:.1f} | {up:.1f} | {single / seconds:.2f} | {cpu:.1f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())

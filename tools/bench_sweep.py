"""The comparison sweep on one process, a local pool and a Dask LocalCluster: wall times.

Usage: nice -n 19 .venv/bin/python tools/bench_sweep.py [--worlds w1,w5]
       [--structures octree:3,bsp] [--cull thesis] [--frames sample:8] [--workers 2]
       [--modes single,pool,dask] [--cache DIR] [--warm-only]
Partitions and ground truths are prepared (cached) first, so each mode times the runs alone;
with --cache they are kept in DIR for later invocations (--warm-only: prepare and stop), so a
loaded machine can warm them and an idle one time the modes. Each mode writes to its own
results folder. The Dask row counts the cluster's start-up
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
from vismobile.study.runner import Context, run_matrix  # noqa: E402
from vismobile.study.tasks import _worker_init, prepare  # noqa: E402


def cpu_s() -> float:
    """CPU seconds of this process and its reaped children (pool workers, Dask nannies and
    their workers once the cluster is closed)."""
    return sum(r.ru_utime + r.ru_stime for r in (resource.getrusage(resource.RUSAGE_SELF),
                                                 resource.getrusage(resource.RUSAGE_CHILDREN)))


def time_mode(mode: str, specs, context, workers: int) -> tuple:
    """(row name, wall s of the runs, cluster start-up s, CPU s) of one mode over specs."""
    start, cpu = time.perf_counter(), cpu_s()
    if mode == "single":
        run_matrix(specs, context, processes=1, progress=False)
        return "single process", time.perf_counter() - start, 0.0, cpu_s() - cpu
    if mode == "pool":
        run_matrix(specs, context, processes=workers, progress=False)
        return f"local pool, {workers} processes", time.perf_counter() - start, 0.0, cpu_s() - cpu
    client, cluster = distributed.open_client("dask", workers)
    up = time.perf_counter() - start
    try:
        start = time.perf_counter()
        run_matrix(specs, context, progress=False, scheduler=client)
        wall = time.perf_counter() - start
    finally:
        client.close()
        cluster.close()
    return f"Dask LocalCluster, {workers} workers", wall, up, cpu_s() - cpu


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--worlds", default="w1,w5")
    parser.add_argument("--structures", default="octree:3,bsp")
    parser.add_argument("--cull", default="thesis")
    parser.add_argument("--profiles", default="ipaq-hx2490b")
    parser.add_argument("--frames", default="sample:8")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--modes", default="single,pool,dask",
                        help="comma-separated modes to time, in order: single, pool, dask")
    parser.add_argument("--cache", type=Path, default=None,
                        help="partition and ground-truth cache kept between runs")
    parser.add_argument("--warm-only", action="store_true", help="prepare the cache and stop")
    args = parser.parse_args(argv)
    modes = [m.strip() for m in args.modes.split(",") if m.strip()]
    if not modes or set(modes) - {"single", "pool", "dask"}:
        parser.error(f"--modes takes single, pool and dask, got {args.modes!r}")
    specs = expand(args.worlds, args.structures, args.cull, args.profiles, args.frames)
    (ROOT / "out").mkdir(exist_ok=True)
    with tempfile.TemporaryDirectory(dir=ROOT / "out") as tmp:
        tmp = Path(tmp)
        cache = args.cache.resolve() if args.cache else tmp / "cache"

        def context(name):
            return Context(ROOT, tmp / name, ROOT / "worlds", cache)

        warm = context("warm")
        _worker_init()  # one llvmpipe thread, as every mode's runs use (before any GL context)
        for spec in {(s.world, s.structure): s for s in specs}.values():
            prepare(("structure", spec, warm.as_tuple()))
        for spec in {(s.world, s.profile, s.frames, s.truth_cull_back): s for s in specs}.values():
            prepare(("truth", spec, warm.as_tuple()))
        if args.warm_only:
            print(f"prepared {len(specs)} runs' partitions and ground truths in {cache}")
            return 0
        # This process's one-time costs (GL context, compiled kernels) before any timing; pool
        # and Dask workers pay theirs inside their rows, as they would in a sweep.
        run_matrix(specs[:1], context("warm-up"), processes=1, progress=False)
        rows = [time_mode(mode, specs, context(mode), args.workers) for mode in modes]
    base = rows[0][1]  # the first mode timed is the baseline
    print(f"{len(specs)} runs ({args.worlds}; {args.structures}; {args.cull}; {args.frames}); "
          f"load average {os.getloadavg()[0]:.1f}")
    print(f"| mode | wall s | start-up s | {rows[0][0]} / mode | CPU s (all processes, with "
          "start-up) |")
    print("| --- | ---: | ---: | ---: | ---: |")
    for name, seconds, up, cpu in rows:
        print(f"| {name} | {seconds:.1f} | {up:.1f} | {base / seconds:.2f} | {cpu:.1f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())

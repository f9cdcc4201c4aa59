"""The conservative PVS bake's time per phase (issue 29: the W2 bake takes at most 120 s on this
2-core machine; W1-W6 bake times reported).

    .venv/bin/python tools/pvs_bake_time.py [--worlds w1,w2,w3,w4] [--repair none,tjunctions]
                                            [--jobs 2] [--sources 0] [--save DIR]
                                            [--against DIR] [--budget none]

Per world and repair (`--structure portal:depth=2,pvs=conservative`, at --budget: default the
bake's, 0.25 of the OBJ; none the exact sets, as revisions before the default baked them):
one bake (pvs.bake over
--jobs processes), each phase of the parent timed: cells (pvs_cells.view_grid, and inside it
refine, crack portals, face-plane portals), walks (pvs_pool.fan_out), solids, coding (the
sets, coarsened to the budget, and face sets encoded); wall seconds, the CPU seconds of the parent and of the pool's
workers, and the load average before and after. "alone" = parent CPU + workers' CPU / jobs:
what the bake would take with the machine to itself (the parts are strided, so the workers
finish together); on a shared machine wall seconds follow the load.
--sources N: the walks of N sampled source cells in this process, the main walks apart from
the face-plane walks (pvs_planes.py): calls, crossings, seconds.
--save DIR writes each bake's extras to DIR/<world>_<repair>.npz; --against DIR compares them
bit for bit with that directory's (another revision's bakes): exit status 1 if any differs.
"""
from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from vismobile.partition import partition, pvs, pvs_cells, pvs_kernels  # noqa: E402
from vismobile.partition.pvs_coarsen import budget_param  # noqa: E402
from vismobile.scenes import build_world  # noqa: E402

PHASES = ((pvs_cells, "view_grid", "cells"), (pvs_cells, "refine", "refine"),
          (pvs_cells, "with_cracks", "crack portals"),
          (pvs_cells, "with_plane_cracks", "plane portals"), (pvs, "fan_out", "walks"),
          (pvs, "with_solids", "solids"), (pvs, "stored_sets", "coding"),
          (pvs, "face_extras", "coding"))


def timed():
    """Wrap PHASES' functions to add their wall and CPU seconds (this process's) to the returned
    dict: label -> [wall, cpu]."""
    spent = {}

    def wrap(function, label):
        def run(*args, **kwargs):
            wall, cpu = time.perf_counter(), time.process_time()
            try:
                return function(*args, **kwargs)
            finally:
                row = spent.setdefault(label, [0.0, 0.0])
                row[0] += time.perf_counter() - wall
                row[1] += time.process_time() - cpu
        return run

    for module, name, label in PHASES:
        setattr(module, name, wrap(getattr(module, name), label))
    return spent


def load(name, repair):
    world = build_world(name)
    if repair == "tjunctions":
        from vismobile.world.tjunctions import repair_tjunctions

        world, _ = repair_tjunctions(world)
    return world


def sampled_walks(world, repair, count, seed=0) -> str:
    """The main and face-plane walks of `count` sampled source cells (this process)."""
    grow = pvs.bake_grow(world)
    g = pvs_cells.view_grid(world, None, grow=grow, split=repair == "tjunctions", planes=True)
    tol = pvs.TOLERANCE * float(np.ptp(world.extent, axis=0).max()) + grow
    cells = len(g["cell_bounds"])
    tally = {"main": [0, 0, 0.0], "face-plane": [0, 0, 0.0]}
    kernels = {"main": pvs_kernels.flow_from_cell, "face-plane": pvs_kernels.flow_in_slab}

    def counted(label):
        def run(*args):
            began = time.perf_counter()
            steps = kernels[label](*args)
            row = tally[label]
            row[0], row[1], row[2] = row[0] + 1, row[1] + max(steps, 0), \
                row[2] + time.perf_counter() - began
            return steps
        return run

    pvs.bake_cells(world, g, np.arange(1), grow, tol)  # numba's first compile, untimed
    pvs_kernels.flow_from_cell, pvs_kernels.flow_in_slab = counted("main"), counted("face-plane")
    try:
        rng = np.random.default_rng(seed)
        pvs.bake_cells(world, g, np.sort(rng.choice(cells, min(count, cells), replace=False)),
                       grow, tol)
    finally:
        pvs_kernels.flow_from_cell, pvs_kernels.flow_in_slab = (kernels["main"],
                                                                kernels["face-plane"])
    return ", ".join(f"{k} walks {c} ({n:,} crossings, {s:.2f} s)"
                     for k, (c, n, s) in tally.items())


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--worlds", default="w1,w2,w3,w4")
    parser.add_argument("--repair", default="none,tjunctions",
                        help="comma list of none, tjunctions")
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--sources", type=int, default=0)
    parser.add_argument("--save", type=Path)
    parser.add_argument("--against", type=Path)
    parser.add_argument("--budget", default=None,
                        help="budget=F of the bakes (default the bake's, 0.25; none: exact)")
    args = parser.parse_args()
    budget = budget_param(args.budget)
    repairs = args.repair.split(",")
    if any(r not in ("none", "tjunctions") for r in repairs):
        parser.error(f"--repair {args.repair}: expected none and/or tjunctions")
    spent = timed()
    differ = 0
    for name in args.worlds.split(","):
        for repair in repairs:
            world = load(name, repair)
            part = partition(world, "portal", depth=2)
            part.params["budget"] = budget  # as partition(..., pvs=, budget=) sets it
            spent.clear()
            began, before, load0 = time.perf_counter(), os.times(), os.getloadavg()[0]
            extras, stats = pvs.bake(part, jobs=args.jobs)
            seconds, after, load1 = time.perf_counter() - began, os.times(), os.getloadavg()[0]
            parent = after.user - before.user + after.system - before.system
            workers = (after.children_user - before.children_user + after.children_system
                       - before.children_system)
            phases = ", ".join(f"{k} {w:.1f} ({c:.1f})" for k, (w, c) in spent.items())
            alone = parent + workers / max(args.jobs, 1)
            print(f"{name} {repair}: {stats['cells']} cells, {stats['walks']:,} crossings | "
                  f"wall {seconds:.1f} s (wall (parent CPU) by phase: {phases}) | "
                  f"CPU parent {parent:.1f} s + workers {workers:.1f} s, alone ~{alone:.1f} s"
                  f" | load {load0:.1f}-{load1:.1f}", flush=True)
            key = f"{name}_{repair}.npz"
            if args.save:
                args.save.mkdir(parents=True, exist_ok=True)
                np.savez(args.save / key, **{k: np.asarray(v) for k, v in extras.items()})
            if args.against:
                other = np.load(args.against / key)
                same = sorted(other.files) == sorted(extras) and all(
                    np.asarray(extras[k]).dtype == other[k].dtype
                    and np.array_equal(np.asarray(extras[k]), other[k]) for k in other.files)
                differ += not same
                print(f"  against {args.against / key}: "
                      f"{'identical' if same else 'DIFFERENT'}", flush=True)
            if args.sources:
                print(f"  {args.sources} sampled sources: "
                      f"{sampled_walks(world, repair, args.sources)}", flush=True)
    sys.exit(1 if differ else 0)


if __name__ == "__main__":
    main()

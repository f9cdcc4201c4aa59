"""Partition build time, size and shape for the thesis worlds, beside thesis Table 5.3.

Usage: .venv/bin/python tools/bench_partition.py [--worlds w1,w2] [--structures bsp,portal]
       [--runs 3] [--million]
Prints a markdown table: median build seconds, nodes, leaves, refs/triangle, largest leaf
(references), .vmp KB, OBJ KB, and the thesis's file size (KB). --structures keeps the rows whose
label starts with one of the given prefixes (case-insensitive: "bsp", "portal 2", "octree").
"BSP" is the default (balanced) BSP; "BSP thesis" the thesis's stopping rule with 16 candidates. --million also times an octree-5 build of a synthetic
1,000,000-triangle world (copies of the cow on a grid).
"""
from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from vismobile.partition import partition, save_partition  # noqa: E402
from vismobile.world.world import World  # noqa: E402

THESIS_KB = {  # SPEC §4, Table 5.3
    "grid": (784, 12455, 11948, 4262, 226, 910),
    "octree 3": (633, None, None, 2955, 271, 976),
    "octree 4": (822, 11098, 11133, 3227, 390, 1103),
    "octree 5": (1478, 13171, 13242, 4035, 920, 1657),
    "octree 6": (4459, None, None, None, 3988, 4815),
    "portal 1": (987, 13043, 12810, 3926, 299, 1087),
    "portal 2": (1429, 14771, 14597, 5146, 353, 1143),
    "portal 3": (3293, None, None, 5591, 528, 1338),
    "BSP": (568, 9449, 9512, 2772, 229, 939),
}
THESIS_KB["BSP thesis"] = THESIS_KB["BSP"]
STRUCTURES = [("grid", "grid", {"auto": True})] + \
    [(f"octree {d}", "octree", {"depth": d}) for d in (3, 4, 5, 6)] + \
    [(f"portal {d}", "portal", {"depth": d}) for d in (1, 2, 3)] + \
    [("BSP", "bsp", {}), ("BSP thesis", "bsp", {"rule": "thesis", "candidates": 16})] + \
    [("kdtree", "kdtree", {}), ("kdtree median", "kdtree", {"split": "median", "min_leaf": 8})]


def timed(world, kind, params, runs):
    times, result = [], None
    for _ in range(runs):
        start = time.perf_counter()
        result = partition(world, kind, **params)
        times.append(time.perf_counter() - start)
    return statistics.median(times), result


def million_world(target=1_000_000):
    cow = World.from_obj(ROOT.parent / "shared" / "models" / "cow.obj")
    copies = -(-target // cow.triangle_count)
    side = int(np.ceil(np.sqrt(copies)))
    size = np.ptp(cow.extent, axis=0) * 1.2
    parts = [cow.transformed(1.0, (i % side * size[0], 0.0, i // side * size[2]))
             for i in range(copies)]
    world = World.concatenate(parts, "million")
    return world.subset(np.arange(target))


def versus(names, labels, runs) -> int:
    """Two structures' builds alternated run by run in one process (first build of each is a
    warm-up, not timed): medians and their ratio per world."""
    from vismobile.scenes import build_world

    by_label = {label.lower(): (kind, params) for label, kind, params in STRUCTURES}
    pair = [by_label[label.strip().lower()] for label in labels.split(",")]
    print(f"| world | {labels.split(',')[0]} s | {labels.split(',')[1]} s | ratio |")
    print("| --- | ---: | ---: | ---: |")
    for name in names:
        world = build_world(name)
        for kind, params in pair:
            partition(world, kind, **params)  # warm-up (numba compiles)
        times = [[], []]
        for _ in range(runs):
            for i, (kind, params) in enumerate(pair):
                times[i].append(timed(world, kind, params, 1)[0])
        a, b = statistics.median(times[0]), statistics.median(times[1])
        print(f"| {name.upper()} | {a:.3f} | {b:.3f} | {a / b:.2f}x |", flush=True)
    return 0


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--worlds", default="w1,w2,w3,w4,w5,w6")
    parser.add_argument("--structures", default="",
                        help="comma-separated label prefixes, e.g. bsp,portal 2 (default: all)")
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--million", action="store_true")
    parser.add_argument("--versus", default="",
                        help="LABEL,LABEL: time these two builds interleaved (--runs each) on "
                             "each world and print the ratio of their medians, e.g. "
                             "'kdtree,octree 5'")
    args = parser.parse_args(argv)
    from vismobile.scenes import build_world, default_cache_dir

    names = args.worlds.split(",")
    if args.versus:
        return versus(names, args.versus, args.runs)
    prefixes = [p.strip().lower() for p in args.structures.split(",") if p.strip()]
    rows = [row for row in STRUCTURES
            if not prefixes or any(row[0].lower().startswith(p) for p in prefixes)]
    print("| world | structure | build s (median) | nodes | leaves | refs/tri | max leaf | .vmp KB "
          "| OBJ KB | vmp/OBJ | thesis KB |")
    print("| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |")
    with tempfile.TemporaryDirectory() as tmp:
        for name in names:
            world = build_world(name)
            obj_kb = (default_cache_dir() / f"{name}.obj").stat().st_size / 1024
            column = int(name[1:]) - 1
            for label, kind, params in rows:
                seconds, result = timed(world, kind, params, args.runs)
                path = Path(tmp) / "p.vmp"
                save_partition(result, path)
                kb = path.stat().st_size / 1024
                stats = result.stats()
                thesis = THESIS_KB.get(label, (None,) * 6)[column]
                print(f"| {name.upper()} | {label} | {seconds:.2f} | {stats['nodes']:,} | "
                      f"{stats['leaves']:,} | {stats['refs_per_triangle']:.2f} | "
                      f"{stats['max_leaf_refs']:,} | {kb:,.0f} | "
                      f"{obj_kb:,.0f} | {kb / obj_kb:.2f} | {thesis if thesis else '–'} |",
                      flush=True)
    if args.million:
        world = million_world()
        seconds, result = timed(world, "octree", {"depth": 5}, 1)
        stats = result.stats()
        print(f"\n1,000,000-triangle synthetic world, octree 5: {seconds:.1f} s, "
              f"{stats['nodes']:,} nodes, {stats['refs_per_triangle']:.2f} refs/triangle")
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""The per-sequence walk tried for issue 29 (docs/partition.md, "Per-sequence walks"): portal
sequences from one source cell enumerated depth first, each carrying its own crossing polygon,
against the bake's union-box walk (pvs_kernels.flow_from_cell), on the sealed cells
(pvs_refine) joined across wholly open faces.

    .venv/bin/python tools/pvs_paths.py [--world w1] [--sources 4] [--random] [--band 0]
                                        [--max-cracks -1] [--exact 0] [--budget 3000000]

A line from an eye in the source box S crosses portals p1, p2, ..., pk in order (cells are convex:
a sequence never repeats a cell). For pk the walk keeps the convex set Xk where such a line may
cross it: pk's quad (a crack's crossing box, pvs_kernels._crack_candidate) clipped by the
separators of (S, X(k-1)), (X1, X(k-1)) and (X(k-2), X(k-1)), each set lying before X(k-1) on
the line (Teller and Sequin 1991; Quake's vis keeps the first portal the same way). With --exact
V, a crossing's first V arrivals are walked as sequences and later ones widen its union state
(the boxes of the crossing, of the crossings before it and of the sequences' first crossings,
walked again when they grow): sound and bounded like the union flow. --max-cracks C drops
sequences through more than C cracks (NOT conservative: how much a crack budget would keep).
--band B moves the source box's floor up and ceiling down by B (eyes kept off the floor and
ceiling planes). Past --budget crossings a walk stops ('over budget', with what it had marked).
Per source (the largest view cells, or --random ones): the share of the world each walk marks,
its crossings and seconds. A diagnostic, not a bake.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from vismobile.partition import pvs, pvs_cracks  # noqa: E402
from vismobile.partition.pvs_cells import view_grid  # noqa: E402
from vismobile.partition.pvs_kernels import flow_from_cell  # noqa: E402
from vismobile.partition.pvs_sequences import (crack_flags, merge_cells, sequences,  # noqa: E402
                                               walk_args)
from vismobile.scenes import build_world  # noqa: E402


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--world", default="w1")
    parser.add_argument("--sources", type=int, default=4, help="view cells walked from")
    parser.add_argument("--random", action="store_true", help="random cells, not the largest")
    parser.add_argument("--band", type=float, default=0.0, help="source floor/ceiling margin")
    parser.add_argument("--max-cracks", type=int, default=-1, help="cap (NOT conservative)")
    parser.add_argument("--exact", type=int, default=0, help="sequence arrivals per crossing"
                        " before widening (0: never widen)")
    parser.add_argument("--budget", type=int, default=3_000_000)
    args = parser.parse_args(argv)
    if args.max_cracks >= 0 and args.exact > 0:
        parser.error("--max-cracks counts cracks along whole sequences: not with --exact")
    world = build_world(args.world)
    grow = pvs.bake_grow(world)
    tol = pvs.TOLERANCE * float(np.ptp(world.extent, axis=0).max()) + grow
    sealed = view_grid(world, grow=grow, split=True)
    joined = merge_cells(sealed, tol)
    exact = args.exact if args.exact > 0 else np.iinfo(np.int64).max
    print(f"{args.world} sealed: {len(sealed['cell_bounds'])} cells, {sealed['cracks']} cracks; "
          f"joined: {len(joined['cell_bounds'])} cells, {joined['cracks']} cracks; band "
          f"{args.band:g}, max cracks {args.max_cracks}, exact {args.exact or 'all'}", flush=True)
    bounds = sealed["cell_bounds"]
    volume = np.prod(bounds[:, 1] - bounds[:, 0], axis=1)
    picks = (np.random.default_rng(0).choice(len(bounds), args.sources, replace=False)
             if args.random else np.argsort(-volume)[:args.sources])
    for s in picks:
        lo, hi = bounds[s, 0].copy(), bounds[s, 1].copy()
        lo[1], hi[1] = lo[1] + args.band, hi[1] - args.band
        line = f"  source {s} {bounds[s].round(2).tolist()}:"
        for kind, g, cell in (("union", sealed, s), ("sequences", joined, joined["member"][s])):
            crack = crack_flags(g)
            visible = np.zeros(world.triangle_count, dtype=bool)
            began = time.perf_counter()
            common = walk_args(world, g, cell, lo, hi, grow, tol)
            if kind == "union":
                walks = flow_from_cell(*common, args.budget, visible,
                                       np.zeros(len(g["cell_bounds"]), dtype=bool), crack,
                                       pvs_cracks.CRACK_SLOPE, np.zeros(len(crack), dtype=bool),
                                       np.zeros(len(crack), dtype=bool))
            else:
                walks = sequences(*common, args.budget, visible, crack, pvs_cracks.CRACK_SLOPE,
                                  np.zeros(len(crack), dtype=bool), exact, args.max_cracks)
            line += (f" {kind} {100 * visible.mean():.1f}% "
                     f"({'over budget' if walks < 0 else f'{walks} walks'}, "
                     f"{time.perf_counter() - began:.1f} s);")
        print(line, flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""What each crack portal adds to a conservative PVS set (issue 29): the bake's walk
(pvs_kernels.flow_from_cell) from the largest view cells with no crack portal open, with all of
them open (as shipped), and with each crack portal open alone.

    .venv/bin/python tools/pvs_crack_share.py [--world w1] [--sources 2] [--split]
                                              [--cracks 0] [--slope 1.0]

Per source cell: its set (a share of the world's triangles) without cracks and with all of them;
then, for every crack portal (or --cracks of them drawn at random), the triangles its walk adds
to the crack-free set when that crack alone is open: how many cracks add anything, more than 1%
and more than 10% of the world, and the five that add most (number among the cracks, as
tools/pvs_anchored.py --crack takes it; segment; the two cells). --split
bakes over the sealed cells (pvs_refine: thin cells split at their reveals, as tools/pvs_slack.py
does); --slope scales the crack's width per unit of distance (pvs_cracks.CRACK_SLOPE), to see
whether narrower cracks would let less through. Diagnostics only: a walk with cracks closed is
not conservative (docs/partition.md).
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from vismobile.partition import pvs, pvs_cracks, pvs_kernels  # noqa: E402
from vismobile.partition.pvs_cells import view_grid  # noqa: E402
from vismobile.scenes import build_world  # noqa: E402


def walker(world, g, grow, tol, slope):
    """walk(source, blocked (P,) bool) -> (T,) bool: the bake's walk from one source cell."""
    bounds, start = g["cell_bounds"], g["cell_start"]
    quads = np.asarray(g["portal_vertices"], dtype=np.float64).reshape(-1, 4, 3)
    pcells = g["portal_cells"]
    crack = np.zeros(len(pcells), dtype=bool)
    crack[len(pcells) - int(g.get("cracks", 0)):] = True

    def walk(s, blocked):
        visible = np.zeros(world.triangle_count, dtype=bool)
        steps = pvs_kernels.flow_from_cell(
            int(s), bounds[s, 0], bounds[s, 1], bounds, pcells, quads, g["cell_portal_start"],
            g["cell_portals"], start[:-1], start[1:], g["cell_tris"], world.corners, grow, tol,
            pvs.BUDGET, visible, np.zeros(len(bounds), dtype=bool), crack, slope, blocked,
            np.zeros(len(pcells), dtype=bool))
        if steps < 0:
            raise RuntimeError(f"source {s}: the walk passed its budget")
        return visible

    return walk, crack


def crack_shares(walk, crack, source, ids):
    """(closed (T,) bool, everything (T,) bool, added (len(ids),) int64): the source's set
    with every crack portal blocked, with none blocked, and what each crack of ids adds to the
    first when it alone is open."""
    closed = walk(source, crack.copy())
    everything = walk(source, np.zeros(len(crack), dtype=bool))
    added = np.zeros(len(ids), dtype=np.int64)
    for i, p in enumerate(ids):
        blocked = crack.copy()
        blocked[p] = False
        added[i] = int((walk(source, blocked) & ~closed).sum())
    return closed, everything, added


def run(name, sources, split, sample, slope_scale):
    world = build_world(name)
    grow = pvs.bake_grow(world)
    began = time.perf_counter()
    g = view_grid(world, grow=grow, split=split)
    tol = pvs.TOLERANCE * float(np.ptp(world.extent, axis=0).max()) + grow
    walk, crack = walker(world, g, grow, tol, slope_scale * pvs_cracks.CRACK_SLOPE)
    ids = np.flatnonzero(crack)
    bounds, quads = g["cell_bounds"], np.asarray(g["portal_vertices"]).reshape(-1, 4, 3)
    print(f"{name}{' sealed' if split else ''}: {len(bounds)} view cells, {len(crack)} portals of "
          f"which {len(ids)} cracks, slope x{slope_scale:g} ({time.perf_counter() - began:.1f} s)",
          flush=True)
    if sample and sample < len(ids):
        ids = np.sort(np.random.default_rng(0).choice(ids, sample, replace=False))
    count = world.triangle_count
    volume = np.prod(bounds[:, 1] - bounds[:, 0], axis=1)
    for s in np.argsort(-volume)[:sources]:
        began = time.perf_counter()
        closed, everything, added = crack_shares(walk, crack, s, ids)
        share = added / count
        print(f"  source {s} {bounds[s].round(2).tolist()}: no cracks {100 * closed.mean():.1f}%, "
              f"all {100 * everything.mean():.1f}%; of {len(ids)} cracks alone, "
              f"{(share > 0).sum()} add any, {(share > 0.01).sum()} > 1%, "
              f"{(share > 0.1).sum()} > 10% (most {100 * share.max():.1f}%, median of those "
              f"adding {100 * np.median(share[share > 0]) if (share > 0).any() else 0:.1f}%) "
              f"({time.perf_counter() - began:.0f} s)", flush=True)
        for i in np.argsort(-added)[:5]:
            p = ids[i]
            a, b = g["portal_cells"][p]
            print(f"    +{100 * share[i]:.1f}%: crack {int(np.searchsorted(np.flatnonzero(crack), p))}"
                  f" {quads[p, 0].round(2).tolist()} - "
                  f"{quads[p, 1].round(2).tolist()} between cells {a} {bounds[a].round(1).tolist()}"
                  f" and {b} {bounds[b].round(1).tolist()}", flush=True)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--world", default="w1")
    parser.add_argument("--sources", type=int, default=2, help="largest view cells walked from")
    parser.add_argument("--split", action="store_true", help="the sealed cells (pvs_refine)")
    parser.add_argument("--cracks", type=int, default=0, help="cracks tried alone (0: all)")
    parser.add_argument("--slope", type=float, default=1.0, help="x CRACK_SLOPE")
    args = parser.parse_args()
    run(args.world, args.sources, args.split, args.cracks, args.slope)


if __name__ == "__main__":
    main()

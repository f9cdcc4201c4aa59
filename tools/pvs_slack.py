"""Why the conservative PVS culls little (issue 29): per view cell, the conservative set against
what item buffers from many points in that cell see (the slack), under three cell models.

    .venv/bin/python tools/pvs_slack.py [--worlds w1] [--cells 12] [--samples 16]

Per world, the K largest view cells of the shipped bake (pvs_cells.view_grid, split=False) that
the other models leave whole, each baked (pvs.bake_cells) with:
  shipped  the PVS's own portal grid (hollow walls are thin cells, open along their length)
           without its crack portals - NOT conservative alone (the bake ships it with them);
  sealed   thin cells split at the walls inside them (pvs_refine: a doorway's reveals close the
           hollow wall's inside from the doorway) - NOT conservative alone: the item buffer
           sees through the rasteriser's cracks along unshared edges (below);
  cracks   sealed plus every unshared edge in two cells' common face as a crack portal, any
           number per line of sight, as the shipped bake does (pvs_cracks);
and the sampled set: six 90-degree item buffers (no back-face culling) from --samples jittered
points in the cell. Prints each cell's box and the four sets as shares of the world, then the
medians and the conservative / sampled ratios, and the unshared edges and crack portals.
"""
from __future__ import annotations

import argparse
import dataclasses
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from vismobile.device.profile import get_profile  # noqa: E402
from vismobile.partition import portal, pvs  # noqa: E402
from vismobile.partition.pvs_cells import view_grid  # noqa: E402
from vismobile.partition.pvs_cracks import crack_reach, unshared_edges, with_cracks  # noqa: E402
from vismobile.partition.pvs_refine import refine  # noqa: E402
from vismobile.render.pvs_sampled import RESOLUTION, seen_from  # noqa: E402
from vismobile.scenes import build_world  # noqa: E402

PROFILE = get_profile("ipaq-hx2490b")


def sampled_share(world, lo, hi, samples, rng):
    """Share of the world the item buffers from `samples` jittered points in [lo, hi] show."""
    cube = dataclasses.replace(PROFILE, resolution=(RESOLUTION, RESOLUTION))
    return seen_from(world, lo + rng.uniform(0.0, 1.0, (samples, 3)) * (hi - lo), cube).mean()


def index_of(boxes, box):
    hit = np.flatnonzero(np.all(np.abs(boxes - box) <= 1e-12, axis=(1, 2)))
    return int(hit[0]) if len(hit) else -1


def run(name, count, samples):
    world = build_world(name)
    size = float(np.ptp(world.extent, axis=0).max())
    thickness = portal.THICKNESS * size
    grow = pvs.bake_grow(world)
    tol = pvs.TOLERANCE * size + grow
    began = time.perf_counter()
    shipped = view_grid(world, split=False, cracks=False)
    sealed = refine(world, shipped, thickness)
    cracked = with_cracks(world, sealed, thickness, crack_reach(world, grow))
    models = {"shipped": shipped, "sealed": sealed, "cracks": cracked}
    print(f"{name}: cells shipped {len(shipped['cell_bounds'])}, sealed "
          f"{len(sealed['cell_bounds'])}; portals {len(shipped['portal_cells'])}, sealed "
          f"{len(sealed['portal_cells'])}, crack portals {cracked.get('cracks', 0)} from "
          f"{len(unshared_edges(world))} unshared edges ({time.perf_counter() - began:.1f} s)",
          flush=True)
    boxes = shipped["cell_bounds"]
    volume = np.prod(boxes[:, 1] - boxes[:, 0], axis=1)
    picks = [c for c in np.argsort(-volume)
             if index_of(sealed["cell_bounds"], boxes[c]) >= 0][:count]
    rng = np.random.default_rng(0)
    rows = []
    for c in picks:
        row = []
        for g in models.values():
            s = index_of(g["cell_bounds"], boxes[c])
            (runs, _, _, _), = pvs.bake_cells(world, g, [s], grow, tol)
            row.append(len(pvs.ids_of(runs)) / world.triangle_count)
        row.append(sampled_share(world, boxes[c, 0], boxes[c, 1], samples, rng))
        rows.append(row)
        lo, hi = np.round(boxes[c], 2)
        print(f"  cell {lo.tolist()}-{hi.tolist()}: shipped {100 * row[0]:.1f}%, sealed "
              f"{100 * row[1]:.1f}%, cracks {100 * row[2]:.1f}%, sampled ({samples} points) "
              f"{100 * row[3]:.1f}%", flush=True)
    rows = np.array(rows)
    med = np.median(rows, axis=0)
    ratio = np.median(rows[:, :3] / np.maximum(rows[:, 3:], 1e-9), axis=0)
    print(f"{name} medians over {len(rows)} cells: shipped {100 * med[0]:.1f}%, sealed "
          f"{100 * med[1]:.1f}%, cracks {100 * med[2]:.1f}%, sampled {100 * med[3]:.1f}%; "
          f"conservative / sampled: shipped {ratio[0]:.1f}x, sealed {ratio[1]:.1f}x, cracks "
          f"{ratio[2]:.1f}x ({time.perf_counter() - began:.0f} s)", flush=True)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--worlds", default="w1")
    parser.add_argument("--cells", type=int, default=12)
    parser.add_argument("--samples", type=int, default=16)
    args = parser.parse_args()
    for name in args.worlds.split(","):
        run(name.strip(), args.cells, args.samples)


if __name__ == "__main__":
    main()

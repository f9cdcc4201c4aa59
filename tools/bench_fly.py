"""Fly-over view cells benchmark (issue 29, partition/pvs_fly.py): what fly=on costs and saves.

    .venv/bin/python tools/bench_fly.py [--worlds w5,w6] [--frames 60] [--random 300] [--jobs 2]
                                        [--split 4] [--no-street]

Per world: the portal structure (depth 2) baked twice, street cells only and with fly=on; bake
seconds of each; the PVS's stored bytes (its extras' sections, pvs_codec.DERIVED aside)
against the OBJ, and what the street cells' sets of the same bake take alone; the fly-over
cells per layer and their mean set (share of the world); along a generated fly-over path
(fly_path: an ellipse over the world at heights from just over the street layer to just under
the ceiling, looking ahead and down) the triangles sent by vfc+tbfc and pvs+vfc+tbfc over the
fly-over PVS (and the distinct triangles the item buffer shows), in all and per layer the eye
is in, the frames that fell back, and the triangles pvs+vfc dropped against the item buffer
without back-face culling; then --random cameras inside random fly-over cells (a
quarter each uniform, on a face, an edge, a corner; pitch +-89, fov 10-120) in float64,
float32 and fixed16.16 (cycled): how many used the PVS and how many triangles they dropped.
--split sets pvs_fly.SPLIT (how far a layer's squares split near a column poking in);
--no-street skips the street-only bake.
"""
from __future__ import annotations

import argparse
import copy
import os
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from bench_pvs import PROFILE, in_cell_cameras, random_checks, shown  # noqa: E402
from vismobile.culling import Culler  # noqa: E402
from vismobile.partition import partition, pvs_fly  # noqa: E402
from vismobile.partition.pvs import bake  # noqa: E402
from vismobile.partition.pvs_codec import cell_sizes, decode, encode  # noqa: E402
from vismobile.partition.pvs_codec import DERIVED  # noqa: E402
from vismobile.partition.store import stored_bytes  # noqa: E402
from vismobile.scenes import build_world  # noqa: E402
from vismobile.world.camera import Camera, yaw_toward  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]


def fly_path(boxes, frames, pitch=-20.0):
    """Cameras on an ellipse over the cells' x-z extent (0.35 of it from the centre), climbing
    and sinking twice between 1 m over the street layer and 1 m under the ceiling (the fly-over
    cells' lowest bottom and highest top), looking along the path and `pitch` down."""
    low, high = boxes[:, 0].min(axis=0), boxes[:, 1].max(axis=0)
    bottom = float(np.min(boxes[:, 0, 1]))
    centre, size = (low + high) / 2, high - low
    angle = np.linspace(0, 2 * np.pi, frames, endpoint=False)
    x = centre[0] + 0.35 * size[0] * np.cos(angle)
    z = centre[2] + 0.35 * size[2] * np.sin(angle)
    y = bottom + 1.0 + (high[1] - bottom - 2.0) * 0.5 * (1 - np.cos(2 * angle))
    yaw = yaw_toward(-np.sin(angle), np.cos(angle))  # along the path (its tangent)
    return [Camera(np.array([x[i], y[i], z[i]]), yaw=float(yaw[i]), pitch=pitch,
                   aspect=PROFILE.aspect) for i in range(frames)]


def stored(extras) -> int:
    """The PVS's bytes in a .vmp: its sections but those rebuilt on load (pvs_codec.DERIVED)."""
    return sum(stored_bytes(v) for k, v in extras.items() if k not in DERIVED)


def baked(part, fly, jobs):
    """(a copy of part with its PVS baked, exact sets (budget=none), bake stats)."""
    out = copy.copy(part)
    out.params = {**part.params, "pvs": "conservative", "budget": "none",  # the exact sets
                  **({"fly": "on"} if fly else {})}
    extras, stats = bake(out, jobs=jobs)
    out.extras = {**part.extras, **extras}
    return out, stats, extras


def run(name, frames, randoms, jobs, street=True):
    world = build_world(name)
    part = partition(world, "portal", depth=2)
    obj = os.path.getsize(ROOT / "worlds" / f"{name}.obj")
    if street:
        _, street_stats, street_extras = baked(part, False, jobs)
    fly_part, stats, extras = baked(part, True, jobs)
    fly_bytes = stored(extras)
    boxes = extras["pvs_cells"]
    cells = len(boxes)
    k = cells - stats["fly_cells"]
    sizes = cell_sizes(*decode(extras, cells, world.triangle_count), cells) / world.triangle_count
    if street:
        street_bytes = stored(street_extras)
        print(f"{name}: street cells {k}, bake {street_stats['seconds']:.1f} s, "
              f"{street_bytes / 1024:.0f} KB ({street_bytes / obj:.2f}x OBJ), mean set "
              f"{100 * sizes[:k].mean():.1f}%", flush=True)
    patterns, ids = decode(extras, cells, world.triangle_count)
    masks = np.unpackbits(patterns, axis=1, count=cells)[ids].T.astype(bool)
    alone = stored(encode(boxes[:k], masks[:k]))  # the street cells' sets of the same bake
    print(f"{name}: the street cells' sets alone take {alone / 1024:.1f} KB "
          f"({alone / obj:.3f}x OBJ)", flush=True)
    print(f"{name} fly=on (SPLIT {pvs_fly.SPLIT}): {stats['fly_cells']} fly-over cells, bake "
          f"{stats['seconds']:.1f} s" + (f" ({stats['seconds'] / street_stats['seconds']:.2f}x "
                                          "the street cells')" if street else "") +
          f", {fly_bytes / 1024:.1f} KB ({fly_bytes / obj:.3f}x OBJ), fly-over mean set "
          f"{100 * sizes[k:].mean():.1f}%", flush=True)
    fly = boxes[k:]
    for y0 in np.unique(fly[:, 0, 1]):
        m = fly[:, 0, 1] == y0
        side = fly[m][:, 1, 0] - fly[m][:, 0, 0]
        print(f"  layer {y0:.1f}-{fly[m][0, 1, 1]:.1f} m: {m.sum()} cells {side.min():.0f}-"
              f"{side.max():.0f} m, mean set {100 * sizes[k:][m].mean():.1f}% (min "
              f"{100 * sizes[k:][m].min():.1f}%)", flush=True)
    base, pvs, check = (Culler(fly_part, s) for s in ("vfc+tbfc", "pvs+vfc+tbfc", "pvs+vfc"))
    tops = np.unique(fly[:, 1, 1])
    rows = np.zeros((len(tops) + 1, 6), dtype=np.int64)  # per layer, then all: frames, vfc+tbfc,
    tested = []  # view-cell boxes the stage's lookup tested per frame (culling/pvs_lookup.py)
    for cam in fly_path(fly, frames):  # pvs+vfc+tbfc, visible, fell back, dropped
        r = pvs.cull(cam)
        tested.append(r.stats.get("pvs.cells_tested", 0))
        ids = shown(world, cam, PROFILE)
        row = np.array([1, len(base.cull(cam).triangles), len(r.triangles), len(ids),
                        r.stats.get("pvs.fallbacks", 0),
                        len(np.setdiff1d(ids, check.cull(cam).triangles))])
        rows[min(int(np.searchsorted(tops, cam.eye[1])), len(tops) - 1)] += row
        rows[-1] += row
    for label, (n, sent_base, sent, seen, fell, lost) in zip(
            [f"eye under {t:.1f} m" for t in tops] + [f"fly path {frames} frames"], rows):
        print(f"  {label}: {n} frames, vfc+tbfc {sent_base}, pvs+vfc+tbfc {sent} "
              f"({sent / max(sent_base, 1):.3f}x; visible {seen / max(sent_base, 1):.3f}x), "
              f"fell back {fell}, dropped {lost}", flush=True)
    print(f"  lookup: {np.median(tested):.0f} cell boxes tested a frame (median), at most "
          f"{max(tested)}", flush=True)
    holder = copy.copy(fly_part)
    holder.extras = {"pvs_cells": fly}
    used, lost = random_checks(fly_part, world, in_cell_cameras(holder, randoms, 1))
    print(f"  random {randoms} cameras in fly-over cells ({used} used the PVS): dropped {lost}",
          flush=True)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--worlds", default="w5,w6")
    parser.add_argument("--frames", type=int, default=60)
    parser.add_argument("--random", type=int, default=300)
    parser.add_argument("--jobs", type=int, default=1, help="bake processes")
    parser.add_argument("--split", type=float, default=pvs_fly.SPLIT)
    parser.add_argument("--no-street", action="store_true")
    args = parser.parse_args()
    pvs_fly.SPLIT = args.split  # the bake's processes are forked: they see it too
    for name in args.worlds.split(","):
        run(name.strip(), args.frames, args.random, args.jobs, not args.no_street)


if __name__ == "__main__":
    main()

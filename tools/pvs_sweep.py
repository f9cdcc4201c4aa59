"""PVS conservativeness sweep (issue 29, target 1): a conservative PVS never drops a triangle
the item buffer shows, from random cameras inside its view cells and along the world's path,
in float64, float32 and fixed16.16.

Per world and structure (each with pvs=conservative baked, or loaded from --cache when the
bake's code and the world are unchanged): --cameras random cameras inside random view cells
(in_cell_cameras: an eighth each uniform; exactly on a face, an edge, a corner of the cell, which
take the face sets of a bake with pvs_plane, partition/pvs_planes.py, and fall back on an older
bake's, culling/pvs_frame.py near_plane; 1 mm to 10 cm inside a face, an edge, a corner; in the
plane of a world triangle crossing the cell; yaw any, pitch up to +-89, fov 10-120, near 0.1
or 0.01), each culled by pvs+vfc in all three arithmetic modes and judged against that mode's
item buffer without back-face culling; and every --path-stride-th frame of the world's
thesis path, likewise. Prints one line per world and structure: view cells, bake
seconds, checks, cameras that fell back (eye outside every cell, within the device's move of
the near plane or in a cell face's plane; with street cells, partition/pvs_street.py, also a
near plane nearer than the bake's NEAR_MIN, counted apart), dropped triangles, and the wall
times; then the random cameras' checks, fallbacks and drops per kind. With --out, appends
the lines' figures as JSON lines. With --repair tjunctions each world is repaired first
(world/tjunctions.py, as `partition --repair` does: the bake seals its thin cells) and judged on
the repaired world's item buffer. Each PVS is coarsened to --budget F x the OBJ's bytes
(partition/pvs_coarsen.py), as `pvs=conservative,budget=F` bakes it: by default the bake's
default, 0.25, as `pvs=conservative` bakes it; --budget none keeps the exact sets.

Usage: .venv/bin/python tools/pvs_sweep.py [--worlds w1,w5] [--structures portal:2,bsp]
       [--cameras 2000] [--path-stride 10] [--seed 0] [--cache out/pvs_sweep] [--out F.jsonl]
       [--jobs 1] [--repair tjunctions] [--budget none]
Run one world per call to stay within a few minutes on a shared machine. Exit status 0 when
nothing was dropped, 1 otherwise.
"""
from __future__ import annotations

import argparse
import hashlib
import json
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from vismobile.culling import Culler, device_options  # noqa: E402
from vismobile.device.profile import get_profile  # noqa: E402
from vismobile.files.loader import repaired  # noqa: E402
from vismobile.partition import load_partition, partition, save_partition  # noqa: E402
from vismobile.partition.pvs import bake  # noqa: E402
from vismobile.partition.pvs_coarsen import budget_param  # noqa: E402
from vismobile.render import SENTINEL, item_buffer  # noqa: E402
from vismobile.scenes import build_world  # noqa: E402
from vismobile.world.camera import Camera  # noqa: E402
from vismobile.world.trajectory import Trajectory  # noqa: E402

PROFILE = get_profile("ipaq-hx2490b")
MODES = ("float64", "float32", "fixed16.16")


def bake_key(world, spec) -> str:
    """16 hex digits of the world, the spec and the bake's code (partition/pvs*.py)."""
    digest = hashlib.sha256(world.digest() + spec.encode())
    for path in sorted((ROOT / "vismobile" / "partition").glob("pvs*.py")):
        digest.update(path.read_bytes())
    return digest.hexdigest()[:16]


def baked(world, spec, cache, jobs=1, budget=None) -> tuple:
    """(partition with pvs=conservative, bake seconds or None when loaded from the cache);
    the sets coarsened to `budget` x the OBJ's bytes (pvs_coarsen.py; None: the bake's
    default, 0.25), or exact for budget "none" (cached under the key exact bakes had)."""
    budget = budget_param(budget)
    tag = "-repaired" if getattr(world, "repair", None) else ""
    if budget != "none":
        spec, tag = spec + f",budget={budget!r}", tag + f"-budget{budget:g}"
    name = spec.split(",")[0].replace(":", "")
    path = Path(cache) / f"{world.name}{tag}-{name}-{bake_key(world, spec)}.vmp"
    if path.is_file():
        try:
            return load_partition(path), None
        except Exception as error:  # an older .vmp layout (store.py): baked again below
            print(f"{path.name}: {error}; baking again", flush=True)
    start = time.perf_counter()
    part = partition(world, spec.split(",")[0])
    part.params["budget"] = budget  # as partition(..., pvs=, budget=) sets it for the bake
    extras, _ = bake(part, "conservative", jobs=jobs)  # as partition(..., pvs=) does
    part.extras.update(extras)
    part.params["pvs"] = "conservative"
    seconds = time.perf_counter() - start
    path.parent.mkdir(parents=True, exist_ok=True)
    save_partition(part, path)
    return part, seconds


# the in-cell cameras' kinds, in turn (in_cell_cameras)
KINDS = ("inside", "face", "edge", "corner", "near face", "near edge", "near corner",
         "triangle plane")


def in_cell_cameras(part, count, seed, world=None):
    """(kind, camera) pairs inside random view cells (module docstring), the KINDS in turn:
    uniform inside; exactly on a face, an edge or a corner of the cell (1-3 coordinates on its
    boundary; a bake with pvs_plane adds its face sets, an older bake falls back); just inside
    a face, an edge or a corner, 1 mm to 10 cm in from each snapped side (past near_plane's
    reach: the cell's own set next to its boundary); and in the plane of a world triangle
    crossing the cell (the projection of a random point of the cell, when it stays inside: an
    eye in a wall's or an object's plane sees it edge-on; without a world, or with none
    found, "inside")."""
    rng = np.random.default_rng(seed)
    boxes = part.extras["pvs_cells"]
    for i in range(count):
        kind = KINDS[i % len(KINDS)]
        lo, hi = boxes[rng.integers(len(boxes))]
        pos = lo + rng.uniform(0, 1, 3) * (hi - lo)
        if kind not in ("inside", "triangle plane"):
            snap = rng.permutation(3)[:KINDS.index(kind.split()[-1])]  # 1, 2 or 3 sides
            side = rng.integers(0, 2, len(snap)).astype(bool)
            pos[snap] = np.where(side, hi[snap], lo[snap])  # exactly on the boundary
            if kind.startswith("near"):
                gap = np.minimum(10.0 ** rng.uniform(-3, -1, len(snap)), 0.25 * (hi - lo)[snap])
                pos[snap] += np.where(side, -gap, gap)
        elif kind == "triangle plane":
            found = plane_point(world, lo, hi, rng)
            pos, kind = (pos, "inside") if found is None else (found, kind)
        yield kind, Camera(pos, yaw=rng.uniform(0, 360), pitch=rng.uniform(-89, 89),
                           fov=rng.uniform(10, 120), near=float(rng.choice([0.1, 0.01])),
                           aspect=PROFILE.aspect)


def plane_point(world, lo, hi, rng, tries=8):
    """(3,) a point of the box [lo, hi] in the plane of a triangle whose bounds meet the box
    (a random point of the box projected onto it; an axis plane's coordinate set exactly), or
    None when no try lands inside the box."""
    if world is None:
        return None
    near = np.flatnonzero((world.bounds[:, 0] <= hi).all(axis=1)
                          & (world.bounds[:, 1] >= lo).all(axis=1))
    for _ in range(tries if len(near) else 0):
        k = near[rng.integers(len(near))]
        normal = world.normals[k]
        corner = world.vertices[world.triangles[k, 0]]
        pos = lo + rng.uniform(0, 1, 3) * (hi - lo)
        axis = np.flatnonzero(normal != 0.0)
        if len(axis) == 1:
            pos[axis[0]] = corner[axis[0]]
        else:
            pos = pos - float(np.dot(pos - corner, normal)) * normal
        if np.all((pos >= lo) & (pos <= hi)):
            return pos
    return None


def check(world, part, cameras) -> dict:
    """Every (kind, camera) through pvs+vfc in each mode, against that mode's unculled item
    buffer; the counts in all and per kind ([checks, fell back, dropped])."""
    cullers, profiles = {}, {}
    for mode in MODES:
        profiles[mode] = PROFILE if mode == "float64" else get_profile(PROFILE, mode)
        options = ({"arithmetic": "float64"} if mode == "float64"
                   else device_options(profiles[mode]))
        cullers[mode] = Culler(part, "pvs+vfc", **options)
    out = {"checks": 0, "fallbacks": 0, "near_fallbacks": 0, "dropped": 0, "worst": None,
           "kinds": {}}
    cover = part.extras.get("pvs_cover")  # street cells: near planes from cover[1] only
    for kind, cam in cameras:
        for mode in MODES:
            ids = np.unique(item_buffer(world, None, cam, profiles[mode], cull_back=False))
            shown = ids[ids != SENTINEL].astype(np.int64)
            result = cullers[mode].cull(cam)
            lost = np.setdiff1d(shown, result.triangles)
            fell = "pvs.fallbacks" in result.stats
            out["checks"] += 1
            out["fallbacks"] += int(fell)
            out["near_fallbacks"] += int(fell and cover is not None and cam.near < float(cover[1]))
            out["dropped"] += len(lost)
            counts = out["kinds"].setdefault(kind, [0, 0, 0])
            counts[0], counts[1], counts[2] = counts[0] + 1, counts[1] + fell, counts[2] + len(lost)
            if len(lost) and out["worst"] is None:
                out["worst"] = f"{mode} {kind} {cam}: {lost[:8].tolist()}"
    return out


def sweep(name, spec, cameras, stride, seed, cache, jobs=1, repair="none", budget=None) -> dict:
    began = time.perf_counter()
    budget = budget_param(budget)  # None: the bake's default
    world = repaired(build_world(name), repair, name)
    part, seconds = baked(world, spec, cache, jobs, budget)
    began_random = time.perf_counter()
    randoms = check(world, part, in_cell_cameras(part, cameras, seed, world))
    path = Trajectory.load(ROOT / "trajectories" / ("outdoor.csv" if name in ("w5", "w6")
                                                    else "indoor.csv"))
    frames = range(0, len(path), stride)
    began_path = time.perf_counter()
    along = check(world, part, (("path", path.camera(f, PROFILE.aspect)) for f in frames))
    row = {"world": name, "structure": spec, "repair": repair, "budget": budget,
           "cells": int(len(part.extras["pvs_cells"])),
           "bake_seconds": seconds, "random": randoms, "path": along,
           "path_frames": len(frames), "seconds": time.perf_counter() - began,
           "random_seconds": began_path - began_random,
           "path_seconds": time.perf_counter() - began_path}
    bake = "cached" if seconds is None else f"{seconds:.1f} s"
    tag = ("" if repair == "none" else f" (repaired {repair})") + \
        (" (budget none: exact sets)" if budget == "none" else f" (budget {budget:g})")
    print(f"{name}{tag} {spec}+pvs: {row['cells']} cells, bake {bake} | random {cameras} cameras x "
          f"3 modes: {randoms['checks']} checks, {randoms['fallbacks']} fell back "
          f"({randoms['near_fallbacks']} for a near plane nearer than the bake's), dropped "
          f"{randoms['dropped']} | path {len(frames)} frames x 3 modes: {along['fallbacks']} "
          f"fell back, dropped {along['dropped']} | {row['seconds']:.0f} s (random "
          f"{row['random_seconds']:.0f} s, path {row['path_seconds']:.0f} s)", flush=True)
    print("  random cameras by kind (checks, fell back, dropped): " + ", ".join(
        f"{kind} {c[0]}/{c[1]}/{c[2]}" for kind, c in randoms["kinds"].items()), flush=True)
    for worst in (randoms["worst"], along["worst"]):
        if worst:
            print(f"  first drop: {worst}")
    return row


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--worlds", default="w1,w2,w3,w4,w5,w6")
    parser.add_argument("--structures", default="portal:2,bsp")
    parser.add_argument("--cameras", type=int, default=2000)
    parser.add_argument("--path-stride", type=int, default=10)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--cache", type=Path, default=ROOT / "out" / "pvs_sweep")
    parser.add_argument("--out", type=Path, default=None)
    parser.add_argument("--jobs", type=int, default=1, help="bake processes")
    parser.add_argument("--repair", choices=("none", "tjunctions"), default="none",
                        help="repair each world first (world/tjunctions.py)")
    parser.add_argument("--budget", default=None,
                        help="coarsen each PVS to this share of the OBJ's bytes (pvs_coarsen.py, "
                             "as pvs=conservative,budget=F; default the bake's, 0.25; none: "
                             "the exact sets)")
    args = parser.parse_args(argv)
    if args.cameras < 0 or args.path_stride < 1 or args.jobs < 1:
        parser.error("--cameras >= 0, --path-stride >= 1 and --jobs >= 1")
    try:
        budget = budget_param(args.budget)
    except ValueError as error:
        parser.error(str(error))
    dropped = 0
    for name in filter(None, args.worlds.split(",")):
        for spec in filter(None, args.structures.split(",")):
            row = sweep(name.strip(), spec.strip(), args.cameras, args.path_stride, args.seed,
                        args.cache, args.jobs, args.repair, budget)
            dropped += row["random"]["dropped"] + row["path"]["dropped"]
            if args.out:
                with open(args.out, "a") as handle:
                    handle.write(json.dumps(row) + "\n")
    return 1 if dropped else 0


if __name__ == "__main__":
    sys.exit(main())

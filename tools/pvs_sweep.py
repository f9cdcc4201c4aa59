"""PVS conservativeness sweep (issue 29, target 1): a conservative PVS never drops a triangle
the item buffer shows, from random cameras inside its view cells and along the world's path,
in float64, float32 and fixed16.16.

Per world and structure (each with pvs=conservative baked, or loaded from --cache when the
bake's code and the world are unchanged): --cameras random cameras inside random view cells (a
quarter each uniform, on a face, on an edge, in a corner of the cell; yaw any, pitch up to
+-89, fov 10-120, near 0.1 or 0.01), each culled by pvs+vfc in all three arithmetic modes and
judged against that mode's item buffer without back-face culling; and every --path-stride-th
frame of the world's thesis path, likewise. Prints one line per world and structure: view
cells, bake seconds, checks, cameras that fell back (eye outside every cell or within the
device's move of the near plane; with street cells, partition/pvs_street.py, also a near plane
nearer than the bake's NEAR_MIN, counted apart), dropped triangles, and the wall time. With --out, appends
the lines' figures as JSON lines. With --repair tjunctions each world is repaired first
(world/tjunctions.py, as `partition --repair` does: the bake seals its thin cells) and judged on
the repaired world's item buffer.

Usage: .venv/bin/python tools/pvs_sweep.py [--worlds w1,w5] [--structures portal:2,bsp]
       [--cameras 2000] [--path-stride 10] [--seed 0] [--cache out/pvs_sweep] [--out F.jsonl]
       [--jobs 1] [--repair tjunctions]
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


def baked(world, spec, cache, jobs=1) -> tuple:
    """(partition with pvs=conservative, bake seconds or None when loaded from the cache)."""
    tag = "-repaired" if getattr(world, "repair", None) else ""
    path = Path(cache) / f"{world.name}{tag}-{spec.replace(':', '')}-{bake_key(world, spec)}.vmp"
    if path.is_file():
        try:
            return load_partition(path), None
        except Exception as error:  # an older .vmp layout (store.py): baked again below
            print(f"{path.name}: {error}; baking again", flush=True)
    start = time.perf_counter()
    part = partition(world, spec)
    extras, _ = bake(part, "conservative", jobs=jobs)  # as partition(..., pvs=) does
    part.extras.update(extras)
    part.params["pvs"] = "conservative"
    seconds = time.perf_counter() - start
    path.parent.mkdir(parents=True, exist_ok=True)
    save_partition(part, path)
    return part, seconds


def in_cell_cameras(part, count, seed):
    """Cameras inside random view cells (module docstring)."""
    rng = np.random.default_rng(seed)
    boxes = part.extras["pvs_cells"]
    for i in range(count):
        lo, hi = boxes[rng.integers(len(boxes))]
        t = rng.uniform(0, 1, 3)
        snap = rng.permutation(3)[:i % 4]  # 0..3 coordinates on the cell's boundary
        t[snap] = rng.integers(0, 2, len(snap))
        yield Camera(lo + t * (hi - lo), yaw=rng.uniform(0, 360), pitch=rng.uniform(-89, 89),
                     fov=rng.uniform(10, 120), near=float(rng.choice([0.1, 0.01])),
                     aspect=PROFILE.aspect)


def check(world, part, cameras) -> dict:
    """Every camera through pvs+vfc in each mode, against that mode's unculled item buffer."""
    cullers, profiles = {}, {}
    for mode in MODES:
        profiles[mode] = PROFILE if mode == "float64" else get_profile(PROFILE, mode)
        options = ({"arithmetic": "float64"} if mode == "float64"
                   else device_options(profiles[mode]))
        cullers[mode] = Culler(part, "pvs+vfc", **options)
    out = {"checks": 0, "fallbacks": 0, "near_fallbacks": 0, "dropped": 0, "worst": None}
    cover = part.extras.get("pvs_cover")  # street cells: near planes from cover[1] only
    for cam in cameras:
        for mode in MODES:
            ids = np.unique(item_buffer(world, None, cam, profiles[mode], cull_back=False))
            shown = ids[ids != SENTINEL].astype(np.int64)
            result = cullers[mode].cull(cam)
            lost = np.setdiff1d(shown, result.triangles)
            out["checks"] += 1
            out["fallbacks"] += int("pvs.fallbacks" in result.stats)
            out["near_fallbacks"] += int("pvs.fallbacks" in result.stats and cover is not None
                                         and cam.near < float(cover[1]))
            out["dropped"] += len(lost)
            if len(lost) and out["worst"] is None:
                out["worst"] = f"{mode} {cam}: {lost[:8].tolist()}"
    return out


def sweep(name, spec, cameras, stride, seed, cache, jobs=1, repair="none") -> dict:
    began = time.perf_counter()
    world = repaired(build_world(name), repair, name)
    part, seconds = baked(world, spec, cache, jobs)
    randoms = check(world, part, in_cell_cameras(part, cameras, seed))
    path = Trajectory.load(ROOT / "trajectories" / ("outdoor.csv" if name in ("w5", "w6")
                                                    else "indoor.csv"))
    frames = range(0, len(path), stride)
    along = check(world, part, (path.camera(f, PROFILE.aspect) for f in frames))
    row = {"world": name, "structure": spec, "repair": repair,
           "cells": int(len(part.extras["pvs_cells"])),
           "bake_seconds": seconds, "random": randoms, "path": along,
           "path_frames": len(frames), "seconds": time.perf_counter() - began}
    bake = "cached" if seconds is None else f"{seconds:.1f} s"
    tag = "" if repair == "none" else f" (repaired {repair})"
    print(f"{name}{tag} {spec}+pvs: {row['cells']} cells, bake {bake} | random {cameras} cameras x "
          f"3 modes: {randoms['checks']} checks, {randoms['fallbacks']} fell back "
          f"({randoms['near_fallbacks']} for a near plane nearer than the bake's), dropped "
          f"{randoms['dropped']} | path {len(frames)} frames x 3 modes: {along['fallbacks']} "
          f"fell back, dropped {along['dropped']} | {row['seconds']:.0f} s", flush=True)
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
    args = parser.parse_args(argv)
    if args.cameras < 0 or args.path_stride < 1 or args.jobs < 1:
        parser.error("--cameras >= 0, --path-stride >= 1 and --jobs >= 1")
    dropped = 0
    for name in filter(None, args.worlds.split(",")):
        for spec in filter(None, args.structures.split(",")):
            row = sweep(name.strip(), spec.strip(), args.cameras, args.path_stride, args.seed,
                        args.cache, args.jobs, args.repair)
            dropped += row["random"]["dropped"] + row["path"]["dropped"]
            if args.out:
                with open(args.out, "a") as handle:
                    handle.write(json.dumps(row) + "\n")
    return 1 if dropped else 0


if __name__ == "__main__":
    sys.exit(main())

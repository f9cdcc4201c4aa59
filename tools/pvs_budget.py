"""The PVS size budget per world (issue 29: PVS bytes at most 0.25x the OBJ, the sent targets
kept, nothing dropped), measured on saved exact bakes (pvs_bytes.py's cache), coarsened here as
`pvs=conservative,budget=F` bakes them (partition/pvs_coarsen.fit).

    .venv/bin/python tools/pvs_budget.py [--worlds w5,w6] [--repair tjunctions]
                                         [--budgets 0.25] [--frames 80] [--cameras 300]
                                         [--cache DIR] [--jobs 2] [--power 2] [--uniform 0]
                                         [--sent-frames N] [--no-fill] [--default]

--default measures the default bake instead (`--structure portal:2,pvs=conservative`, which
takes budget=0.25), baked here through study.engine.bake_pvs over --jobs processes (the
partition command's path): the PVS's bytes against the OBJ (and the face sets' bytes, exact
and as stored), the cells and sets kept, the bake's and the coarsening's seconds with the load
before and after, and over every path frame (--sent-frames N: N evenly spaced) pvs+vfc+tbfc
against vfc+tbfc and the frames that fell back; --cameras in-cell cameras x 3 modes and
--frames path frames x 3 modes checked for drops (0 cameras: none).

Per world and budget: the PVS's bytes in the .vmp against the OBJ before and after, the view
cells and how many sets they keep, the volume-weighted mean set, the coarsening's seconds
(what the budget adds to the bake); along the world's path (--frames evenly spaced frames)
the triangles pvs+vfc+tbfc sends against vfc+tbfc with the exact and the coarsened sets; and
dropped triangles of the coarsened sets (pvs+vfc against each mode's item buffer without
back-face culling) on those frames and on --cameras random in-cell cameras, each in float64,
float32 and fixed16.16 (pvs_sweep.py's cameras of each kind, and its check). With --uniform
N, also the sent ratio from N cameras drawn uniformly by volume in the cells (by_volume); with
--power P, merges weigh the cells' volumes raised to P. With --sent-frames N the sent ratios
along the path are taken over N evenly spaced frames instead (0: every frame), the drop checks
staying on --frames; --no-fill merges the sets as baked (pvs_coarsen.fit's fill=False: the
free bits, fill_back, left as they are). Exit status 1 if any was dropped.
"""
from __future__ import annotations

import argparse
import copy
import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from pvs_bytes import baked  # noqa: E402
from pvs_sweep import check, in_cell_cameras  # noqa: E402

from vismobile.culling import Culler  # noqa: E402
from vismobile.device.profile import get_profile  # noqa: E402
from vismobile.partition import partition, pvs_codec  # noqa: E402
from vismobile.partition.pvs_coarsen import (FACE_KEYS, HEADER, POWER, fit,  # noqa: E402
                                             stored_size)
from vismobile.partition.store import to_bytes  # noqa: E402
from vismobile.world.trajectory import Trajectory  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
PROFILE = get_profile("ipaq-hx2490b")


def pvs_bytes(part) -> int:
    """The PVS's bytes in the .vmp: the file with its PVS minus the file without."""
    plain = copy.copy(part)
    plain.extras = {k: v for k, v in part.extras.items() if not k.startswith("pvs_")}
    return len(to_bytes(part)) - len(to_bytes(plain))


def face_masks(part, triangles):
    """(V, T) bool the bake's face sets (partition/pvs_planes.py), or None without them."""
    from vismobile.partition.pvs_planes import face_sets

    sets = face_sets(part.extras)
    if sets is None:
        return None
    pvs_codec._CACHE.clear()
    boxes, patterns, ids = pvs_codec.decode_all(sets, triangles)
    pvs_codec._CACHE.clear()
    return np.unpackbits(patterns, axis=1, count=len(boxes))[ids.astype(np.int64)].T > 0


def sent(part, cameras) -> tuple:
    """(pvs+vfc+tbfc, vfc+tbfc) triangles sent over the cameras."""
    pvs, base = Culler(part, "pvs+vfc+tbfc"), Culler(part, "vfc+tbfc")
    return (sum(len(pvs.cull(c).triangles) for c in cameras),
            sum(len(base.cull(c).triangles) for c in cameras))


def by_volume(part, count, seed) -> list:
    """count cameras drawn uniformly by volume in the view cells (5-95% of each side), yaw
    any, pitch +-10, fov 60: an eye anywhere in the cells alike."""
    from vismobile.world.camera import Camera

    rng = np.random.default_rng(seed)
    boxes = part.extras["pvs_cells"]
    volume = np.prod(boxes[:, 1] - boxes[:, 0], axis=1)
    out = []
    for c in rng.choice(len(boxes), count, p=volume / volume.sum()):
        lo, hi = boxes[c]
        out.append(Camera(lo + rng.uniform(0.05, 0.95, 3) * (hi - lo), yaw=rng.uniform(0, 360),
                          pitch=rng.uniform(-10, 10), fov=60.0, aspect=PROFILE.aspect))
    return out


def run(name, repair, budgets, frames, cameras, cache, jobs, power=POWER, uniform=0,
        sent_frames=None, fill=True) -> int:
    world, part = baked(name, repair, cache, jobs)
    triangles = world.triangle_count
    obj = os.path.getsize(ROOT / "worlds" / f"{name}.obj")
    pvs_codec._CACHE.clear()
    boxes, patterns, ids = pvs_codec.decode_all(part.extras, triangles)
    masks = np.unpackbits(patterns, axis=1, count=len(boxes))[ids.astype(np.int64)].T
    masks = masks.astype(bool)
    others = {k: v for k, v in part.extras.items()
              if k.startswith("pvs_") and k not in ("pvs_shape", "pvs_pack", "pvs_cells")}
    faces = face_masks(part, triangles)  # counted, and collapsed first, as the bake does
    traj = Trajectory.load(ROOT / "trajectories" / ("outdoor.csv" if name in ("w5", "w6")
                                                    else "indoor.csv"))
    path = [traj.camera(int(f), PROFILE.aspect)
            for f in np.linspace(0, len(traj) - 1, frames).astype(int)]
    count = frames if sent_frames is None else (sent_frames or len(traj))
    along_path = path if count == frames else [
        traj.camera(int(f), PROFILE.aspect)
        for f in np.linspace(0, len(traj) - 1, count).astype(int)]
    exact_sent, base_sent = sent(part, along_path)
    spread = by_volume(part, uniform, 7)
    exact_spread, base_spread = sent(part, spread)
    exact_bytes = pvs_bytes(part)
    label = name + (" (repaired)" if repair == "tjunctions" else "")
    dropped = 0
    for share in budgets:
        began = time.perf_counter()
        extras, report = fit(boxes, masks, share * world.obj_bytes(), others, world.corners,
                             power, fill, faces=faces)
        seconds = time.perf_counter() - began
        coarse = copy.copy(part)
        coarse.extras = {**part.extras, **extras}
        size = pvs_bytes(coarse)
        coarse_sent, _ = sent(coarse, along_path)
        coarse_spread, _ = sent(coarse, spread)
        randoms = check(world, coarse, in_cell_cameras(coarse, cameras, 0, world))
        along = check(world, coarse, (("path", c) for c in path))
        dropped += randoms["dropped"] + along["dropped"]
        print(f"{label} budget={share:g}: PVS {exact_bytes / obj:.3f}x -> {size / obj:.3f}x the "
              f"OBJ ({exact_bytes / 1e3:.1f} -> {size / 1e3:.1f} KB; counted "
              f"{stored_size({**others, **extras}) / 1e3:.1f} KB, met {report['met']}), "
              f"{report['cells']} cells in {report['groups']} sets, mean set (by volume) "
              f"{report['mean_set_before']:.3f} -> {report['mean_set_after']:.3f}, coarsening "
              f"{seconds:.1f} s | path {count} frames: pvs+vfc+tbfc / vfc+tbfc "
              f"{exact_sent / base_sent:.3f}x -> {coarse_sent / base_sent:.3f}x"
              + (f" | {uniform} cameras by volume: {exact_spread / base_spread:.3f}x -> "
                 f"{coarse_spread / base_spread:.3f}x" if uniform else "") + " | dropped: "
              f"{cameras} in-cell cameras x 3 modes {randoms['dropped']} "
              f"({randoms['fallbacks']} of {randoms['checks']} fell back), path x 3 modes "
              f"{along['dropped']}", flush=True)
    return dropped


def run_default(name, repair, frames, cameras, jobs, sent_frames=None) -> int:
    """One line for the default bake of a world (module docstring, --default)."""
    from vismobile.files.loader import repaired
    from vismobile.scenes import build_world
    from vismobile.study.engine import bake_pvs

    world = repaired(build_world(name), repair, name)
    obj = os.path.getsize(ROOT / "worlds" / f"{name}.obj")
    load0 = os.getloadavg()[0]
    began = time.perf_counter()
    part, stats = bake_pvs(partition(world, "portal", depth=2), "conservative", jobs=jobs)
    seconds, load1 = time.perf_counter() - began, os.getloadavg()[0]
    report = stats["budget"]
    size = pvs_bytes(part)
    face = stored_size({k: part.extras[k] for k in FACE_KEYS if k in part.extras}) - HEADER
    traj = Trajectory.load(ROOT / "trajectories" / ("outdoor.csv" if name in ("w5", "w6")
                                                    else "indoor.csv"))
    count = sent_frames or len(traj)
    picks = np.linspace(0, len(traj) - 1, count).astype(int)
    pvs, base = Culler(part, "pvs+vfc+tbfc"), Culler(part, "vfc+tbfc")
    sent_pvs = sent_base = fallbacks = 0
    for f in picks:
        cam = traj.camera(int(f), PROFILE.aspect)
        r = pvs.cull(cam)
        sent_pvs += len(r.triangles)
        fallbacks += r.stats.get("pvs.fallbacks", 0)
        sent_base += len(base.cull(cam).triangles)
    dropped, checked = 0, ""
    if cameras:
        randoms = check(world, part, in_cell_cameras(part, cameras, 0, world))
        path = [traj.camera(int(f), PROFILE.aspect)
                for f in np.linspace(0, len(traj) - 1, frames).astype(int)]
        along = check(world, part, (("path", c) for c in path))
        dropped = randoms["dropped"] + along["dropped"]
        checked = (f" | dropped: {cameras} in-cell cameras x 3 modes {randoms['dropped']} "
                   f"({randoms['fallbacks']} of {randoms['checks']} fell back), {frames} path "
                   f"frames x 3 modes {along['dropped']}")
    label = name + (" (repaired)" if repair == "tjunctions" else "")
    faces = report.get("faces", [0, 0])
    print(f"{label} default (budget {part.params['budget']}): PVS {size / obj:.3f}x the OBJ "
          f"({size / 1e3:.1f} KB; counted before {report['before'] / 1e3:.1f} KB, met "
          f"{report['met']}), face sets {faces[0] / 1e3:.1f} -> {face / 1e3:.1f} KB"
          f"{' (collapsed)' if report.get('faces_collapsed') else ''}, {report['cells']} cells "
          f"in {report['groups']} sets ({report['merges']} merges), mean set (by volume) "
          f"{report['mean_set_before']:.3f} -> {report['mean_set_after']:.3f} | bake "
          f"{seconds:.1f} s (coarsening {report['seconds']:.1f} s), load {load0:.1f}-{load1:.1f}"
          f" | path {count} frames: pvs+vfc+tbfc / vfc+tbfc {sent_pvs / max(sent_base, 1):.3f}x"
          f" ({sent_pvs} / {sent_base}), fallbacks {fallbacks}{checked}", flush=True)
    return dropped


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--worlds", default="w5,w6")
    parser.add_argument("--repair", default="none", choices=("none", "tjunctions"))
    parser.add_argument("--budgets", default="0.25")
    parser.add_argument("--frames", type=int, default=80)
    parser.add_argument("--cameras", type=int, default=300)
    parser.add_argument("--cache", default=os.path.join(os.environ.get("TMPDIR", "/tmp"),
                                                        "vismobile-pvs-bytes"))
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--power", type=float, default=POWER,
                        help="cells' volumes raised to it to weigh merges (pvs_coarsen.fit)")
    parser.add_argument("--uniform", type=int, default=0,
                        help="also sent from this many cameras drawn uniformly by volume")
    parser.add_argument("--sent-frames", type=int, default=None,
                        help="path frames for the sent ratios (0: every frame; default --frames)")
    parser.add_argument("--no-fill", action="store_true",
                        help="merge the sets as baked, free bits not filled (fit's fill=False)")
    parser.add_argument("--default", action="store_true",
                        help="measure the default bake (budget=0.25), baked here (docstring)")
    args = parser.parse_args(argv)
    if args.default:
        dropped = sum(run_default(w.strip(), args.repair, args.frames, args.cameras, args.jobs,
                                  args.sent_frames)
                      for w in args.worlds.split(",") if w.strip())
        return 1 if dropped else 0
    budgets = [float(b) for b in args.budgets.split(",") if b]
    dropped = sum(run(w.strip(), args.repair, budgets, args.frames, args.cameras, args.cache,
                      args.jobs, args.power, args.uniform, args.sent_frames, not args.no_fill)
                  for w in args.worlds.split(",") if w.strip())
    return 1 if dropped else 0


if __name__ == "__main__":
    sys.exit(main())

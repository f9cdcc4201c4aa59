"""PVS benchmark (issue 29): bake time, size, and what `pvs` saves and drops, per world.

    .venv/bin/python tools/bench_pvs.py [--worlds w1,w2] [--frames 40] [--random 2000]
                                        [--sampled 4,16 [--only-sampled]]
                                        [--repair tjunctions] [--timing-frames 150]
                                        [--structure bsp] [--budget none]

Per world: the --structure (default portal:2; any kind in the CLI grammar) with
pvs=conservative at --budget (default: the bake's default, 0.25 of the OBJ; none: the exact
sets; partition/pvs_coarsen.py); bake seconds (of which coarsening); the PVS's bytes
in the .vmp (file with minus file without) against the OBJ; the mean share of the world in a
cell's set; along the world's thesis path (--frames evenly spaced frames) the triangles sent by
vfc+tbfc and pvs+vfc+tbfc and the frames that fell back; dropped triangles (pvs+vfc against the
item buffer without back-face culling) on those frames and on --random cameras inside random
view cells (a quarter each uniform, on a face, an edge, a corner; pitch +-89, fov 10-120) in
float64, float32 and fixed16.16 (cycled); on W2, pvs+vfc (the fused call and the staged
path) against vfc cull time, with and without tbfc, interleaved, medians over --timing-frames
path frames after a warm-up, and a frame whose set is not cached (w2_timing). With
--sampled, for each N the aggressive sampled PVS
(render/pvs_sampled.py) on the same cells: bake seconds, sent by pvs+vfc+tbfc against
vfc+tbfc, and its misses along the path (visible triangles and pixels of the unculled item
buffer that pvs+vfc dropped, as a share of the visible pixels).
"""
from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from vismobile.culling import Culler, device_options  # noqa: E402
from vismobile.device.profile import get_profile  # noqa: E402
from vismobile.partition import partition, save_partition  # noqa: E402
from vismobile.partition.pvs import bake  # noqa: E402
from vismobile.partition.pvs_coarsen import budget_param  # noqa: E402
from vismobile.partition.pvs_codec import cell_sizes, decode  # noqa: E402
from vismobile.render import SENTINEL, item_buffer  # noqa: E402
from vismobile.scenes import build_world  # noqa: E402
from vismobile.world.camera import Camera  # noqa: E402
from vismobile.world.trajectory import Trajectory  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
PROFILE = get_profile("ipaq-hx2490b")
MODES = ("float64", "float32", "fixed16.16")


def shown(world, cam, profile):
    ids = np.unique(item_buffer(world, None, cam, profile, cull_back=False))
    return ids[ids != SENTINEL].astype(np.int64)


def in_cell_cameras(part, count, seed):
    rng = np.random.default_rng(seed)
    boxes = part.extras["pvs_cells"]
    for i in range(count):
        lo, hi = boxes[rng.integers(len(boxes))]
        t = rng.uniform(0, 1, 3)
        snap = rng.permutation(3)[:i % 4]
        t[snap] = rng.integers(0, 2, len(snap))
        yield Camera(lo + t * (hi - lo), yaw=rng.uniform(0, 360), pitch=rng.uniform(-89, 89),
                     fov=rng.uniform(10, 120), aspect=PROFILE.aspect)


def random_checks(part, world, cameras) -> tuple:
    """(used, dropped): each camera culled by pvs+vfc in the next of MODES in turn; how many
    used the PVS, and the triangles lost against that mode's item buffer."""
    cullers = {m: Culler(part, "pvs+vfc", **({"arithmetic": "float64"} if m == "float64"
                                               else device_options(get_profile(PROFILE, m))))
               for m in MODES}
    used = dropped = 0
    for i, cam in enumerate(cameras):
        mode = MODES[i % 3]
        profile = PROFILE if mode == "float64" else get_profile(PROFILE, mode)
        r = cullers[mode].cull(cam)
        used += "pvs.fallbacks" not in r.stats
        dropped += len(np.setdiff1d(shown(world, cam, profile), r.triangles))
    return used, dropped


def sampled(name, world, part, traj, picks, counts):
    """One line per sample count: bake time, sent ratio, misses along the path."""
    from vismobile.render.pvs_sampled import bake_sampled

    base = Culler(part, "vfc+tbfc")
    for n in counts:
        extras, stats = bake_sampled(part, n, PROFILE, seed=0)
        baked = partition(world, "portal", depth=2)
        baked.extras.update(extras)
        baked.params["pvs"] = f"sampled:{n}"
        pvs, check = Culler(baked, "pvs+vfc+tbfc"), Culler(baked, "pvs+vfc")
        sent_base = sent = missed = missed_px = pixels = visible = 0
        for f in picks:
            cam = traj.camera(int(f), PROFILE.aspect)
            sent_base += len(base.cull(cam).triangles)
            sent += len(pvs.cull(cam).triangles)
            buffer = item_buffer(world, None, cam, PROFILE, cull_back=False)
            shown_ids = np.unique(buffer)
            shown_ids = shown_ids[shown_ids != SENTINEL].astype(np.int64)
            kept = check.cull(cam).triangles
            lost = np.setdiff1d(shown_ids, kept)
            missed += len(lost)
            visible += len(shown_ids)
            pixels += int((buffer != SENTINEL).sum())
            missed_px += int(np.isin(buffer, lost).sum())
        print(f"{name} sampled:{n}: bake {stats['seconds']:.1f} s ({stats['renders']} renders), "
              f"pvs+vfc+tbfc {sent} vs vfc+tbfc {sent_base} ({sent / max(sent_base, 1):.3f}x) | "
              f"path misses: {missed} of {visible} visible triangles, {missed_px} of {pixels} "
              f"pixels ({100 * missed_px / max(pixels, 1):.3f}%)", flush=True)


def w2_timing(part, traj, count, reps=3, misses=20):
    """One line: vfc, pvs+vfc (the fused call, culling/pvs_frame.py) and pvs+vfc staged
    (pvs={"fuse": False}: pvs's nodes walked by vfc, then the per-triangle filter), and the
    same three with tbfc; count path frames, each culled by every row in turn, reps times
    after a warm-up (every combination of cells cached); medians and ratios to vfc (vfc+tbfc),
    mean sent and nodes visited. Then the median time of a frame whose cells' set is not
    cached (the gather, partition/pvs_codec.py) over `misses` frames."""
    rows = {"vfc": ("vfc", {}), "pvs+vfc": ("pvs+vfc", {}),
            "staged": ("pvs+vfc", {"pvs": {"fuse": False}}), "vfc+tbfc": ("vfc+tbfc", {}),
            "pvs+vfc+tbfc": ("pvs+vfc+tbfc", {}),
            "staged+tbfc": ("pvs+vfc+tbfc", {"pvs": {"fuse": False}})}
    cullers = {k: Culler(part, stages, **options) for k, (stages, options) in rows.items()}
    cams = [traj.camera(int(f), PROFILE.aspect) for f in
            np.linspace(0, len(traj) - 1, count).astype(int)]
    for c in cams:  # warm-up: compiled, every combination of cells decoded
        for culler in cullers.values():
            culler.cull(c)
    times = {k: [] for k in rows}
    sent = {k: 0 for k in rows}
    visited = {k: 0 for k in rows}
    for rep in range(reps):
        for c in cams:
            for k, culler in cullers.items():
                t = time.perf_counter()
                result = culler.cull(c)
                times[k].append(time.perf_counter() - t)
                if rep == 0:
                    sent[k] += len(result.triangles)
                    visited[k] += result.stats["nodes_visited"]
    median = {k: 1e3 * np.median(v) for k, v in times.items()}
    parts = []
    for k in rows:
        base = "vfc+tbfc" if "tbfc" in k else "vfc"
        parts.append(f"{k} {median[k]:.4f} ms ({median[k] / median[base]:.3f}x, sent "
                     f"{sent[k] / count:.1f}, visited {visited[k] / count:.1f})")
    stage = cullers["pvs+vfc"].stages[0]
    missed = []
    for c in cams[:: max(1, count // misses)][:misses]:
        stage.forget()
        t = time.perf_counter()
        cullers["pvs+vfc"].cull(c)
        missed.append(time.perf_counter() - t)
    return (f"W2 cull ms median over {count} path frames x {reps}, interleaved: "
            + "; ".join(parts) + f"; a frame whose set is not cached {1e3 * np.median(missed):.1f}"
            f" ms (median of {len(missed)})")


def run(name, frames, randoms, counts=(), only_sampled=False, jobs=1, repair="none",
        timing_frames=150, structure="portal:2", budget=None):
    world = build_world(name)
    if repair == "tjunctions":  # the bake then seals the thin cells, no crack portals
        from vismobile.world.tjunctions import repair_tjunctions

        world, done = repair_tjunctions(world)
        print(f"{name}: --repair tjunctions: {done.junctions} junctions, {done.split} "
              f"triangles split, {world.triangle_count} triangles", flush=True)
    if only_sampled:  # on portal:2's cells, whatever --structure says
        traj = Trajectory.load(ROOT / "trajectories" / ("outdoor.csv" if name in ("w5", "w6")
                                                        else "indoor.csv"))
        picks = np.linspace(0, len(traj) - 1, frames).astype(int)
        return sampled(name, world, partition(world, "portal", depth=2), traj, picks, counts)
    part = partition(world, structure)
    part.params["budget"] = budget_param(budget)  # as partition(..., pvs=, budget=) sets it
    extras, stats = bake(part, jobs=jobs)
    with tempfile.TemporaryDirectory() as tmp:
        save_partition(part, Path(tmp) / "a.vmp")
        before = os.path.getsize(Path(tmp) / "a.vmp")
        part.extras.update(extras)
        part.params["pvs"] = "conservative"
        save_partition(part, Path(tmp) / "b.vmp")
        pvs_bytes = os.path.getsize(Path(tmp) / "b.vmp") - before
    obj = os.path.getsize(ROOT / "worlds" / f"{name}.obj")
    cells = len(extras["pvs_cells"])
    share = np.mean(cell_sizes(*decode(extras, cells, world.triangle_count), cells)) \
        / world.triangle_count
    traj = Trajectory.load(ROOT / "trajectories" / ("outdoor.csv" if name in ("w5", "w6")
                                                    else "indoor.csv"))
    picks = np.linspace(0, len(traj) - 1, frames).astype(int)
    base, pvs, check = (Culler(part, s) for s in ("vfc+tbfc", "pvs+vfc+tbfc", "pvs+vfc"))
    sent_base = sent_pvs = fallbacks = dropped_path = 0
    for f in picks:
        cam = traj.camera(int(f), PROFILE.aspect)
        sent_base += len(base.cull(cam).triangles)
        r = pvs.cull(cam)
        sent_pvs += len(r.triangles)
        fallbacks += r.stats.get("pvs.fallbacks", 0)
        dropped_path += len(np.setdiff1d(shown(world, cam, PROFILE), check.cull(cam).triangles))
    used, dropped_random = random_checks(part, world, in_cell_cameras(part, randoms, 1))
    timing = f" | {w2_timing(part, traj, timing_frames)}" if name == "w2" else ""
    print(f"{name} {structure},budget={part.params['budget']}: cells {stats['cells']}, bake "
          f"{stats['seconds']:.1f} s (coarsening {stats['budget']['seconds']:.1f} s, overflowed "
          f"{stats.get('overflowed', 0)}), PVS {pvs_bytes / 1024:.0f} KB = "
          f"{pvs_bytes / obj:.3f}x OBJ ({pvs_bytes / stats['cells']:.0f} B/cell), mean set "
          f"{100 * share:.1f}% of the world | path {frames} frames: vfc+tbfc {sent_base}, "
          f"pvs+vfc+tbfc {sent_pvs} ({sent_pvs / max(sent_base, 1):.3f}x), fallbacks "
          f"{fallbacks}, dropped {dropped_path} | random {randoms} in-cell cameras "
          f"({used} used the PVS): dropped {dropped_random}{timing}", flush=True)
    if counts:
        sampled(name, world, partition(world, "portal", depth=2), traj, picks, counts)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--worlds", default="w1,w2,w3,w4,w5,w6")
    parser.add_argument("--frames", type=int, default=40)
    parser.add_argument("--random", type=int, default=2000)
    parser.add_argument("--sampled", default="", help="sample counts, e.g. 4,16,64")
    parser.add_argument("--only-sampled", action="store_true")
    parser.add_argument("--jobs", type=int, default=1, help="bake processes")
    parser.add_argument("--repair", choices=("none", "tjunctions"), default="none",
                        help="repair the world first (world/tjunctions.py)")
    parser.add_argument("--timing-frames", type=int, default=150,
                        help="W2 path frames timed (vfc against pvs+vfc)")
    parser.add_argument("--structure", default="portal:2",
                        help="the structure the PVS is baked on (partition's grammar)")
    parser.add_argument("--budget", default=None,
                        help="budget=F of the bake (default the bake's, 0.25; none: exact)")
    args = parser.parse_args()
    budget_param(args.budget)  # a bad value refused before the first bake
    counts = [int(n) for n in args.sampled.split(",") if n]
    for name in args.worlds.split(","):
        run(name.strip(), args.frames, args.random, counts, args.only_sampled, args.jobs,
            args.repair, args.timing_frames, args.structure, args.budget)


if __name__ == "__main__":
    main()

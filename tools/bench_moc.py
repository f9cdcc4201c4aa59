"""`vfc,occlusion,tbfc` with the profile's screen against Intel's Masked Occlusion Culling driven
hierarchically (tools/moc_peer.py), for tools/bench_peers.py --moc (issue 32).

Each world: W2 (octree 5) or W2 tiled n x n (tools/tile_world.py, octree 5 + ceil(log2 n), the
indoor path moved to the centre tile), `frames` consecutive frames of the indoor path from
`start`. Per frame, in one process: our Culler, MOC with the frustum's triangles as occluders
and MOC with the occluders our stage rasterised that frame, in an order that alternates frame by
frame (ours first, then MOC first), and then the item buffer of the whole world with back faces
culled (the truth, and a render between culls as in a real frame). Times are medians over the
frames after a warm-up (numba compiled, MOC built); ours is the whole Culler.cull, MOC's the sum
of its C++ calls (walks, render, triangle tests; MOC+driver adds the numpy work around them),
by wall clock; the thread's CPU time of each whole call is given too (on a loaded machine a
preempted call's wall time counts the other processes' slices: compare the CPU columns).
"""
from __future__ import annotations

import os
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tools"))

from moc_peer import MocCuller, unavailable  # noqa: E402
from vismobile.culling import Culler, device_options  # noqa: E402
from vismobile.partition import partition  # noqa: E402
from vismobile.device.profile import get_profile  # noqa: E402
from vismobile.render.item_buffer import item_buffer_renderer  # noqa: E402
from vismobile.scenes import build_world  # noqa: E402
from vismobile.world.trajectory import Trajectory  # noqa: E402

STEPS = ("walk_frustum", "render", "walk", "triangles")
WARMUP = 5


def world_and_cameras(name, start, frames, profile):
    """(world, octree depth, cameras) for "w2" or "w2xN"."""
    traj = Trajectory.load(ROOT / "trajectories" / "indoor.csv")
    picks = [f % len(traj) for f in range(start, start + frames)]
    cameras = [traj.camera(f, profile.aspect) for f in picks]
    if name == "w2":
        return build_world("w2"), 5, cameras
    if not name.startswith("w2x") or not name[3:].isdigit() or int(name[3:]) < 1:
        raise ValueError(f"unknown world {name!r}: w2 or w2xN (W2 tiled N x N)")
    from tile_world import centre_offset, tiled_w2

    n = int(name[3:])
    shift = centre_offset(n)
    cameras = [c.with_(position=tuple(np.asarray(c.position) + shift)) for c in cameras]
    return tiled_w2(n), 5 + int(np.ceil(np.log2(n))), cameras


def compare(world, tree, cameras, profile) -> dict:
    """Per method: times (s), C++ times, sent counts, drops; plus visible counts."""
    ours = Culler(tree, "vfc,occlusion,tbfc", **device_options(profile))
    stage = next(s for s in ours.stages if s.name == "occlusion")
    width, height = profile.resolution
    mocs = {"MOC, frustum occluders": MocCuller(ours.tree, width, height, cameras[0].near),
            "MOC, our occluders": MocCuller(ours.tree, width, height, cameras[0].near, "ours")}
    renderer = item_buffer_renderer(world, profile)
    everything = np.arange(world.triangle_count)
    names = ["ours"] + list(mocs)
    rec = {n: {"t": [], "cpu": [], "cpp": [], "sent": [], "drop": [], "steps": {s: [] for s in STEPS},
               "occluders": [], "tested": []} for n in names}
    visible = []
    for i, cam in enumerate(cameras[:WARMUP] + cameras):
        order = names if i % 2 == 0 else names[1:2] + names[:1] + names[2:]
        sent = {}
        for n in order:
            t, c = time.perf_counter(), time.thread_time()
            if n == "ours":
                result = ours.cull(cam)
                took, cpu = time.perf_counter() - t, time.thread_time() - c
                sent[n] = result.triangles
                occluders = np.array(stage.frame_occluders, dtype=np.int64)
                cpp = took
            else:
                moc = mocs[n]
                sent[n] = moc.cull(cam, occluders if moc.occluders == "ours" else None)
                took, cpu = time.perf_counter() - t, time.thread_time() - c
                cpp = sum(moc.times[s] for s in STEPS)
            if i >= WARMUP:
                rec[n]["t"].append(took)
                rec[n]["cpu"].append(cpu)
                rec[n]["cpp"].append(cpp)
                if n != "ours":
                    for s in STEPS:
                        rec[n]["steps"][s].append(mocs[n].times[s])
                    rec[n]["occluders"].append(mocs[n].times["occluders"])
                    rec[n]["tested"].append(mocs[n].times["tested"])
                else:
                    rec[n]["occluders"].append(len(occluders))
                    rec[n]["tested"].append(result.stats.get("triangles_tested", 0))
        truth = renderer.visible(everything, cam, cull_back=True)
        if i >= WARMUP:
            visible.append(len(truth))
            for n in names:
                rec[n]["sent"].append(len(sent[n]))
                rec[n]["drop"].append(len(np.setdiff1d(truth, sent[n])))
    return {"rec": rec, "visible": visible,
            "impl": next(iter(mocs.values())).moc.implementation}


def rows(label, triangles, data) -> list:
    rec, visible = data["rec"], data["visible"]
    shown = float(np.mean(visible))
    lines = []
    base, base_cpu = np.array(rec["ours"]["t"]), np.array(rec["ours"]["cpu"])
    for n, r in rec.items():
        t, cpp = np.array(r["t"]) * 1e3, np.array(r["cpp"]) * 1e3
        paired = float(np.median(base / np.array(r["t"]))) if n != "ours" else 1.0
        cpu = np.array(r["cpu"])
        paired_cpu = float(np.median(base_cpu / cpu)) if n != "ours" else 1.0
        drops = np.array(r["drop"])
        lines.append(
            f"| {label} ({triangles:,}) | {n} | {np.median(cpp):.2f} | {np.median(t):.2f} | "
            f"{np.percentile(t, 90):.2f} | {t.max():.1f} | {paired:.2f} | "
            f"{1e3 * np.median(cpu):.2f} | {paired_cpu:.2f} | "
            f"{np.mean(r['sent']):,.0f} | {shown:,.0f} | {np.mean(r['sent']) / max(shown, 1):.2f} | "
            f"{int((drops > 0).sum())} of {len(drops)} | {int(drops.sum())} | "
            f"{np.mean(r['occluders']):,.0f} | {np.mean(r['tested']):,.0f} |")
    return lines


def steps(label, data) -> list:
    out = []
    ours = float(np.median(data["rec"]["ours"]["t"]))
    for n, r in data["rec"].items():
        if n == "ours":
            continue
        parts = ", ".join(f"{s} {1e3 * np.median(r['steps'][s]):.3f}" for s in STEPS)
        out.append(f"- {label}, {n}: median ms per C++ step: {parts}; ours' median / its "
                   f"median: {ours / np.median(r['cpp']):.2f} (C++), "
                   f"{ours / np.median(r['t']):.2f} (with driver)")
    return out


def moc_main(worlds: str, start: int, frames: int, out: Path) -> int:
    reason = unavailable()
    if reason:
        print(f"bench_peers --moc: skipping the MOC rows: {reason}", file=sys.stderr)
        return 0
    profile = get_profile("ipaq-hx2490b")
    load0 = os.getloadavg()
    table = ["| world (triangles) | method | median ms (ours: cull; MOC: C++) | median ms "
             "(MOC: + driver) | p90 ms | max ms | ours' time / its time (per frame, median) "
             "| thread CPU ms, median (MOC: + driver) | ours' CPU / its CPU (per frame, median) "
             "| sent | visible | sent / visible | frames dropping | triangles dropped "
             "| occluders | triangles tested |",
             "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    notes, impl = [], "?"
    for name in [w for w in worlds.split(",") if w]:
        try:
            world, depth, cameras = world_and_cameras(name, start, frames, profile)
        except ValueError as error:
            print(f"bench_peers --moc: {error}", file=sys.stderr)
            return 2
        t = time.perf_counter()
        tree = partition(world, "octree", depth=depth)
        built = time.perf_counter() - t
        data = compare(world, tree, cameras, profile)
        table += rows(name, world.triangle_count, data)
        notes += steps(name, data)
        notes.append(f"- {name}: octree {depth} built in {built:.0f} s")
        impl = data["impl"]
        print("\n".join(table[-3:]), flush=True)
        del world, tree, data
    load1 = os.getloadavg()
    lines = [f"## Occlusion against Intel MOC ({impl}), {frames} consecutive indoor frames "
             f"from {start}, {profile.resolution[0]}x{profile.resolution[1]}, one thread", "",
             f"Load average {load0[0]:.1f} at the start, {load1[0]:.1f} at the end "
             f"({os.cpu_count()} cores).", ""] + table + [""] + notes
    print("\n".join(lines))
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_suffix(out.suffix + ".tmp")
    tmp.write_text("\n".join(lines) + "\n")
    tmp.replace(out)
    return 0

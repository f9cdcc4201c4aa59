"""Culling benchmark: cull time of vfc+cbfc against brute-force per-triangle frustum culling in
the same run, triangles sent with occlusion / portals against the item buffer's visible count,
and per-stage counters for every stage, on a thesis world along a trajectory.

    .venv/bin/python tools/bench_cull.py [--world w2] [--depth 5] [--frames 120]
        [--trajectory trajectories/indoor.csv] [--out runs/bench_cull.md]

Prints a markdown report. Times are medians over the sampled frames (host-dependent); the
counters and triangle counts are hardware-independent.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from vismobile.culling import BACKFACE_STAGES, Culler  # noqa: E402
from vismobile.culling.backface import thesis_region_count  # noqa: E402
from vismobile.geometry.sphere_regions import direction_regions  # noqa: E402
from vismobile.partition import partition  # noqa: E402
from vismobile.profile import get_profile  # noqa: E402
from vismobile.render import SENTINEL, item_buffer  # noqa: E402
from vismobile.scenes import build_world  # noqa: E402
from vismobile.trajectory import Trajectory  # noqa: E402

# Stage combinations, optionally "stages@preset" with the option presets below.
COMBOS = ("vfc", "vfc_thesis", "vfc,cbfc", "vfc,cone", "vfc,tbfc", "vfc,bfc,cbfc,cone",
          "vfc,occlusion_thesis", "vfc,occlusion", "vfc,occlusion,cbfc", "vfc,occlusion,tbfc",
          "vfc,occlusion,cbfc,cone", "vfc,occlusion,cbfc,cone,tbfc",
          "vfc,occlusion@self", "vfc,occlusion,tbfc@self", "vfc,occlusion@screen",
          "vfc,occlusion,tbfc@screen", "vfc,occlusion,tbfc@screen+self",
          "vfc,occlusion,cbfc,cone,tbfc@screen")
PORTAL_COMBOS = ("portals", "portals,occlusion", "portals,occlusion,tbfc",
                 "portals,occlusion,tbfc@screen")
# Option presets: "screen" = occlusion also drops triangles that cover no pixel centre of the
# profile's screen (safe at that resolution only); "self" = objects' near sides occlude too.
PRESETS = {"screen": lambda profile: {"screen": profile.resolution},
           "self": lambda profile: {"self_occluders": 32}}


def combo_options(combo, profile) -> tuple:
    """(stages string, Culler keyword options) of a "stages@preset+preset" combo."""
    stages, _, presets = combo.partition("@")
    occlusion = {}
    for name in filter(None, presets.split("+")):
        occlusion.update(PRESETS[name](profile))
    return stages, ({"occlusion": occlusion} if occlusion else {})


def brute_force_frustum(corners, planes):
    """(T,) bool: triangle not wholly outside one frustum plane (numpy, every triangle)."""
    dist = corners @ planes[:, :3].T + planes[:, 3]  # (T, 3, 6)
    return ~(dist < 0).all(axis=1).any(axis=1)


def median_ms(fn, cameras, repeat=3):
    """Median over cameras of the best of `repeat` runs, in ms."""
    times = []
    for cam in cameras:
        best = np.inf
        for _ in range(repeat):
            t = time.perf_counter()
            fn(cam)
            best = min(best, time.perf_counter() - t)
        times.append(best * 1e3)
    return float(np.median(times))


def visible(world, cam, profile, cull_back):
    ids = np.unique(item_buffer(world, None, cam, profile, cull_back=cull_back))
    return ids[ids != SENTINEL]


def thesis_cbfc_errors(world, cam, corners):
    """Front-facing triangles in the frustum that the thesis's 2D rule would drop."""
    n = thesis_region_count(cam.fov)
    normal_region = direction_regions(world.normals, n, 1)
    view_region = direction_regions(cam.forward[None], n, 1)[0]
    dropped = normal_region == view_region
    facing = np.einsum("ij,ij->i", world.normals, cam.eye - corners[:, 0]) > 0
    inside = brute_force_frustum(corners, cam.frustum_planes())
    return int((dropped & facing & inside).sum()), int(dropped.sum())


def run_combos(part, combos, cameras, world, profile, truth):
    rows = []
    for combo in combos:
        stages, options = combo_options(combo, profile)
        culler = Culler(part, stages, **options)
        back = any(s in BACKFACE_STAGES for s in culler.names)
        stats, sent, ratios, missed = {}, [], [], 0
        for i, cam in enumerate(cameras):
            result = culler.cull(cam)
            for k, v in result.stats.items():
                stats[k] = stats.get(k, 0) + v
            sent.append(len(result.triangles))
            vis = truth[i, back]
            ratios.append(len(result.triangles) / max(len(vis), 1))
            missed += len(np.setdiff1d(vis, result.triangles))
        ms = median_ms(culler.cull, cameras)
        mean = {k: v / len(cameras) for k, v in stats.items()}
        shown = np.mean([len(truth[i, back]) for i in range(len(cameras))])
        rows.append((part.kind, combo, ms, float(np.mean(sent)), float(np.mean(ratios)),
                     float(np.mean(sent) / max(shown, 1)), missed, mean))
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--world", default="w2")
    ap.add_argument("--depth", type=int, default=5)
    ap.add_argument("--portal-depth", type=int, default=2)
    ap.add_argument("--trajectory", default=str(ROOT / "trajectories" / "indoor.csv"))
    ap.add_argument("--frames", type=int, default=120, help="frames sampled evenly")
    ap.add_argument("--profile", default="ipaq-hx2490b")
    ap.add_argument("--out", default=None, help="also write the report here")
    args = ap.parse_args(argv)

    profile = get_profile(args.profile)
    world = build_world(args.world)
    traj = Trajectory.load(args.trajectory)
    frames = np.unique(np.linspace(0, len(traj) - 1, args.frames).astype(int))
    cameras = [traj.camera(int(f), profile.aspect) for f in frames]
    t = time.perf_counter()
    octree = partition(world, "octree", depth=args.depth)
    build_s = time.perf_counter() - t
    portal = partition(world, "portal", depth=args.portal_depth)

    truth = {}
    for i, cam in enumerate(cameras):
        for back in (False, True):
            truth[i, back] = visible(world, cam, profile, back)
    mean_visible = float(np.mean([len(truth[i, False]) for i in range(len(cameras))]))

    # Cull time: vfc+cbfc against brute force, same frames, same process.
    corners = world.corners
    culler = Culler(octree, "vfc,cbfc")
    fast = median_ms(culler.cull, cameras)
    brute = median_ms(lambda cam: np.flatnonzero(brute_force_frustum(corners, cam.frustum_planes())),
                      cameras)
    in_frustum = float(np.mean([brute_force_frustum(corners, c.frustum_planes()).sum()
                                for c in cameras]))
    thesis_err = [thesis_cbfc_errors(world, c, corners) for c in cameras]

    rows = run_combos(octree, COMBOS, cameras, world, profile, truth)
    rows += run_combos(portal, PORTAL_COMBOS, cameras, world, profile, truth)

    out = [f"# Culling benchmark: {args.world.upper()} ({world.triangle_count} triangles), "
           f"octree depth {args.depth} ({octree.node_count} nodes, built in {build_s:.2f} s), "
           f"portal octree depth {args.portal_depth}, {len(cameras)} frames of "
           f"{Path(args.trajectory).name}", "",
           "| measure | value |", "| --- | --- |",
           f"| median cull time vfc+cbfc (ms) | {fast:.3f} |",
           f"| median brute-force per-triangle frustum test (ms) | {brute:.3f} |",
           f"| speed-up | {brute / fast:.1f}x |",
           f"| mean triangles in frustum (brute force) | {in_frustum:.0f} |",
           f"| mean visible triangles (item buffer) | {mean_visible:.0f} |",
           f"| thesis 2D cbfc: front-facing in-frustum triangles it would drop, mean per frame "
           f"| {np.mean([e for e, _ in thesis_err]):.1f} (of {np.mean([d for _, d in thesis_err]):.0f}"
           f" dropped) |", "",
           "Stages `@screen`: occlusion also drops triangles covering no pixel centre of the "
           f"{profile.width}x{profile.height} screen; `@self`: objects' near sides occlude too "
           "(32 per frame). Visible = item buffer, back-face culled for bfc/cbfc/cone/tbfc.", "",
           "| structure | stages | median ms | mean sent | mean of sent / visible | "
           "mean sent / mean visible | visible dropped (all frames) |",
           "| --- | --- | --- | --- | --- | --- | --- |"]
    for kind, combo, ms, sent, ratio, ratio_of_means, missed, _ in rows:
        out.append(f"| {kind} | {combo} | {ms:.3f} | {sent:.0f} | {ratio:.2f} | "
                   f"{ratio_of_means:.2f} | {missed} |")
    out += ["", "Mean per-frame counters:", "", "| structure | stages | counters |",
            "| --- | --- | --- |"]
    for kind, combo, *_, mean in rows:
        text = ", ".join(f"{k} {v:.1f}" for k, v in sorted(mean.items()))
        out.append(f"| {kind} | {combo} | {text} |")
    report = "\n".join(out) + "\n"
    print(report)
    if args.out:
        from vismobile.world import atomic_write_bytes

        Path(args.out).parent.mkdir(parents=True, exist_ok=True)
        atomic_write_bytes(args.out, report.encode())
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""Culling benchmark: cull time of vfc+cbfc against brute-force per-triangle frustum culling in
the same run, triangles sent with occlusion / portals against the item buffer's visible count,
per-stage counters for every stage, the exact visible set's other routes (the item buffer of the
whole world rendered and read back, Open3D ray casting, brute force) against vfc,occlusion,tbfc,
and the tiled W2 worlds (tools/tile_world.py) for scaling, on a thesis world along a trajectory.

    .venv/bin/python tools/bench_cull.py [--world w2] [--depth 5] [--frames 120]
        [--trajectory trajectories/indoor.csv] [--tiled 3,7] [--out runs/bench_cull.md]

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
from vismobile.errors import VisMobileError  # noqa: E402
from vismobile.render.item_buffer import item_buffer_renderer  # noqa: E402
from vismobile.culling.backface import thesis_region_count  # noqa: E402
from vismobile.geometry.sphere_regions import direction_regions  # noqa: E402
from vismobile.partition import partition  # noqa: E402
from vismobile.device.profile import get_profile  # noqa: E402
from vismobile.render import SENTINEL, item_buffer  # noqa: E402
from vismobile.scenes import build_world  # noqa: E402
from vismobile.world.trajectory import Trajectory  # noqa: E402

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
# profile's screen (safe at that resolution only); "self" = objects' near sides occlude too;
# "whole" = the first round's occluder candidates from the whole frustum (not the near shells).
PRESETS = {"screen": lambda profile: {"screen": profile.resolution},
           "self": lambda profile: {"self_occluders": 512},
           "whole": lambda profile: {"first_candidates": 0}}


def combo_options(combo, profile) -> tuple:
    """(stages string, Culler keyword options) of a "stages@preset+preset" combo: "screen"
    goes to occlusion and horizon (whichever run), the others to occlusion."""
    stages, _, presets = combo.partition("@")
    options = {}
    for name in filter(None, presets.split("+")):
        targets = ("occlusion", "horizon") if name == "screen" else ("occlusion",)
        for stage in targets:
            if stage in stages.split(","):
                options.setdefault(stage, {}).update(PRESETS[name](profile))
    return stages, options


def brute_force_frustum(corners, planes):
    """(T,) bool: triangle not wholly outside one frustum plane (numpy, every triangle)."""
    dist = corners @ planes[:, :3].T + planes[:, 3]  # (T, 3, 6)
    return ~(dist < 0).all(axis=1).any(axis=1)


def outcode_frustum(vertices, triangles, planes):
    """(T,) bool: the fastest plain numpy frustum test, per-vertex outcodes: each vertex once
    against the six planes (one bit each), a triangle is out when its three codes share a bit."""
    # Written out, not `vertices @ planes`: BLAS's threads contend with numba's and llvmpipe's
    # in this process (a matmul measured 44 ms here against 1 ms alone).
    outside = (vertices[:, :1] * planes[:, 0] + vertices[:, 1:2] * planes[:, 1]
               + vertices[:, 2:] * planes[:, 2] + planes[:, 3]) < 0  # (V, 6)
    codes = outside.astype(np.uint8) @ (1 << np.arange(6, dtype=np.uint8))
    corner = codes[triangles]
    return (corner[:, 0] & corner[:, 1] & corner[:, 2]) == 0


def frame_ms(fn, cameras, repeat=3) -> np.ndarray:
    """(F,) per camera the best of `repeat` runs, in ms."""
    times = []
    for cam in cameras:
        best = np.inf
        for _ in range(repeat):
            t = time.perf_counter()
            fn(cam)
            best = min(best, time.perf_counter() - t)
        times.append(best * 1e3)
    return np.array(times)


def median_ms(fn, cameras, repeat=3):
    """Median over cameras of the best of `repeat` runs, in ms."""
    return float(np.median(frame_ms(fn, cameras, repeat)))


def exact_routes(world, profile, cameras, truth, octree) -> list:
    """Rows (route, median ms, mean ids, mean ids / mean visible) of the ways to the visible set
    or a superset in the same run: vfc,occlusion,tbfc (with and without the screen option),
    the item buffer of the whole world (draw + readback + distinct ids), Open3D ray casting
    (one ray per pixel centre, scene built once), brute-force per-triangle frustum test."""
    from vismobile.open3d_import import open3d
    from vismobile.study.groundtruth import camera_rays

    rows = []
    shown = float(np.mean([len(truth[i, True]) for i in range(len(cameras))]))
    for label, options in (("vfc,occlusion,tbfc", {}),
                           ("vfc,occlusion,tbfc@screen",
                            {"occlusion": {"screen": profile.resolution}})):
        culler = Culler(octree, "vfc,occlusion,tbfc", **options)
        sent = [len(culler.cull(c).triangles) for c in cameras]
        rows.append((label, median_ms(culler.cull, cameras), float(np.mean(sent)),
                     float(np.mean(sent)) / max(shown, 1)))
    renderer = item_buffer_renderer(world, profile)
    every = np.arange(world.triangle_count)
    ids = [len(renderer.visible(every, c, cull_back=True)) for c in cameras]
    rows.append(("item buffer, whole world (draw + readback + distinct ids)",
                 median_ms(lambda c: renderer.visible(every, c, cull_back=True), cameras),
                 float(np.mean(ids)), float(np.mean(ids)) / max(shown, 1)))
    o3d = open3d()
    scene = o3d.t.geometry.RaycastingScene()
    scene.add_triangles(o3d.core.Tensor(world.vertices.astype(np.float32)),
                        o3d.core.Tensor(world.triangles.astype(np.uint32)))

    def cast(cam):
        origins, directions = camera_rays(cam, profile.width, profile.height)
        rays = np.concatenate([origins + cam.near * directions, directions], axis=1)
        hit = scene.cast_rays(o3d.core.Tensor(rays.astype(np.float32)))
        prim = hit["primitive_ids"].numpy()
        return np.unique(prim[np.isfinite(hit["t_hit"].numpy())])

    ids = [len(cast(c)) for c in cameras]
    rows.append(("Open3D ray casting (Embree), one ray per pixel", median_ms(cast, cameras),
                 float(np.mean(ids)), float(np.mean(ids)) / max(shown, 1)))
    corners = world.corners
    vertices, faces = world.vertices, world.triangles
    ids = [int(outcode_frustum(vertices, faces, c.frustum_planes()).sum()) for c in cameras]
    rows.append(("per-vertex outcodes against the frustum (numpy)",
                 median_ms(lambda c: np.flatnonzero(outcode_frustum(vertices, faces,
                                                                    c.frustum_planes())),
                           cameras), float(np.mean(ids)), float(np.mean(ids)) / max(shown, 1)))
    ids = [int(brute_force_frustum(corners, c.frustum_planes()).sum()) for c in cameras]
    rows.append(("brute force: every triangle against the frustum (numpy)",
                 median_ms(lambda c: np.flatnonzero(brute_force_frustum(corners,
                                                                        c.frustum_planes())),
                           cameras), float(np.mean(ids)), float(np.mean(ids)) / max(shown, 1)))
    return rows


TILED_COMBOS = ("vfc", "vfc,occlusion,tbfc", "vfc,occlusion,tbfc@screen")


def tiled_rows(sizes, base, traj, frames, profile, depth_of, saved=None,
               combos=TILED_COMBOS) -> list:
    """Rows (world, triangles, depth, build s, prepare s, stages, median ms, worst ms, mean sent,
    mean visible, sent / visible, dropped, mean nodes visited) on W2 tiled n x n, the trajectory on the centre tile. saved:
    None, or a .vmp path pattern with {n} and {depth}: the octree is loaded from it when the
    file exists (build s is then the load), else built in memory and saved there. combos:
    the stage combos run on each (--combos when given)."""
    from tile_world import centre_offset, tiled_w2

    from vismobile.partition import load_partition, save_partition

    rows = []
    for n in sizes:
        shift = centre_offset(n)
        cameras = [traj.camera(int(f), profile.aspect) for f in frames]
        cameras = [c.with_(position=tuple(np.asarray(c.position) + shift)) for c in cameras]
        depth = depth_of(n)
        path = Path(saved.format(n=n, depth=depth)) if saved else None
        t = time.perf_counter()
        if path is not None and path.exists():
            tree = load_partition(path)
            world = tree.world
            if world.triangle_count != n * n * base.triangle_count:
                raise ValueError(f"{path}: {world.triangle_count:,} triangles, not W2 tiled "
                                 f"{n} x {n} ({n * n * base.triangle_count:,})")
        else:
            world = tiled_w2(n, base)
            tree = partition(world, "octree", depth=depth)
            if path is not None:  # built once: the next run loads it
                path.parent.mkdir(parents=True, exist_ok=True)
                save_partition(tree, path)
        build_s = time.perf_counter() - t
        renderer = item_buffer_renderer(world, profile)
        truth = {}
        for combo in combos:
            stages, options = combo_options(combo, profile)
            back = any(s in BACKFACE_STAGES for s in stages.split(","))
            t = time.perf_counter()
            culler = Culler(tree, stages, **options)
            prepare_s = time.perf_counter() - t
            sent, shown, dropped, visited = [], [], 0, []
            for i, cam in enumerate(cameras):
                result = culler.cull(cam)
                if (i, back) not in truth:
                    truth[i, back] = renderer.visible(np.arange(world.triangle_count), cam,
                                                      cull_back=back)
                seen = truth[i, back]
                sent.append(len(result.triangles))
                shown.append(len(seen))
                dropped += len(np.setdiff1d(seen, result.triangles))
                visited.append(result.stats.get("nodes_visited", 0))
            times = frame_ms(culler.cull, cameras)  # the worst frame too: the tail counts
            rows.append((world.name, world.triangle_count, depth, build_s, prepare_s, combo,
                         float(np.median(times)), float(times.max()), float(np.mean(sent)),
                         float(np.mean(shown)), float(np.mean(sent) / max(np.mean(shown), 1)),
                         dropped, float(np.mean(visited))))
        del renderer, world, tree
    return rows


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


def structure_rows(world, cameras, stages="vfc", labels=("octree:3", "octree:4", "octree:5",
                                                           "octree:6", "kdtree")) -> list:
    """Rows (structure, nodes, build s, mean nodes visited, mean triangles sent, median ms) of
    one stage combination on several structures, the cameras of one run (--structures-vfc)."""
    from vismobile.partition.spec import parse_spec

    rows = []
    for label in labels:
        kind, params = parse_spec(label)
        t = time.perf_counter()
        part = partition(world, kind, **params)
        build_s = time.perf_counter() - t
        culler = Culler(part, stages)
        results = [culler.cull(cam) for cam in cameras]
        rows.append((label, part.node_count, build_s,
                     float(np.mean([r.stats["nodes_visited"] for r in results])),
                     float(np.mean([len(r.triangles) for r in results])),
                     median_ms(culler.cull, cameras)))
    return rows


HORIZON_COMBOS = ("vfc,tbfc", "vfc,horizon,tbfc", "vfc,occlusion,tbfc")
# --screen: both occlusion stages also drop triangles covering no pixel centre of the screen.
SCREEN_COMBOS = ("vfc,horizon,tbfc@screen", "vfc,occlusion,tbfc@screen")


def horizon_rows(world, cameras, labels, rounds=3, profile=None, screen=False) -> list:
    """Rows (structure, combo, mean sent, sent / vfc,tbfc's, median ms, ms / occlusion's,
    horizon nodes culled, horizon triangles culled, horizon triangles covering no centre per
    frame) of HORIZON_COMBOS (and SCREEN_COMBOS with screen, at profile's resolution) on each
    structure: every camera culled by each in turn (interleaved, the order rotated camera by
    camera), `rounds` times, after a warm-up pass."""
    from vismobile.partition.spec import parse_spec

    combos = HORIZON_COMBOS + (SCREEN_COMBOS if screen else ())
    rows = []
    for label in labels:
        kind, params = parse_spec(label)
        part = partition(world, kind, **params)
        cullers = {}
        for combo in combos:
            stages, options = combo_options(combo, profile)
            cullers[combo] = Culler(part, stages, **options)
        sent = {combo: [] for combo in combos}
        stats = {combo: {} for combo in combos}
        for cam in cameras:  # warm-up and counters
            for combo, culler in cullers.items():
                result = culler.cull(cam)
                sent[combo].append(len(result.triangles))
                for key, value in result.stats.items():
                    stats[combo][key] = stats[combo].get(key, 0) + value
        times = {combo: [] for combo in combos}
        for r in range(rounds):
            for i, cam in enumerate(cameras):
                # Rotated camera by camera: in a fixed order a cull's time depends on what ran
                # before it (W6 outdoor_pitched, octree 4: the horizon 0.69x occlusion's ms run
                # after another horizon cull, 0.87x right after occlusion, 0.92-0.95x rotated).
                k = (i + r) % len(combos)
                for combo in combos[k:] + combos[:k]:
                    start = time.perf_counter()
                    cullers[combo].cull(cam)
                    times[combo].append(time.perf_counter() - start)
        base = float(np.mean(sent["vfc,tbfc"]))
        occ_ms = float(np.median(times["vfc,occlusion,tbfc"])) * 1e3
        for combo in combos:
            ms = float(np.median(times[combo])) * 1e3
            st = stats[combo]
            rows.append((label, combo, float(np.mean(sent[combo])),
                         float(np.mean(sent[combo])) / max(base, 1), ms, ms / occ_ms,
                         st.get("horizon.nodes_culled", 0) / len(cameras),
                         st.get("horizon.triangles_culled", 0) / len(cameras),
                         st.get("horizon.triangles_subpixel", 0) / len(cameras)))
    return rows


def horizon_report(args, profile) -> int:
    """--horizon-structures: the horizon against vfc,tbfc and occlusion on --world's path (a
    thesis world and --trajectory, or "terrain": tools/horizon_objects.py's terrain world on its
    valley path)."""
    if args.world == "terrain":
        from horizon_objects import terrain_objects_world

        from vismobile.terrain.paths import path_cameras

        world, hm = terrain_objects_world()
        cameras = path_cameras(hm, "valley", "fast", frames=args.frames, eye_height=2.0,
                               aspect=profile.aspect, every=max(1, 240 // args.frames))
        path = "the valley path"
    else:
        world = build_world(args.world)
        traj = Trajectory.load(args.trajectory)
        frames = np.unique(np.linspace(0, len(traj) - 1, args.frames).astype(int))
        cameras = [traj.camera(int(f), profile.aspect) for f in frames]
        path = Path(args.trajectory).name
    rows = horizon_rows(world, cameras, args.horizon_structures.split(","), profile=profile,
                        screen=args.screen)
    print(f"horizon on {args.world.upper()} ({world.triangle_count:,} triangles), "
          f"{len(cameras)} frames of {path}, interleaved, medians of 3 rounds"
          f"{'; @screen: ' + 'x'.join(map(str, profile.resolution)) if args.screen else ''}"
          "\n\n| structure | stages | mean sent | sent / vfc,tbfc | median ms | "
          "ms / occlusion's | horizon nodes culled | horizon triangles culled | "
          "horizon no-centre culled |\n| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |")
    for label, combo, sent, ratio, ms, vs, nodes, tris, sub in rows:
        print(f"| {label} | {combo} | {sent:.1f} | {ratio:.3f} | {ms:.3f} | {vs:.2f} | "
              f"{nodes:.1f} | {tris:.1f} | {sub:.1f} |")
    return 0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--world", default="w2")
    ap.add_argument("--depth", type=int, default=5)
    ap.add_argument("--portal-depth", type=int, default=2)
    ap.add_argument("--trajectory", default=str(ROOT / "trajectories" / "indoor.csv"))
    ap.add_argument("--frames", type=int, default=120, help="frames sampled evenly")
    ap.add_argument("--profile", default="ipaq-hx2490b")
    ap.add_argument("--out", default=None, help="also write the report here")
    ap.add_argument("--tiled", default="", help="W2 tiled n x n worlds to run, e.g. 3,7")
    ap.add_argument("--tiled-frames", type=int, default=30, help="frames on tiled worlds")
    ap.add_argument("--tiled-partition", default=None,
                    help="load each tiled octree from this .vmp when it exists (a pattern with "
                         "{n} and {depth}, e.g. out/w2x{n}_d{depth}.vmp), else build and save it")
    ap.add_argument("--skip-combos", action="store_true", help="only the comparison and tiles")
    ap.add_argument("--horizon-structures", default=None,
                    help="only compare vfc,tbfc / vfc,horizon,tbfc / vfc,occlusion,tbfc on these "
                         "structures (e.g. octree:4,octree:5,kdtree) and exit; --world terrain "
                         "runs the terrain world with objects on its valley path")
    ap.add_argument("--screen", action="store_true",
                    help="with --horizon-structures: also vfc,horizon,tbfc and "
                         "vfc,occlusion,tbfc dropping triangles that cover no pixel centre of "
                         "the profile's screen (safe at that resolution only)")
    ap.add_argument("--structures-vfc", default=None,
                    help="only compare vfc on these structures (comma-separated specs, e.g. "
                         "octree:3,octree:4,octree:5,octree:6,kdtree) and exit")
    ap.add_argument("--skip-routes", action="store_true", help="no item buffer / Open3D rows")
    ap.add_argument("--combos", default=None,
                    help="octree combos to run instead of the list (and on the tiled worlds), "
                         "separated by ';'")
    args = ap.parse_args(argv)
    try:
        sizes = [int(v) for v in args.tiled.split(",") if v.strip()]
    except ValueError:
        print(f"bench_cull: --tiled must be comma-separated integers, got {args.tiled!r}",
              file=sys.stderr)
        return 2

    profile = get_profile(args.profile)
    if args.horizon_structures:
        return horizon_report(args, profile)
    world = build_world(args.world)
    traj = Trajectory.load(args.trajectory)
    frames = np.unique(np.linspace(0, len(traj) - 1, args.frames).astype(int))
    cameras = [traj.camera(int(f), profile.aspect) for f in frames]
    if args.structures_vfc:
        rows = structure_rows(world, cameras, "vfc", args.structures_vfc.split(","))
        print(f"vfc on {args.world.upper()}, {len(cameras)} frames of "
              f"{Path(args.trajectory).name}\n\n| structure | nodes | build s | mean nodes "
              "visited | mean triangles sent | median ms |\n| --- | ---: | ---: | ---: | ---: "
              "| ---: |")
        for label, nodes, build_s, visited, sent, ms in rows:
            print(f"| {label} | {nodes:,} | {build_s:.2f} | {visited:.1f} | {sent:.0f} | "
                  f"{ms:.3f} |")
        return 0
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
    vertices, faces = world.vertices, world.triangles
    outcodes = median_ms(lambda cam: np.flatnonzero(
        outcode_frustum(vertices, faces, cam.frustum_planes())), cameras)
    if args.skip_routes:  # the long check: no brute force either
        brute, in_frustum, thesis_err = np.nan, np.nan, [(np.nan, np.nan)]
    else:
        brute = median_ms(lambda cam: np.flatnonzero(
            brute_force_frustum(corners, cam.frustum_planes())), cameras)
        in_frustum = float(np.mean([brute_force_frustum(corners, c.frustum_planes()).sum()
                                    for c in cameras]))
        thesis_err = [thesis_cbfc_errors(world, c, corners) for c in cameras]

    combos = COMBOS if args.combos is None else [c for c in args.combos.split(";") if c]
    rows = [] if args.skip_combos else run_combos(octree, combos, cameras, world, profile, truth)
    if not args.skip_combos and args.combos is None:
        rows += run_combos(portal, PORTAL_COMBOS, cameras, world, profile, truth)
    routes = [] if args.skip_routes else exact_routes(world, profile, cameras, truth, octree)
    tile_frames = np.unique(np.linspace(0, len(traj) - 1, args.tiled_frames).astype(int))
    try:
        tiles = tiled_rows(sizes, world, traj, tile_frames, profile,
                           lambda n: args.depth + int(np.ceil(np.log2(n))),
                           args.tiled_partition,
                           TILED_COMBOS if args.combos is None else combos) if sizes else []
    except (VisMobileError, ValueError) as error:  # a bad or mismatched --tiled-partition
        print(f"bench_cull: {error}", file=sys.stderr)
        return 2

    out = [f"# Culling benchmark: {args.world.upper()} ({world.triangle_count} triangles), "
           f"octree depth {args.depth} ({octree.node_count} nodes, built in {build_s:.2f} s), "
           f"portal octree depth {args.portal_depth}, {len(cameras)} frames of "
           f"{Path(args.trajectory).name}", "",
           "| measure | value |", "| --- | --- |",
           f"| median cull time vfc+cbfc (ms) | {fast:.3f} |",
           f"| median brute-force per-triangle frustum test (ms) | {brute:.3f} |",
           f"| speed-up | {brute / fast:.1f}x |",
           f"| median per-vertex outcode frustum test, numpy (ms; the fastest plain baseline) "
           f"| {outcodes:.3f} |",
           f"| speed-up against per-vertex outcodes | {outcodes / fast:.1f}x |",
           f"| mean triangles in frustum (brute force) | {in_frustum:.0f} |",
           f"| mean visible triangles (item buffer) | {mean_visible:.0f} |",
           f"| thesis 2D cbfc: front-facing in-frustum triangles it would drop, mean per frame "
           f"| {np.mean([e for e, _ in thesis_err]):.1f} (of {np.mean([d for _, d in thesis_err]):.0f}"
           f" dropped) |", "",
           "Stages `@screen`: occlusion also drops triangles covering no pixel centre of the "
           f"{profile.width}x{profile.height} screen; `@self`: objects' near sides occlude too "
           "(512 per frame). Visible = item buffer, back-face culled for bfc/cbfc/cone/tbfc.", "",
           "| structure | stages | median ms | mean sent | mean of sent / visible | "
           "mean sent / mean visible | visible dropped (all frames) |",
           "| --- | --- | --- | --- | --- | --- | --- |"]
    for kind, combo, ms, sent, ratio, ratio_of_means, missed, _ in rows:
        out.append(f"| {kind} | {combo} | {ms:.3f} | {sent:.0f} | {ratio:.2f} | "
                   f"{ratio_of_means:.2f} | {missed} |")
    base_ms = routes[0][1] if routes else np.nan
    out += [] if not routes else ["", "Routes to the visible set (octree depth "
            f"{args.depth}; visible = back-face-culled item buffer, mean "
            f"{np.mean([len(truth[i, True]) for i in range(len(cameras))]):.0f}); time ratio "
            "against vfc,occlusion,tbfc in the same run:", "",
            "| route | median ms | ratio to vfc,occlusion,tbfc | mean ids | mean ids / mean "
            "visible |", "| --- | --- | --- | --- | --- |"]
    for label, ms, ids, ratio in routes:
        out.append(f"| {label} | {ms:.3f} | {ms / base_ms:.2f}x | {ids:.0f} | {ratio:.2f} |")
    if tiles:
        out += ["", f"Tiled W2 ({args.tiled_frames} frames of the trajectory on the centre tile; "
                "octree depth 5 + ceil(log2 n); visible = item buffer, back-face culled for "
                "tbfc):", "",
                "| world | triangles | depth | build s | prepare s | stages | median ms | "
                "worst ms | worst / median | mean sent | mean visible | sent / visible | "
                "dropped | nodes visited |",
                "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- "
                "| --- |"]
        for name, tris, depth, build_s, prep_s, stages, ms, worst, sent, shown, ratio, \
                dropped, visited in tiles:
            out.append(f"| {name} | {tris:,} | {depth} | {build_s:.1f} | {prep_s:.1f} | "
                       f"{stages} | {ms:.3f} | {worst:.3f} | {worst / ms:.2f} | {sent:.0f} | "
                       f"{shown:.0f} | {ratio:.2f} | {dropped} | {visited:.0f} |")
    out += ["", "Mean per-frame counters:", "", "| structure | stages | counters |",
            "| --- | --- | --- |"]
    for kind, combo, *_, mean in rows:
        text = ", ".join(f"{k} {v:.1f}" for k, v in sorted(mean.items()))
        out.append(f"| {kind} | {combo} | {text} |")
    report = "\n".join(out) + "\n"
    print(report)
    if args.out:
        from vismobile.world.world import atomic_write_bytes

        Path(args.out).parent.mkdir(parents=True, exist_ok=True)
        atomic_write_bytes(args.out, report.encode())
    return 0


if __name__ == "__main__":
    sys.exit(main())

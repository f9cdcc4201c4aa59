"""Terrain LOD benchmark (issue 15): LOD+cull time and triangles of the tile quadtree (seed 002),
Röttger CLOD (seed 000) and ROAM (seed 003) along Pires's paths on a large map, and image error
against the full-resolution render for a sweep of the pixel knob on a smaller one.

    .venv/bin/python tools/bench_terrain.py [--size 4097] [--frames 60] [--render-size 1025]
        [--taus 0.25,0.5,0.7,1,2,4,8] [--error-frames 4] [--methods tiles,roettger,roam]
        [--out runs/bench_terrain.md]
    .venv/bin/python tools/bench_terrain.py --display-lists --size 1025 --frames 60
    .venv/bin/python tools/bench_terrain.py --roam-speeds --size 1025 --frames 30

Heightmaps are deterministic diamond-square maps (seed 1, roughness 0.5, relief 0.12 of the
width, unit spacing), cached as out/terrain/fractal-N.vmt. Times are medians over consecutive
frames of each path in this process (host-dependent; the machine may be shared); triangle
counts and errors are hardware-independent.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from vismobile.device.profile import get_profile  # noqa: E402
from vismobile.study.terrain import TileMethod, build_method, measure  # noqa: E402
from vismobile.terrain import sources, store  # noqa: E402
from vismobile.terrain.paths import path_cameras  # noqa: E402
from vismobile.terrain.tiles import TilePyramid  # noqa: E402

PATHS = [("circle", "slow"), ("circle", "fast"), ("lemniscate", "slow"), ("lemniscate", "fast"),
         ("valley", "fast")]


def heightmap(size: int):
    path = ROOT / "out" / "terrain" / f"fractal-{size}.vmt"
    if path.is_file():
        return store.load(path)[0]
    hm = sources.diamond_square(size, seed=1, roughness=0.5, relief=0.12)
    store.save(path, hm)
    return hm


def build_methods(hm, names, patch, C) -> tuple:
    """The named methods on one heightmap and their pre-processing seconds."""
    methods, builds = [], {}
    for name in names:
        start = time.perf_counter()
        try:
            methods.append(build_method(name, hm, patch, C))
        except ValueError as error:
            raise SystemExit(str(error)) from None
        builds[name] = time.perf_counter() - start
    return methods, builds


def speed(hm, frames, tau, profile, patch, C, eye_height, names) -> list:
    """Per path and method: median/p95 LOD ms, median/max triangles, chunk churn (Röttger),
    splits/merges (ROAM)."""
    methods, builds = build_methods(hm, names, patch, C)
    rows = []
    for kind, pace in PATHS:
        cameras = path_cameras(hm, kind, pace, frames=frames, eye_height=eye_height)
        for method in methods:
            ms, cpu, tris, changed, reused = [], [], [], [], []
            for camera in cameras:
                result, lod_ms, triangles = method.frame(camera, profile.resolution, tau)
                ms.append(lod_ms)
                cpu.append(method.cpu_ms)
                tris.append(triangles)
                if method.name == "roettger":
                    changed.append(result.chunks_changed)
                    reused.append(result.chunks_reused)
                elif method.name == "roam":  # splits / merges in the churn columns
                    changed.append(result.splits)
                    reused.append(result.merges)
            warm = slice(2, None)  # first frames: JIT cache load, first refinement
            rows.append({"path": f"{kind} {pace}", "method": method.name, "tau": tau,
                         "lod_ms_median": float(np.median(ms[warm])),
                         "lod_ms_p95": float(np.percentile(ms[warm], 95)),
                         "lod_ms_min": float(np.min(ms[warm])),
                         "lod_cpu_ms_median": float(np.median(cpu[warm])),
                         "triangles_median": int(np.median(tris)), "triangles_max": int(max(tris)),
                         "chunks_changed_mean": float(np.mean(changed[1:])) if changed else None,
                         "chunks_reused_mean": float(np.mean(reused[1:])) if reused else None})
    return rows, builds


def errors(hm, taus, frames, profile, patch, C, eye_height, exact, names) -> list:
    cameras = path_cameras(hm, "lemniscate", "fast", frames=frames, every=900 // max(frames, 1),
                           eye_height=eye_height)
    methods, _ = build_methods(hm, names, patch, C)
    rows = measure(methods, hm, cameras, taus, profile, exact_vertices=exact)
    summary = []
    for method in [m.name for m in methods]:
        for tau in taus:
            r = [x for x in rows if x["method"] == method and x["tau"] == tau]
            summary.append({
                "method": method, "tau": tau,
                "triangles": int(np.median([x["triangles"] for x in r])),
                "share_of_full": float(np.median([x["triangles"] / x["full_triangles"] for x in r])),
                "psnr_min": float(min(x["psnr"] for x in r)),
                "psnr_median": float(np.median([x["psnr"] for x in r])),
                "differing_median": float(np.median([x["differing"] for x in r])),
                "pixel_height_max": float(max(x["pixel_height_max"] for x in r)),
                "pixel_height_p99": float(np.median([x["pixel_height_p99"] for x in r])),
                "vertex_error_max": float(max(x.get("vertex_error_max", np.nan) for x in r)),
                "render_ms": float(np.median([x["render_ms"] for x in r])),
            })
    return summary


def horizon(hm, frames, profile, patch, eye_height, objects, arithmetic="float64") -> dict:
    """Objects the horizon hides on the valley path, checked against the item buffer, and the
    tile triangles it removes."""
    from vismobile.geometry.planes import classify_boxes
    from vismobile.render import SENTINEL
    from vismobile.render.terrain import TerrainRenderer
    from vismobile.terrain.horizon import HorizonCaster
    from vismobile.terrain.placement import place_objects
    from vismobile.terrain.tiles import full_selection, selection_mesh

    placement = place_objects(hm, objects, seed=3, height=6.0 * hm.spacing)
    boxes = placement.boxes()
    meshes = placement.meshes()
    starts = np.cumsum([0] + [len(t) for _, t in meshes])
    offsets = np.cumsum([0] + [len(v) for v, _ in meshes])
    vertices = np.concatenate([v for v, _ in meshes])
    triangles = np.concatenate([t + o for (_, t), o in zip(meshes, offsets[:-1])])
    pyramid = TilePyramid.build(hm, patch)
    caster = HorizonCaster(hm, bands=120, step=0.01, arithmetic=arithmetic)
    renderer = TerrainRenderer(hm, profile)
    base = 1 << 28
    rows = []
    plain, culled = TileMethod(pyramid), TileMethod(pyramid, HorizonCaster(hm, 60, 0.02))
    cameras = path_cameras(hm, "valley", "fast", frames=frames, every=max(1, 1800 // frames),
                           eye_height=eye_height)
    for camera in cameras:
        cpu = time.thread_time()
        hidden = caster.cast(camera).hidden(boxes)
        cast_ms = (time.thread_time() - cpu) * 1000.0
        in_view = ~classify_boxes(boxes, camera.frustum_planes())[0]
        renderer.draw(*selection_mesh(pyramid, full_selection(pyramid, camera)), camera,
                      kind="item")
        renderer.draw_mesh_items(vertices, triangles, camera, base)
        ids = renderer.read_ids()
        seen = np.unique(np.searchsorted(starts, ids[(ids != SENTINEL) & (ids >= base)] - base,
                                         side="right") - 1)
        tiles = plain.frame(camera, profile.resolution, 1.0)[2]
        tiles_culled = culled.frame(camera, profile.resolution, 1.0)[2]
        rows.append({"in_view": int(in_view.sum()), "hidden": int((hidden & in_view).sum()),
                     "visible": int(len(seen)), "lost": int(hidden[seen].sum()),
                     "cast_cpu_ms": cast_ms, "tiles": tiles, "tiles_horizon": tiles_culled,
                     "tiles_horizon_cpu_ms": culled.cpu_ms})
    return rows


def display_lists(hm, frames, tau, profile, C, speed_name="slow") -> dict:
    """Pires's cached chunks against rebuilding, on the circle path (frames consecutive, after
    a warm-up), interleaved in one process: per frame, the cached variant (DisplayLists +
    ChunkRenderer: only changed chunks are emitted and uploaded), the same path with the cache
    off (every visible chunk emitted and uploaded each frame) and the engine's plain path
    (Roettger.update + TerrainRenderer.draw_samples: every triangle's vertices gathered and
    uploaded). A frame is LOD + index build + upload + draw + glFinish (llvmpipe); its CPU
    part is LOD + index build + the vertex gathering and uploads (the plain path's gathering
    and upload of vertices is inside its draw, so its CPU column is LOD + emission only); its
    process CPU is the whole frame's CPU time over every thread, llvmpipe's rasteriser threads
    included (on a loaded machine wall time also counts waiting for a core; this does not)."""
    from vismobile.render.chunks import ChunkRenderer
    from vismobile.render.terrain import TerrainRenderer
    from vismobile.terrain.display_lists import DisplayLists
    from vismobile.terrain.roettger import Roettger

    cameras = path_cameras(hm, "circle", speed_name, frames=frames + 3)
    cached = DisplayLists(Roettger(hm, C))
    rebuilt = DisplayLists(Roettger(hm, C), cache=False)
    renderers = {"cached": ChunkRenderer(cached, profile),
                 "rebuilt": ChunkRenderer(rebuilt, profile)}
    plain, plain_renderer = Roettger(hm, C), TerrainRenderer(hm, profile)
    times = {"cached": [], "rebuilt": [], "plain": []}
    cpu = {"cached": [], "rebuilt": [], "plain": []}
    threads = {"cached": [], "rebuilt": [], "plain": []}  # LOD + index build, thread CPU
    processes = {"cached": [], "rebuilt": [], "plain": []}  # whole frame, all threads' CPU
    uploads = {"cached": [], "rebuilt": []}
    churn = []
    for k, camera in enumerate(cameras):
        order = [("cached", cached), ("rebuilt", rebuilt)]
        if k % 2:
            order.reverse()
        for name, lists in order:
            process = time.process_time()
            thread = time.thread_time()
            frame = lists.update(camera, profile.resolution, tau)
            thread = (time.thread_time() - thread) * 1000
            stats = renderers[name].draw(frame, camera)
            process = (time.process_time() - process) * 1000
            if k >= 3:
                processes[name].append(process)
                times[name].append(frame.lod_ms + frame.build_ms + stats.render_ms)
                cpu[name].append(frame.lod_ms + frame.build_ms + renderers[name].upload_ms)
                threads[name].append(thread)
                uploads[name].append(renderers[name].uploaded_bytes)
                if name == "cached":
                    churn.append((frame.rebuilt, frame.reused, frame.triangles))
        process = time.process_time()
        thread = time.thread_time()
        result = plain.update(camera, profile.resolution, tau)
        thread = (time.thread_time() - thread) * 1000
        stats = plain_renderer.draw_samples(result.triangles, camera)
        process = (time.process_time() - process) * 1000
        if k >= 3:
            processes["plain"].append(process)
            times["plain"].append(result.lod_ms + stats.render_ms)
            cpu["plain"].append(result.lod_ms)
            threads["plain"].append(thread)
    med = {k: float(np.median(v)) for k, v in times.items()}
    ratio = float(np.median(np.array(times["cached"]) / np.array(times["rebuilt"])))
    return {"speed": speed_name, "frames": frames, "frame_ms": med,
            "cpu_ms": {k: float(np.median(v)) for k, v in cpu.items()},
            "thread_ms": {k: float(np.median(v)) for k, v in threads.items()},
            "process_ms": {k: float(np.median(v)) for k, v in processes.items()},
            "process_ratio_cached_over_rebuilt": float(np.median(
                np.array(processes["cached"]) / np.array(processes["rebuilt"]))),
            "ratio_cached_over_rebuilt": ratio,
            "cpu_ratio_cached_over_rebuilt": float(np.median(np.array(cpu["cached"])
                                                             / np.array(cpu["rebuilt"]))),
            "ratio_cached_over_plain": float(np.median(np.array(times["cached"])
                                                       / np.array(times["plain"]))),
            "upload_bytes": {k: float(np.median(v)) for k, v in uploads.items()},
            "rebuilt_mean": float(np.mean([c[0] for c in churn])),
            "reused_mean": float(np.mean([c[1] for c in churn])),
            "triangles_median": float(np.median([c[2] for c in churn]))}


def circle_cameras(hm, step, frames, eye_height=1.0):
    """Cameras on the circle path (radius 0.4 of the width, looking at the centre) at step
    world units a frame."""
    from vismobile.world.camera import Camera

    w = hm.extent
    radius, centre = 0.4 * w, w / 2
    angle = np.arange(frames) * step / radius
    x, z = centre + radius * np.cos(angle), centre + radius * np.sin(angle)
    y = hm.height_at(x, z) + eye_height * hm.spacing
    yaw = np.degrees(np.arctan2(x - centre, z - centre))
    fov = float(np.degrees(2 * np.arctan(np.tan(np.radians(30.0)) / (240 / 320))))
    return [Camera((a, b, c), yaw=float(d), pitch=-10, fov=fov, near=0.05 * hm.spacing,
                   far=1.5 * w) for a, b, c, d in zip(x, y, z, yaw)]


def roam_speeds(hm, frames, tau, profile, steps=(0.1, 1.0, 10.0), walk_above=None) -> list:
    """ROAM's frame time against speed: the default ROAM, the walking one and the incremental
    one that never walks (and the hybrid with walk_above), each
    coherent along the circle at each speed (3 warm-up frames), updated alternately on the
    same cameras; medians of wall time and of the thread's CPU time (immune to the shared
    machine's descheduling)."""
    from vismobile.terrain.roam import Roam

    rows = []
    for step in steps:
        cameras = circle_cameras(hm, step, frames + 3)
        # the default (incremental, walking the frames whose due wake-ups exceed a share
        # of the mesh), the walking ROAM, the incremental one that never walks
        roams = {"default": Roam(hm), "walking": Roam(hm, incremental=False),
                 "incremental": Roam(hm, walk_above=np.inf)}
        if walk_above is not None:  # the hybrid: incremental, walking frames above a speed
            roams["hybrid"] = Roam(hm, walk_above=walk_above)
        record = {key: {"ms": [], "cpu": [], "ops": [], "tris": []} for key in roams}
        for k, camera in enumerate(cameras):
            keys = list(roams)
            for key in (keys if k % 2 else keys[::-1]):
                cpu = time.thread_time()
                frame = roams[key].update(camera, profile.resolution, tau)
                cpu = (time.thread_time() - cpu) * 1000
                if k >= 3:
                    r = record[key]
                    r["ms"].append(frame.lod_ms)
                    r["cpu"].append(cpu)
                    r["ops"].append(frame.splits + frame.merges)
                    r["tris"].append(len(frame.triangles))
        for key in roams:
            r = record[key]
            rows.append({"step": step, "roam": key, "walked": roams[key].fast_frames,
                         "ms_median": float(np.median(r["ms"])),
                         "cpu_ms_median": float(np.median(r["cpu"])),
                         "ops_median": float(np.median(r["ops"])),
                         "triangles_median": float(np.median(r["tris"]))})
    return rows


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--size", type=int, default=4097)
    parser.add_argument("--frames", type=int, default=60)
    parser.add_argument("--tau", type=float, default=1.0)
    parser.add_argument("--render-size", type=int, default=1025)
    parser.add_argument("--taus", default="0.25,0.5,0.7,1,2,4,8")
    parser.add_argument("--error-frames", type=int, default=4)
    parser.add_argument("--patch", type=int, default=16)
    parser.add_argument("--C", type=float, default=8.0)
    parser.add_argument("--eye-height", type=float, default=1.0)
    parser.add_argument("--exact", action="store_true", help="also the exact per-sample error")
    parser.add_argument("--skip-speed", action="store_true")
    parser.add_argument("--skip-errors", action="store_true")
    parser.add_argument("--skip-horizon", action="store_true")
    parser.add_argument("--objects", type=int, default=200)
    parser.add_argument("--horizon-frames", type=int, default=12)
    parser.add_argument("--methods", default="tiles,roettger,roam")
    parser.add_argument("--arithmetic", default="float64", choices=("float64", "fixed16.16"),
                        help="the horizon's arithmetic (fixed16.16: a fixed-point profile's)")
    parser.add_argument("--display-lists", action="store_true",
                        help="only Pires's cached chunks against rebuilding (circle paths)")
    parser.add_argument("--roam-speeds", action="store_true",
                        help="only ROAM's frame time at 0.1, 1 and 10 units a frame")
    parser.add_argument("--walk-above", type=float, default=None,
                        help="with --roam-speeds, also the hybrid ROAM: incremental, walking "
                             "frames whose eye moved more than this many units")
    parser.add_argument("--out", type=Path, default=ROOT / "runs" / "bench_terrain.md")
    args = parser.parse_args(argv)
    profile = get_profile("ipaq-hx2490b")
    lines, record = [], {}
    if args.roam_speeds:
        hm = heightmap(args.size)
        rows = roam_speeds(hm, args.frames, args.tau, profile, walk_above=args.walk_above)
        record["roam_speeds"] = rows
        lines += [f"## ROAM frame time against speed, {args.size}^2, tau = {args.tau} px, "
                  f"circle, {args.frames} frames a speed, medians", "",
                  "| units / frame | ROAM | frame ms | CPU ms | splits + merges | triangles "
                  "| frames walked for speed |", "|---:|---|---:|---:|---:|---:|---:|"]
        for r in rows:
            lines.append(f"| {r['step']:g} | {r['roam']} "
                         f"| {r['ms_median']:.2f} | {r['cpu_ms_median']:.2f} | "
                         f"{r['ops_median']:.0f} | {r['triangles_median']:,.0f} | "
                         f"{r['walked']} |")
        for name in dict.fromkeys(r["roam"] for r in rows):
            t = {r["step"]: r["ms_median"] for r in rows if r["roam"] == name}
            c = {r["step"]: r["cpu_ms_median"] for r in rows if r["roam"] == name}
            lines.append(f"\n{name}: 0.1 / 10 units a frame = "
                         f"{t[0.1] / t[10.0]:.2f} (CPU {c[0.1] / c[10.0]:.2f})")
        print("\n".join(lines), flush=True)
        args.skip_speed = args.skip_errors = args.skip_horizon = True
    if args.display_lists:
        hm = heightmap(args.size)
        lines += [f"## Display lists (Pires), Röttger C = {args.C:g}, {args.size}^2, tau = "
                  f"{args.tau} px, {args.frames} frames per path, medians", "",
                  "| circle | frame ms cached | cache off | plain Röttger | cached / cache off "
                  "| cached / plain | process CPU ms cached / off / plain | process CPU cached / "
                  "off | CPU ms cached / off / plain | CPU cached / off | LOD + build thread "
                  "CPU ms cached / off / plain | bytes uploaded cached / off | chunks rebuilt / "
                  "reused | triangles |", "|---|" + "---:|" * 13]
        for name in ("slow", "fast"):
            r = display_lists(hm, args.frames, args.tau, profile, args.C, name)
            record.setdefault("display_lists", []).append(r)
            f, c, u = r["frame_ms"], r["cpu_ms"], r["upload_bytes"]
            lines.append(f"| {name} | {f['cached']:.2f} | {f['rebuilt']:.2f} | {f['plain']:.2f} "
                         f"| {r['ratio_cached_over_rebuilt']:.2f} | "
                         f"{r['ratio_cached_over_plain']:.2f} | "
                         f"{r['process_ms']['cached']:.2f} / {r['process_ms']['rebuilt']:.2f} / "
                         f"{r['process_ms']['plain']:.2f} | "
                         f"{r['process_ratio_cached_over_rebuilt']:.2f} | {c['cached']:.2f} / "
                         f"{c['rebuilt']:.2f} / {c['plain']:.2f} | "
                         f"{r['cpu_ratio_cached_over_rebuilt']:.2f} | "
                         f"{r['thread_ms']['cached']:.2f} / {r['thread_ms']['rebuilt']:.2f} / "
                         f"{r['thread_ms']['plain']:.2f} | {u['cached']:,.0f} / "
                         f"{u['rebuilt']:,.0f} | {r['rebuilt_mean']:.1f} / "
                         f"{r['reused_mean']:.1f} | {r['triangles_median']:,.0f} |")
            print(lines[-1], flush=True)
        args.skip_speed = args.skip_errors = args.skip_horizon = True
    if not args.skip_speed:
        hm = heightmap(args.size)
        rows, builds = speed(hm, args.frames, args.tau, profile, args.patch, args.C,
                             args.eye_height, args.methods.split(","))
        record["speed"] = rows
        lines += [f"## LOD + cull per frame, {args.size}^2, tau = {args.tau} px, "
                  f"{args.frames} consecutive frames per path (eye {args.eye_height} above ground)",
                  "", "Pre-processing: " + ", ".join(f"{k} {v:.1f} s" for k, v in builds.items())
                  + f" (patch {args.patch}, C = {args.C:g}).", "",
                  "| path | method | LOD ms median | p95 | min | CPU ms median | triangles median "
                  "| max | chunks changed / reused (roam: splits / merges) |",
                  "|---|---|---:|---:|---:|---:|---:|---:|---|"]
        for r in rows:
            churn = (f"{r['chunks_changed_mean']:.1f} / {r['chunks_reused_mean']:.1f}"
                     if r["chunks_changed_mean"] is not None else "")
            lines.append(f"| {r['path']} | {r['method']} | {r['lod_ms_median']:.2f} | "
                         f"{r['lod_ms_p95']:.2f} | {r['lod_ms_min']:.2f} | "
                         f"{r['lod_cpu_ms_median']:.2f} | "
                         f"{r['triangles_median']:,} | {r['triangles_max']:,} | {churn} |")
        lines.append("")
        print("\n".join(lines), flush=True)
    if not args.skip_errors:
        taus = [float(t) for t in args.taus.split(",")]
        hm = heightmap(args.render_size)
        summary = errors(hm, taus, args.error_frames, profile, args.patch, args.C,
                         args.eye_height, args.exact, args.methods.split(","))
        record["errors"] = summary
        table = [f"## Image error against the full render, {args.render_size}^2, "
                 f"{args.error_frames} frames of the fast lemniscate, 240x320", "",
                 "| method | tau px | triangles | of full | PSNR min | PSNR median | "
                 "pixels differing | pixel-height max | p99 | sample error max | render ms |",
                 "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
        for r in summary:
            table.append(f"| {r['method']} | {r['tau']:g} | {r['triangles']:,} | "
                         f"{100 * r['share_of_full']:.0f}% | {r['psnr_min']:.1f} | "
                         f"{r['psnr_median']:.1f} | {100 * r['differing_median']:.2f}% | "
                         f"{r['pixel_height_max']:.2f} | {r['pixel_height_p99']:.2f} | "
                         f"{r['vertex_error_max']:.2f} | {r['render_ms']:.0f} |")
        print("\n".join(table), flush=True)
        lines += table
    if not args.skip_horizon:
        hm = heightmap(args.render_size)
        rows = horizon(hm, args.horizon_frames, profile, args.patch, 2.0, args.objects,
                       args.arithmetic)
        record["horizon"] = rows
        in_view = sum(r["in_view"] for r in rows)
        hidden = sum(r["hidden"] for r in rows)
        table = [f"## Horizon ({args.arithmetic}) on the valley path, {args.render_size}^2, "
                 f"{args.objects} objects, {len(rows)} frames, eye 2 above ground", "",
                 "| frame | objects in view | hidden | visible (item buffer) | hidden but visible "
                 "| cast CPU ms | tile triangles | with horizon | tiles+horizon CPU ms |",
                 "|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
        for k, r in enumerate(rows):
            table.append(f"| {k} | {r['in_view']} | {r['hidden']} | {r['visible']} | {r['lost']} "
                         f"| {r['cast_cpu_ms']:.1f} | {r['tiles']:,} | {r['tiles_horizon']:,} "
                         f"| {r['tiles_horizon_cpu_ms']:.1f} |")
        table += ["", f"Hidden: {hidden} of {in_view} objects in view "
                      f"({100 * hidden / max(in_view, 1):.0f}%); hidden but visible: "
                      f"{sum(r['lost'] for r in rows)}."]
        print("\n".join(table), flush=True)
        lines += table
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text("\n".join(lines) + "\n")
    args.out.with_suffix(".json").write_text(json.dumps(record, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())

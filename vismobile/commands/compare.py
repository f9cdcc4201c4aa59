"""`vismobile compare`: the thesis's chapter-5 matrix (SPEC §6) in one command, with a report."""
import sys
from pathlib import Path

from . import (CULL_HELP, FIX_WINDING_HELP, FRAMES_HELP, PROFILE_NAMES, REPAIR_HELP, REPAIRS,
               WORLDS_DIR_HELP)


def add_parser(sub):
    parser = sub.add_parser(
        "compare", help="run the comparison matrix (parallel, resumable) and write a report",
        description="Example: vismobile compare --worlds w1,w2 --structures "
                    "grid,octree:3-6,portal:1-3,bsp --cull all --profiles "
                    "ipaq-hx2490b,nokia-n82. With --terrain FILE.vmt: the terrain methods' "
                    "pixel-knob sweep along camera paths instead (vismobile compare --terrain "
                    "t.vmt --methods tiles,roettger,roam --taus 0.5,1,4 --frames sample:3)")
    parser.add_argument("--worlds", default="all",
                        help="comma-separated thesis worlds w1..w6, all, or mesh file paths "
                             "(a file needs --trajectory) (default all)")
    parser.add_argument("--trajectory", type=Path, default=None,
                        help="trajectory CSV for the worlds given as files, or pitched: the "
                             "thesis's paths for w1..w6 with the camera looking up and down "
                             "(+-85 degrees every 150 frames; trajectories/indoor_pitched.csv, "
                             "outdoor_pitched.csv)")
    parser.add_argument("--fix-winding", action="store_true",
                        help=FIX_WINDING_HELP + "; worlds given as mesh files only (the thesis "
                             "worlds are used as built), each fixed copy written to "
                             "OUT/fixed/NAME.obj and swept in its place")
    parser.add_argument("--repair", choices=REPAIRS, default="none",
                        help=REPAIR_HELP + "; every world of the sweep, each run's record and "
                             "key say so (a static world only)")
    parser.add_argument("--structures", default="grid,octree:3-6,portal:1-3,bsp",
                        help="comma-separated grid, octree[:N or A-B], portal[:N or A-B], bsp, "
                             "kdtree, or all (the thesis's set; the default); +pvs bakes a "
                             "conservative PVS on one (portal:2+pvs: its combinations run with "
                             "pvs added), +pvs=sampled:N an aggressive sampled one")
    parser.add_argument("--cull", action="append", default=None, metavar="COMBINATIONS",
                        help="culling combinations, each stages joined by + (as in play and "
                             "view), several separated by ';' or given as repeated --cull "
                             "(--cull vfc+bfc --cull vfc+occlusion): all, thesis (its 8), ours, "
                             "none, or stages " + CULL_HELP.split("; stages: ")[1]
                             + " (default all; the older ',' between combinations still works "
                               "and is noted when it may have meant +)")
    parser.add_argument("--profiles", default="ipaq-hx2490b,nokia-n82",
                        help="comma-separated device profiles: " + ", ".join(PROFILE_NAMES)
                             + " (default ipaq-hx2490b,nokia-n82)")
    parser.add_argument("--frames", default=None,
                        help=FRAMES_HELP + " (default all; with --terrain: of one lap of each "
                             "path, default sample:4)")
    parser.add_argument("-o", "--out", type=Path, default=Path("out/compare"),
                        help="results folder (runs/<key>.json, runs.csv, runs.json)")
    parser.add_argument("--report", type=Path, default=None,
                        help="HTML report path (default OUT/report.html)")
    parser.add_argument("--worlds-dir", type=Path, default=None,
                        help=WORLDS_DIR_HELP)
    parser.add_argument("--cache", type=Path, default=Path("out/cache"),
                        help="partition and ground-truth cache")
    parser.add_argument("--jobs", type=int, default=None, help="worker processes (default: cores)")
    parser.add_argument("--scheduler", default="local",
                        help="local (a pool of --jobs processes, the default), dask (a Dask "
                             "LocalCluster of --jobs worker processes) or the address of a "
                             "running dask.distributed scheduler, e.g. tcp://host:8786 (its "
                             "workers must see the same worlds, cache and out paths)")
    parser.add_argument("--agreement", type=int, default=2,
                        help="frames per world for the raster/ray-cast check (0: skip)")
    parser.add_argument("--lod", default="none", metavar="TAUS",
                        help="level of detail: one run per tolerance in pixels, e.g. none,1,2 "
                             "(none: full detail; each LOD run measures PSNR against the "
                             "full-detail frames of its culling; docs/lod.md)")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
    terrain = parser.add_argument_group("terrain sweep (--terrain)")
    terrain.add_argument("--terrain", type=Path, default=None,
                         help="a .vmt terrain (vismobile terrain build): sweep the pixel knob "
                              "of the terrain methods instead of the matrix (its placed "
                              "objects too: culled by vfc+horizon over octree:4 and drawn at "
                              "their LOD within each tau, as play runs them; chains in --cache)")
    terrain.add_argument("--methods", default="tiles,roettger,roam",
                         help="comma-separated terrain methods: tiles, roettger, roam, "
                              "roam/BUDGET (default tiles,roettger,roam)")
    terrain.add_argument("--taus", default="0.25,0.5,0.7,1,2,4,8",
                         help="pixel tolerances (default 0.25,0.5,0.7,1,2,4,8)")
    terrain.add_argument("--paths", default="circle:fast,lemniscate:fast",
                         help="comma-separated KIND:SPEED, kinds circle, lemniscate, valley, "
                              "speeds slow, fast (default circle:fast,lemniscate:fast)")
    terrain.add_argument("--peers", action="store_true",
                         help="also pymartini and pydelatin at equal triangles and equal error "
                              "(optional extra vismobile[peers]; missing ones are skipped)")
    return parser


def run(args) -> int:
    if args.terrain is not None:
        return run_terrain(args)
    import json

    from ..files.atomic import check_destination
    from ..study.matrix import expand, parse_worlds
    from ..study.thesis import NAMED_WORLDS as WORLDS, TRAJECTORY_VARIANTS, trajectory_for
    from ..study.report import write_report
    from ..study.runner import Context, agreement, reusable_runs, run_matrix
    from ..world.world import atomic_write_bytes

    trajectories = ({w: str(args.trajectory.resolve()) for w in parse_worlds(args.worlds)
                     if w not in WORLDS} if args.trajectory else None)
    variant = str(args.trajectory) if args.trajectory is not None else ""
    if variant in TRAJECTORY_VARIANTS and not args.trajectory.is_file():
        # a variant of the thesis's paths for w1..w6; world files still need a CSV
        trajectories = {w: trajectory_for(w, variant) for w in parse_worlds(args.worlds)
                        if w in WORLDS}
    from ..study.matrix import ambiguous_commas

    culls = args.cull or ["all"]
    note = ambiguous_commas(culls)
    if note:
        print(f"note: {note}", file=sys.stderr)
    worlds = args.worlds
    if args.fix_winding:
        worlds, trajectories = _fixed_worlds(worlds, trajectories or {}, args.out)
    specs = expand(worlds, args.structures, culls, args.profiles, args.frames or "all",
                   trajectories, args.lod)
    for path in (args.out / "runs.csv", args.out / "runs" / "x.json",
                 args.report or args.out / "report.html"):
        check_destination(path)  # before hours of runs, not after
    if not args.fix_winding:
        _warn_winding(specs)
    context = Context(".", args.out, args.worlds_dir, args.cache, args.repair)
    reused, executed = reusable_runs(specs, context)
    shared = len(specs) - reused - executed
    print(f"{len(specs)} runs -> {args.out}/runs/: {reused} reused from earlier, {executed} to "
          f"run" + (f", {shared} shared with a profile measured alike (same screen and vertex "
                    f"format: only the device models differ)" if shared else ""), flush=True)
    records = run_matrix(specs, context, args.jobs, progress=not args.quiet,
                         scheduler=args.scheduler)
    from ..progress import Status

    checks = []
    with Status("compare", enabled=not args.quiet) as status:
        for world in parse_worlds(worlds) if args.agreement > 0 else []:
            status(f"raster/ray-cast agreement on {world}")
            checks += agreement(world, context, specs[0].profile, args.agreement,
                                (trajectories or {}).get(world))
        if checks:
            atomic_write_bytes(args.out / "agreement.json",
                               json.dumps(checks, indent=1).encode())
        status("writing the report")
        report = write_report(records, args.report or args.out / "report.html",
                              agreement=checks,
                              **({} if args.repair == "none" else
                                 {"title": f"vismobile comparison (worlds repaired: "
                                           f"{args.repair})"}))
    failed = sum("error" in r for r in records)
    print(f"wrote {args.out / 'runs.csv'}, {args.out / 'runs.json'} and {report}"
          + (f"; {failed} runs failed (listed in the report)" if failed else ""))
    return 1 if failed else 0


def _warn_winding(specs) -> None:
    """commands.warn_winding for each mesh-file world swept with a back-face stage."""
    from . import warn_winding
    from ..files.loader import load_world
    from ..world.trajectory import Trajectory

    stages, paths = {}, {}
    for spec in specs:
        stages.setdefault(spec.world, set()).update(spec.stages)
        paths[spec.world] = spec.trajectory
    for world, names in stages.items():
        if world.lower().endswith(".vmp") or world.lower() in ("w1", "w2", "w3", "w4", "w5",
                                                                 "w6", "w7"):
            continue
        eyes = Trajectory.load(paths[world]).poses[:, :3] if paths[world] else None
        warn_winding(load_world(world), sorted(names), world, eyes)


def _fixed_worlds(worlds: str, trajectories: dict, out: Path) -> tuple:
    """(worlds text, trajectories) with each mesh-file world whose winding check_winding flags
    (camera positions from its trajectory) replaced by its fixed copy out/fixed/<stem>.obj
    (<stem>_<k>.obj when another file of that name came first)."""
    from ..study.matrix import parse_worlds
    from ..study.thesis import NAMED_WORLDS as WORLDS
    from ..world.trajectory import Trajectory
    from ..world.winding import fixed_world
    from ..files.loader import load_world

    names, trajectories = [], dict(trajectories)
    for world in parse_worlds(worlds):
        if world in WORLDS:
            names.append(world)
            continue
        eyes = Trajectory.load(trajectories[world]).poses[:, :3] if world in trajectories \
            else None
        fixed, report = fixed_world(load_world(world), eyes=eyes)
        print(f"--fix-winding: {world}: reversed {report.to_fix:,} of {report.triangles:,} "
              "triangles", flush=True)
        if report.to_fix:
            stem = Path(world).stem
            copy = (out / "fixed" / f"{stem}.obj").resolve()
            if str(copy) in names:  # two files of the same name in different folders
                copy = copy.with_name(f"{stem}_{len(names)}.obj")
            fixed.to_obj(copy)
            if world in trajectories:
                trajectories[str(copy)] = trajectories.pop(world)
            world = str(copy)
        names.append(world)
    return ",".join(names), trajectories


def _terrain_options(args) -> tuple:
    """(methods, taus, paths, frames, profile) checked, or WorldError naming the bad option."""
    from ..errors import WorldError
    from ..device.profile import get_profile
    from ..study.terrain import METHODS

    def bad(option, message):
        return WorldError(args.terrain, f"{option}: {message}")

    if args.repair != "none":
        raise bad("--repair", "applies to triangle worlds, not to a .vmt terrain")

    methods = [m.strip() for m in args.methods.split(",") if m.strip()]
    for m in methods:
        budget = m.split("/", 1)[1] if m.startswith("roam/") else None
        if m not in METHODS and not (budget and budget.isdigit() and int(budget) >= 2):
            raise bad("--methods", f"unknown method {m!r} (tiles, roettger, roam, roam/BUDGET)")
    try:
        taus = [float(t) for t in args.taus.split(",")]
    except ValueError:
        raise bad("--taus", f"not a list of numbers: {args.taus!r}") from None
    if not taus or not all(t > 0 and t < float("inf") for t in taus):
        raise bad("--taus", "tolerances must be finite and > 0")
    paths = []
    for item in args.paths.split(","):
        kind, _, speed = item.strip().partition(":")
        if kind not in ("circle", "lemniscate", "valley") or speed not in ("slow", "fast"):
            raise bad("--paths", f"{item!r} is not KIND:SPEED (circle, lemniscate, valley; "
                                 "slow, fast)")
        paths.append((kind, speed))
    frames = args.frames or "sample:4"
    mode, _, value = frames.partition(":")
    if not (frames == "all" or (mode in ("stride", "sample") and value.isdigit()
                                and int(value) >= 1)):
        raise bad("--frames", f"all, stride:N or sample:N, got {frames!r}")
    profile = get_profile(args.profiles.split(",")[0])  # ProfileError: exit 2, one line
    return methods, taus, paths, frames, profile


def run_terrain(args) -> int:
    """The terrain sweep: runs the methods along the paths for each tau, writes
    OUT/terrain.csv, OUT/terrain.json and the report."""
    import csv
    import io
    import json

    from ..files.atomic import check_destination
    from ..progress import Status
    from ..study.report import write_terrain_report
    from ..study.terrain import SWEEP_KEYS, sweep
    from ..terrain import store
    from ..world.world import atomic_write_bytes

    methods, taus, paths, frames, profile = _terrain_options(args)
    report_path = args.report or args.out / "report.html"
    for path in (args.out / "terrain.csv", args.out / "terrain.json", report_path):
        check_destination(path)
    heightmap, placement = store.load(args.terrain)
    keys = SWEEP_KEYS
    with Status("compare --terrain", enabled=not args.quiet) as status:
        rows = sweep(heightmap, methods, paths, taus, profile, frames, progress=status)
        if len(placement):  # the objects on it, as play runs them (study/terrain_objects.py)
            from ..app.terrain_objects import OBJECT_KEYS, object_figures

            figures = object_figures(args.terrain, methods, paths, taus, profile, frames,
                                     cache_dir=args.cache, progress=status)
            for row in rows:
                row.update(figures.get((row["method"], row["path"], row["tau"]), {}))
            keys = SWEEP_KEYS + OBJECT_KEYS
        peers = None
        if args.peers:
            from ..study.peers import PEERS, compare, missing
            from ..study.terrain import build_method, path_frames

            for name in PEERS:
                if missing(name):
                    print(f"compare: skipping {name}: {missing(name)}", flush=True)
            status("peers on the first path")
            cameras = path_frames(heightmap, *paths[0], frames)
            peers = compare([build_method(m, heightmap) for m in methods], heightmap, cameras,
                            taus, profile)
        status("writing the report")
        buffer = io.StringIO()
        writer = csv.DictWriter(buffer, fieldnames=keys)
        writer.writeheader()
        writer.writerows(rows)
        atomic_write_bytes(args.out / "terrain.csv", buffer.getvalue().encode())
        atomic_write_bytes(args.out / "terrain.json", json.dumps(
            {"terrain": str(args.terrain), "profile": profile.name, "frames": frames,
             "rows": rows, "peers": peers}, indent=1).encode())
        from ..study.terrain import path_frames
        from ..study.terrain_report import recommend, terrain_picture

        picture = terrain_picture(heightmap, [(f"{kind} {speed}",
                                               path_frames(heightmap, kind, speed, frames))
                                              for kind, speed in paths])
        report = write_terrain_report(
            rows, report_path, title=f"vismobile terrain comparison: {heightmap.name}",
            notes=f"{args.terrain}: {heightmap.size}^2 samples; {profile.name} "
                  f"({profile.resolution[0]}x{profile.resolution[1]}); frames {frames} of each "
                  "path." + (f" {len(placement)} objects on it, culled by vfc+horizon over "
                             "octree:4 and drawn at their LOD within each row's tau."
                             if len(placement) else ""), peers=peers, picture=picture)
    dropped = sum(r.get("objects_dropped", 0) for r in rows)
    if len(placement):
        print(f"objects: {dropped} visible object triangles dropped over every method, path "
              "and tau (item buffer of the drawn ground and every object)")
    for path, row, met in recommend(rows):
        print(f"use on the {path} path: {row['method']}, tau {row['tau']:g} px "
              f"({row['triangles']:,.0f} triangles, {row['lod_ms'] + row['render_ms']:.2f} ms "
              f"LOD + render here, sample error {row['sample_error_max']:.2f} px"
              + ("" if met else "; none stays within 1 px: the smallest error") + ")")
    print(f"wrote {args.out / 'terrain.csv'}, {args.out / 'terrain.json'} and {report}")
    return 0

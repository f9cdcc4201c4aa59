"""`vismobile play WORLD --trajectory CSV ...`: cull and render a recorded path, log each frame."""
from pathlib import Path

from . import (CULL_HELP, DEFAULT_CULL, default_cull, DEFAULT_STRUCTURE, FIX_WINDING_HELP, FRAMES_HELP,
               REPAIR_HELP, REPAIRS, FPS_HELP, MOTION_HELP, PROFILE_HELP, STRUCTURE_HELP,
               WORLD_HELP, default_trajectory, warn_winding)


def add_parser(sub):
    parser = sub.add_parser(
        "play", help="play a trajectory through a (partitioned) world; write frames.csv, "
                     "summary.json and optional images")
    parser.add_argument("world", help=WORLD_HELP + ", a partition file (.vmp), or a terrain "
                        "(.vmt: played with its LOD method, --terrain-method, at --lod pixels)")
    parser.add_argument("--trajectory", type=Path, default=None,
                        help="trajectory CSV (default for w1..w6: the thesis's path, indoor for "
                             "w1-w4, outdoor for w5, w6; for a .vmt terrain one lap of its "
                             "fast circle path; a mesh file needs one: `vismobile "
                             "trajectory generate MESH -o walk.csv` makes it)")
    parser.add_argument("--structure", default=DEFAULT_STRUCTURE,
                        help="partition to build for a mesh: " + STRUCTURE_HELP
                             + f" (default {DEFAULT_STRUCTURE}, as in view)")
    parser.add_argument("--cull", default=None,
                        help=CULL_HELP + f" (default {DEFAULT_CULL}, as in view; none with --structure none)")
    parser.add_argument("--profile", default="ipaq-hx2490b",
                        help=PROFILE_HELP + " (default ipaq-hx2490b)")
    parser.add_argument("--vertex-format", choices=("float32", "fixed16.16"),
                        help="override the profile's vertex format")
    parser.add_argument("-o", "--out", type=Path, required=True, help="output folder")
    parser.add_argument("--frames", default="all", help=FRAMES_HELP + " (default all)")
    parser.add_argument("--fix-winding", action="store_true", help=FIX_WINDING_HELP)
    parser.add_argument("--repair", choices=REPAIRS, default="none", help=REPAIR_HELP)
    parser.add_argument("--images", type=int, default=0, metavar="N",
                        help="save every Nth played frame as PNG under OUT/frames/ (default 0: "
                             "none)")
    parser.add_argument("--gif", action="store_true",
                        help="write OUT/run.gif (at most 120 frames evenly over the run, whatever "
                             "--images is)")
    parser.add_argument("--hud", action="store_true",
                        help="draw algorithms, memory, triangles sent and fps onto images")
    parser.add_argument("--limit", type=int, default=None, metavar="F",
                        help="play only the first F frames")
    parser.add_argument("--adaptive", action="store_true",
                        help="switch stages off while they cost more than they save")
    parser.add_argument("--lod", "--lod-tau", dest="lod_tau", type=float, default=None,
                        metavar="PX",
                        help="level of detail: a .vmt terrain's ground within PX pixels by "
                             "its --terrain-method (default 1); draw each object at its "
                             "coarsest level whose "
                             "error projects below PX pixels (0: full detail), and measure "
                             "every frame against the full-detail frame (PSNR in summary.json); "
                             "needs --structure or a .vmp (its LOD chains are built when it "
                             "has none: partition --lod stores them)")
    parser.add_argument("--terrain-method", choices=("tiles", "roettger", "roam"),
                        default=None,
                        help="a .vmt terrain's LOD method: tiles (seed 002's tile quadtree), "
                             "roettger (Röttger's quadtree with Pires's cached chunks), roam "
                             "(split and merge queues); default tiles (a paged .vmtiles or "
                             ".vmrpages terrain: its own method)")
    parser.add_argument("--regional", default=None, metavar="CHOICES",
                        help="pick per portal cell of the eye the cheapest of these stage "
                             "combinations (separated by ;, e.g. "
                             "'portals+tbfc;vfc+occlusion+tbfc'), priced by the iPaq model "
                             "on each region's first 2 frames; needs a portal structure")
    parser.add_argument("--motion", type=Path, default=None, metavar="FILE.json",
                        help=MOTION_HELP)
    parser.add_argument("--fps", type=float, default=None, help=FPS_HELP)
    parser.add_argument("--measure-error", action="store_true",
                        help="a .vmt terrain: also measure each frame's exact largest screen "
                             "error at the samples (frames.csv sample_error_px; untimed)")
    parser.add_argument("--no-object-lod", action="store_true",
                        help="a .vmt terrain's objects at full detail (default: at their "
                             "coarsest LOD level within the same --lod pixels; chains built "
                             "once, then cached beside the built worlds)")
    parser.add_argument("--page-budget", type=float, default=16.0, metavar="MB",
                        help="a .vmtiles or .vmrpages terrain (terrain tile) is paged in: the "
                             "memory its tile records or Röttger pages may hold (default 16 MB)")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
    return parser


def run(args) -> int:
    import os

    # One llvmpipe thread, as every compare and tune run measures (study/tasks.py): on a
    # loaded machine the render threads' contention made the median swing several-fold.
    os.environ.setdefault("LP_NUM_THREADS", "1")
    if str(args.world).lower().endswith((".vmt", ".vmtiles", ".vmrpages")):
        return run_terrain(args)
    args.cull = default_cull(args.cull, args.structure)
    from ..app.playback import load_scene, parse_stages, play
    from ..device.profile import get_profile
    from ..world.trajectory import Trajectory

    check_folder(args.out)  # before loading and playing, not after (issue 28)
    profile = get_profile(args.profile, args.vertex_format)
    trajectory = Trajectory.load(default_trajectory(args.world, args.trajectory),
                                 limit=args.limit)
    from ..progress import Status

    with Status(f"play {args.world}", enabled=not args.quiet) as status:
        status("loading the world")
        scene = load_scene(args.world, args.structure, progress=not args.quiet,
                           fix_winding=args.fix_winding, eyes=trajectory.poses[:, :3],
                           repair=args.repair,
                           motion=args.motion, fps=args.fps)
        status("checking the winding")
        warn_winding(scene.world, parse_stages(args.cull), args.world,
                     trajectory.poses[:, :3], args.fix_winding)
    result = play(scene, trajectory, args.cull, profile, args.out, frames_every=args.images,
                  gif=args.gif, hud=args.hud, progress=not args.quiet, frame_limit=args.limit,
                  adaptive=args.adaptive, frames=args.frames, lod_tau=args.lod_tau,
                  regional=regional_choices(args.regional))
    s = result.summary
    corr = s["pearson_frame_ms_triangles"]
    print(f"{s['frames']} frames of {s['world']} ({s['structure']}, cull "
          f"{'+'.join(s['stages']) or 'none'}, {s['profile']}): "
          f"{s['triangles_sent']['mean']:,.0f} triangles sent per frame on average; "
          f"{correlation_words(corr)}")
    if s.get("lod_tau") is not None:
        low, mean = s["psnr_db_min"], s["psnr_db_mean"]
        print(f"  level of detail at {s['lod_tau']:g} px: "
              f"{s['triangles_full']['mean']:,.0f} triangles at full detail; PSNR "
              + ("identical on every frame" if low is None else
                 f"min {low:.1f} dB, mean {mean:.1f} dB, largest difference {s['max_diff']}"))
    # The profile's own device first; every figure says whether it is measured or modelled.
    devices = sorted(s["model"], key=lambda d: d != s["profile"])
    for device in devices:
        model = s["model"][device]
        print(f"  {model['label']:>20}: {model['frame_ms']['mean']:8.2f} ms/frame, "
              f"{model['fps']:.2f} fps")
    cpu = s.get("cpu_ms")
    print(f"  {s['timing']:>20}: {s['frame_ms']['median']:8.2f} ms/frame median "
          f"(mean {s['frame_ms']['mean']:.2f}, {s['fps']:.1f} fps; this machine, not the device)"
          + (f"; CPU {cpu['median']:.2f} ms/frame median" if cpu else ""))
    print(f"  {'warm-up':>20}: {s['warmup_ms'] / 1000:8.2f} s before the first measured frame "
          f"({s['warmup_compile_ms'] / 1000:.1f} s of it numba's first-use compile; in no "
          "figure)"
          + (f"; {s['compile_ms'] / 1000:.2f} s more compiling during frames, those timed "
             "again" if s.get("compile_ms") else ""))
    memory = s["memory"]["total"] / (1 << 20)
    print(f"  memory {memory:.1f} MB of the {s['profile']} heap of "
          f"{s['heap_bytes'] / (1 << 20):.0f} MB")
    for event in s["adaptive_events"]:
        print(f"frame {event['frame']}: {event['stage']} {event['action']} (saves "
              f"{event['saving_ms']:.3f} ms, costs {event['cost_ms']:.3f} ms per frame)")
    for region, choice in (s.get("regional") or {}).items():
        print(f"  region (portal cell) {region}: {choice}")
    if s.get("moving_objects"):
        print(f"  {s['moving_objects']:,} moving objects, frame f at t = f / {s['scene_fps']:g} s")
    print(f"wrote {args.out}/frames.csv and {args.out}/summary.json")
    return 0


def regional_choices(text):
    """--regional text -> canonical stage strings (compare's --cull grammar: ; separates), or
    None; VisMobileError on a bad one."""
    if text is None:
        return None
    from ..errors import VisMobileError
    from ..study.matrix import parse_culls

    try:
        choices = [c for c in parse_culls(text) if c != "none"]
    except ValueError as error:
        raise VisMobileError(f"--regional {text!r}: {error}") from None
    if not choices:
        raise VisMobileError(f"--regional {text!r}: no stage combination")
    return choices


def run_terrain(args) -> int:
    """play for a .vmt: the terrain's LOD method at --lod pixels, its objects culled by --cull
    (default vfc+horizon) over --structure (app/terrain_play.py)."""
    import os

    os.environ.setdefault("LP_NUM_THREADS", "1")
    from ..app.playback import parse_stages
    from ..app.terrain_play import play_terrain, terrain_camera_options
    from ..app.terrain_scene import TerrainScene, default_cameras
    from ..errors import VisMobileError
    from ..progress import Status
    from ..world.trajectory import Trajectory, select_frames

    check_folder(args.out)
    if args.adaptive or args.fix_winding or args.gif or args.hud or args.repair != "none":
        raise VisMobileError("--adaptive, --fix-winding, --repair, --gif and --hud apply to "
                             "triangle "
                             "worlds, not to a .vmt terrain")
    stages = parse_stages(args.cull if args.cull is not None else "vfc+horizon")
    tau = 1.0 if args.lod_tau is None else args.lod_tau
    with Status(f"play {args.world}", enabled=not args.quiet) as status:
        from ..scenes.thesis import default_cache_dir

        status("loading the terrain, its LOD method and its objects' LOD chains (built once, "
               "then cached)")
        scene = TerrainScene(args.world, args.terrain_method, tau, stages, args.structure,
                             args.profile, int(args.page_budget * (1 << 20)),
                             object_lod=not args.no_object_lod, cache_dir=default_cache_dir())
    aspect = scene.profile.aspect
    if args.trajectory is not None:
        trajectory = Trajectory.load(args.trajectory, limit=args.limit,
                                     **terrain_camera_options(scene.heightmap))
        count, waypoints = len(trajectory), trajectory.waypoints
    else:
        cameras = default_cameras(scene.heightmap, args.limit, aspect)
        count, waypoints = len(cameras), {}
    try:
        played = select_frames(args.frames, count, waypoints)
    except ValueError as error:
        raise VisMobileError(f"--frames: {error}") from None
    if args.trajectory is not None:
        cameras = [trajectory.camera(f, aspect) for f in played]
    else:
        cameras = [cameras[f] for f in played]
    labels = {int(f): label for label, f in waypoints.items()}
    s = play_terrain(scene, cameras, labels, args.out, args.images, not args.quiet, played,
                     measure=args.measure_error)
    if not s["frames"]:
        print(f"0 frames of {s['world']}")
        return 0
    print(f"{s['frames']} frames of {s['world']} ({scene.heightmap.size}^2, "
          f"{s['method']} at {s['tau']:g} px; objects: {len(scene.placement)}, "
          f"{scene.structure}, cull {'+'.join(stages) or 'none'}): "
          f"{s['ground_triangles']['mean']:,.0f} ground and "
          f"{s['object_triangles']['mean']:,.0f} object triangles per frame on average; "
          f"error bound at most {s['error_px_max']:.3f} px"
          + (f", measured at most {s['sample_error_px_max']:.3f} px"
             if s.get("sample_error_px_max") is not None else ""))
    print(f"  {s['frame_ms']['median']:8.2f} ms/frame median on this machine (LOD "
          f"{s['lod_ms']['median']:.2f}, cull {s['cull_ms']['median']:.2f}, render "
          f"{s['render_ms']['median']:.2f})")
    print(f"wrote {args.out}/frames.csv and {args.out}/summary.json")
    return 0


def check_folder(out: Path) -> None:
    """OutputError naming out when a run folder cannot be made there: a file or special file,
    a path under a file, or a nearest existing folder where nothing can be created (probed
    with a temporary folder, removed at once: permissions alone do not stop root)."""
    import os
    import tempfile

    from ..files.atomic import check_destination
    from ..errors import OutputError

    out = Path(out)
    if out.exists() and not out.is_dir():
        raise OutputError(out, "is not a folder; give a folder for the run")
    check_destination(out / "summary.json")
    existing = next((p for p in (out, *out.parents) if p.is_dir()), Path("."))
    try:
        os.rmdir(tempfile.mkdtemp(prefix=".vismobile-probe-", dir=existing))
    except OSError as error:
        raise OutputError(out, f"cannot write in {existing}: {error.strerror or error}") from None


def correlation_words(r) -> str:
    """Pearson's r of frame time against triangles sent, in words."""
    if r is None:
        return "frame time against triangles sent: no correlation (constant)"
    strength = "strong" if abs(r) >= 0.7 else "moderate" if abs(r) >= 0.3 else "weak or none"
    meaning = ("; the time follows the triangles" if r >= 0.7 else
               "; the time hardly depends on the triangle count" if abs(r) < 0.3 else "")
    return f"frame time against triangles sent: r = {r:+.2f} ({strength}{meaning})"

"""`vismobile tune WORLD`: choose structure, parameters and culling stages from a cheap probe.

With a device profile (ipaq-hx2490b, nokia-n82) the choice minimises the frame time the
profile's device model predicts on that device; `--measured` minimises this machine's.
"""
from pathlib import Path

from . import (BACKFACE_NAMES, FIX_WINDING_HELP, PROFILE_HELP, REPAIR_HELP, REPAIRS,
               WORLD_HELP, WORLDS_DIR_HELP, fix_winding, warn_winding)

# The same default as tune() (study/tune.py PROBE_FRAMES; tests/study/test_tune.py checks), kept
# here so that `--help` needs no heavy import.
PROBE_FRAMES = 24


def add_parser(sub):
    parser = sub.add_parser("tune", help="pick the fastest conservative configuration for a world")
    parser.add_argument("world", help=WORLD_HELP + ", or a terrain (.vmt: picks its LOD method "
                        "and tau within --max-error-px, default 1, over the probe frames of "
                        "--trajectory or its fast circle path)")
    parser.add_argument("--trajectory", type=Path, default=None,
                        help="trajectory CSV (default: the thesis's path for w1..w6)")
    parser.add_argument("--profile", default="ipaq-hx2490b",
                        help=PROFILE_HELP + " (default ipaq-hx2490b)")
    parser.add_argument("--probe", type=int, default=PROBE_FRAMES,
                        help="evenly spaced probe frames, the waypoints added (default 24)")
    parser.add_argument("--structures", default="grid,octree:3-6,portal:1-3,bsp,kdtree",
                        help="comma-separated candidates: grid, octree[:N or A-B], portal[:N or "
                             "A-B], bsp, kdtree, all (default grid,octree:3-6,portal:1-3,bsp,kdtree); "
                             "+pvs bakes a conservative PVS on one (portal:2+pvs), "
                             "+pvs=sampled:N an aggressive sampled one")
    parser.add_argument("--pvs", action="store_true",
                        help="also consider baked PVS configurations: adds portal:2+pvs and "
                             "bsp+pvs to --structures (each bake is cached with --cache)")
    parser.add_argument("--worlds-dir", type=Path, default=None,
                        help=WORLDS_DIR_HELP)
    parser.add_argument("--cache", type=Path, default=None,
                        help="folder to keep partition files and ground truths in (default: "
                             "none, build afresh)")
    parser.add_argument("--cost", choices=("device", "measured"), default="device",
                        help="device: minimise the frame time the profile's device model predicts "
                             "(iPaq, N82); measured: this machine's wall time (desktop always)")
    parser.add_argument("--measured", dest="cost", action="store_const", const="measured",
                        help="same as --cost measured")
    parser.add_argument("-o", "--out", "--json", dest="out", type=Path, default=None,
                        help="also write the result as JSON to this file")
    parser.add_argument("--fix-winding", action="store_true", help=FIX_WINDING_HELP)
    parser.add_argument("--repair", choices=REPAIRS, default="none",
                        help=REPAIR_HELP + " (a static world only)")
    parser.add_argument("--max-error-px", type=float, default=None, metavar="PX",
                        help="also pick the level-of-detail tolerance for the chosen "
                             "configuration: the fastest tau up to PX pixels of projected "
                             "error, with its PSNR against full detail (docs/lod.md)")
    parser.add_argument("--no-object-lod", action="store_true",
                        help="a .vmt terrain's objects at full detail (default: each candidate "
                             "draws them at their coarsest LOD level within its tau, as play "
                             "does; chains built once, then cached beside the built worlds)")
    parser.add_argument("--quiet", action="store_true", help="no status lines on stderr")
    return parser


def run(args) -> int:
    if str(args.world).lower().endswith(".vmt"):
        return run_terrain(args)
    import json

    from ..files.atomic import check_destination
    from ..errors import TrajectoryError
    from ..device.profile import get_profile
    from ..study import engine
    from ..study.thesis import NAMED_WORLDS as WORLDS, trajectory_for
    from ..study.candidates import PVS_STRUCTURES
    from ..study.tune import tune
    from ..world.trajectory import Trajectory
    from ..world.world import atomic_write_bytes

    if args.out:
        check_destination(args.out)  # before tuning, not after
    if args.probe < 1:
        raise TrajectoryError(f"--probe must be at least 1 frame, got {args.probe}")
    if args.trajectory is None and args.world.lower() not in WORLDS:
        raise TrajectoryError(f"{args.world}: not a thesis world; pass --trajectory")
    from ..scenes.thesis import default_cache_dir

    from ..progress import Status

    from ..timing import compile_seconds

    compiling = compile_seconds()
    with Status(f"tune {args.world}", enabled=not args.quiet) as status:
        status("loading the world (compiling on a first run)")
        world = engine.load_world(args.world.lower() if args.world.lower() in WORLDS
                                  else args.world, args.worlds_dir or default_cache_dir(),
                                  args.repair)
        trajectory = Trajectory.load(args.trajectory or trajectory_for(args.world.lower()))
        world = fix_winding(world, args.fix_winding, trajectory.poses[:, :3])
        status("checking the winding")
        warn_winding(world, BACKFACE_NAMES, args.world, trajectory.poses[:, :3],
                     args.fix_winding)
        status(f"{world.triangle_count:,} triangles; ground truth of {args.probe} probe frames "
               "plus the waypoints")
        result = tune(world, trajectory, get_profile(args.profile), probe=args.probe,
                      structures=args.structures + ("," + PVS_STRUCTURES if args.pvs else ""),
                      cache_dir=args.cache, cost=args.cost,
                      progress=lambda done, _: status(f"{done} structure(s) probed"))
        lod = None
        if args.max_error_px is not None:
            from ..study.lod_tune import pick_tau

            status(f"level of detail up to {args.max_error_px:g} px")
            lod = pick_tau(world, trajectory, get_profile(args.profile),
                           result.choice.structure, result.choice.cull, result.frames,
                           args.max_error_px, args.cache)
    print(result.report())
    compiled = compile_seconds() - compiling
    if compiled >= 1.0:  # a first run: say where the time went (no probe figure holds it)
        print(f"numba's first-use compile took {compiled:.0f} s of this run (timed apart; a "
              "second run loads its cache)")
    output = result.to_dict()
    if args.repair != "none":  # the world tuned is not the file's geometry: say so
        print(f"world repaired first: {args.repair} ({world.triangle_count:,} triangles)")
        output["repair"] = args.repair
    if lod is not None:
        from ..study.lod_tune import report_lines

        print("\n".join(report_lines(lod)))
        output["lod"] = lod
    if args.out:
        atomic_write_bytes(args.out, json.dumps(output, indent=1).encode())
    return 0



def run_terrain(args) -> int:
    """tune for a .vmt (app/terrain_tune.py): every method at taus within --max-error-px over
    --probe frames; prints the table and the choice, -o writes it as JSON."""
    import json

    import numpy as np

    from ..app.terrain_play import terrain_camera_options
    from ..app.terrain_scene import default_cameras
    from ..app.terrain_tune import report, tune_terrain
    from ..device.profile import get_profile
    from ..errors import VisMobileError
    from ..files.atomic import atomic_write_bytes, check_destination
    from ..progress import Status
    from ..terrain import store
    from ..world.trajectory import Trajectory

    if args.out:
        check_destination(args.out)
    if args.fix_winding or args.pvs or args.repair != "none":
        raise VisMobileError("--fix-winding, --pvs and --repair apply to triangle worlds, not "
                             "to a .vmt")
    profile = get_profile(args.profile)
    heightmap, _ = store.load(args.world)
    if args.trajectory is not None:
        trajectory = Trajectory.load(args.trajectory, **terrain_camera_options(heightmap))
        pick = np.unique(np.linspace(0, len(trajectory) - 1, args.probe).astype(int))
        cameras = [trajectory.camera(int(f), profile.aspect) for f in pick]
    else:
        lap = default_cameras(heightmap, None, profile.aspect)
        pick = np.unique(np.linspace(0, len(lap) - 1, args.probe).astype(int))
        cameras = [lap[int(f)] for f in pick]
    from ..scenes.thesis import default_cache_dir

    with Status(f"tune {args.world}", enabled=not args.quiet) as status:
        result = tune_terrain(args.world, cameras, profile,
                              max_error_px=1.0 if args.max_error_px is None
                              else args.max_error_px,
                              cost=args.cost, progress=status,
                              object_lod=not args.no_object_lod,
                              cache_dir=default_cache_dir())
    print(report(result))
    if args.out:
        atomic_write_bytes(args.out, (json.dumps(result, indent=2) + "\n").encode())
        print(f"wrote {args.out}")
    return 0

"""`vismobile view WORLD ...`: fly through a world with the thesis's HUD, toggles and recorder."""
from pathlib import Path

from . import (CULL_HELP, DEFAULT_CULL, default_cull, DEFAULT_STRUCTURE, FIX_WINDING_HELP, FPS_HELP,
               MOTION_HELP, STRUCTURE_HELP, WORLD_HELP)


def add_parser(sub):
    parser = sub.add_parser(
        "view", help="open a window and fly through a world (joystick keys, stage toggles, "
                     "HUD, god view, trajectory recorder); F1 in the window lists the keys")
    parser.add_argument("world", help=WORLD_HELP + ", a partition file (.vmp), or a terrain "
                        "(.vmt: a flythrough of its LOD method; T cycles tau, M the method)")
    parser.add_argument("--structure", default=DEFAULT_STRUCTURE,
                        help="partition to start with (Tab cycles): " + STRUCTURE_HELP
                             + f" (default {DEFAULT_STRUCTURE}, as in play)")
    parser.add_argument("--cull", default=None,
                        help="stages on at start (number keys toggle): " + CULL_HELP
                             + f" (default {DEFAULT_CULL}, as in play; none with --structure none)")
    parser.add_argument("--profile", default="ipaq-hx2490b",
                        help="device profile: its screen, scaled up, is the view (desktop: the "
                             "window's size); ipaq-hx2490b, nokia-n82, desktop")
    parser.add_argument("--trajectory", type=Path, help="trajectory CSV that L loads and plays; "
                        "the camera starts at its first pose (default for w1..w6: the thesis's "
                        "path)")
    parser.add_argument("--record-to", type=Path, default=Path("recorded.csv"),
                        help="where V saves the recorded trajectory (default recorded.csv)")
    parser.add_argument("--scale", type=int, default=2,
                        help="whole-number zoom of the device screen (default 2)")
    parser.add_argument("--fix-winding", action="store_true", help=FIX_WINDING_HELP)
    parser.add_argument("--lod", type=float, default=1.0, metavar="PX",
                        help="a .vmt terrain's tau at start, pixels (default 1; T cycles "
                             "0.5, 1, 2, 4, 8)")
    parser.add_argument("--terrain-method", choices=("tiles", "roettger", "roam"),
                        default=None,
                        help="a .vmt terrain's LOD method at start (default tiles; M cycles; "
                             "a paged .vmtiles or .vmrpages terrain: its own)")
    parser.add_argument("--no-object-lod", action="store_true",
                        help="a .vmt terrain's objects at full detail (default: at their "
                             "coarsest LOD level within the terrain's tau, which T cycles; "
                             "chains built once, then cached beside the built worlds)")
    parser.add_argument("--motion", type=Path, default=None, metavar="FILE.json",
                        help=MOTION_HELP)
    parser.add_argument("--fps", type=float, default=None, help=FPS_HELP)
    parser.add_argument("--script", help=argparse_suppress(), default=None)
    parser.add_argument("--screenshot", type=Path, help=argparse_suppress(), default=None)
    return parser


def run_terrain(args, script) -> int:
    """view for a .vmt: viewer/terrain_session.py (objects culled by --cull, default
    vfc+horizon, over --structure)."""
    from ..app.playback import parse_stages
    from ..viewer.terrain_session import TerrainSession
    from ..viewer.window import run as run_window

    from ..progress import Status
    from ..scenes.thesis import default_cache_dir

    stages = parse_stages(args.cull if args.cull is not None else "vfc+horizon")
    with Status(f"view {args.world}") as status:
        status("loading the terrain, its LOD method and its objects' LOD chains (built once, "
               "then cached)")
        session = TerrainSession.open_terrain(args.world, args.terrain_method, args.lod, stages,
                                              args.structure, args.profile, args.trajectory,
                                              object_lod=not args.no_object_lod,
                                              cache_dir=default_cache_dir(),
                                              record_path=args.record_to)
    from ..render.context import release_current

    release_current()  # the scene built its buffers in the headless context: free the thread
    frames = run_window(session, args.scale, script, args.screenshot)
    if script is None:
        print(f"{frames} frames; {session.message or 'bye'}")
    return 0


def argparse_suppress():
    import argparse

    return argparse.SUPPRESS  # --script KEYS --screenshot PNG: scripted runs for tests


def run(args) -> int:
    args.cull = default_cull(args.cull, args.structure)
    from ..errors import VisMobileError
    from ..viewer import Session
    from ..viewer.keys import parse_script

    if args.scale < 1:
        raise VisMobileError(f"--scale must be >= 1, got {args.scale}")
    try:
        script = parse_script(args.script) if args.script else None
    except ValueError as error:
        raise VisMobileError(f"--script: {error}") from None
    if args.screenshot is not None and script is None:
        raise VisMobileError("--screenshot needs --script")
    from . import THESIS_WORLDS, default_trajectory

    if str(args.world).lower().endswith((".vmt", ".vmtiles", ".vmrpages")):
        return run_terrain(args, script)
    trajectory = args.trajectory
    if trajectory is None and str(args.world).lower() in THESIS_WORLDS:
        trajectory = default_trajectory(args.world, None)  # the thesis's path: L plays it
    session = Session.open(args.world, args.structure, args.cull, args.profile,
                           trajectory, fix_winding=args.fix_winding,
                           record_path=args.record_to, motion=args.motion, fps=args.fps)
    from . import warn_winding
    from ..viewer.window import run as run_window

    eyes = None
    if session.trajectory_path is not None:
        from ..world.trajectory import Trajectory

        eyes = Trajectory.load(session.trajectory_path).poses[:, :3]
    warn_winding(session.world, session.stages, args.world, eyes, args.fix_winding)

    frames = run_window(session, args.scale, script, args.screenshot)
    if script is None:
        print(f"{frames} frames; {session.message or 'bye'}")
    return 0

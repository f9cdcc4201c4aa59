"""`vismobile trajectory generate WORLD`: a collision-free walk or a fly-over, with waypoints."""
from pathlib import Path

from . import FIX_WINDING_HELP, PROFILE_HELP, WORLD_HELP, fix_winding


def add_parser(sub):
    parser = sub.add_parser("trajectory", help="make a camera path (trajectory CSV) for a world")
    actions = parser.add_subparsers(dest="action", required=True)
    gen = actions.add_parser(
        "generate", help="a collision-free walk at eye height through an indoor world's free "
                         "space, or a fly-over of an outdoor one; waypoints where the camera "
                         "sees most and least",
        description="Indoor (most free cells at eye height have geometry above them): a walk "
                    "through the largest free region, clear of every triangle. Outdoor: an "
                    "elliptical fly-over above the highest point, looking at the centre. "
                    "Waypoints (the CSV's waypoint column): most_visible, least_visible "
                    "(distinct triangles in the item buffers of sampled frames), "
                    "most_in_frustum, least_in_frustum (triangle boxes meeting the frustum).")
    gen.add_argument("world", help=WORLD_HELP)
    gen.add_argument("-o", "--out", type=Path, default=None,
                     help="trajectory CSV to write (default: WORLDNAME-walk.csv or "
                          "WORLDNAME-flyover.csv here)")
    gen.add_argument("--seed", type=int, default=0,
                     help="where the walk starts and which way the fly-over turns (default 0); "
                          "the same seed gives the same file")
    gen.add_argument("--length", type=int, default=600, metavar="FRAMES",
                     help="frames in the path (default 600)")
    gen.add_argument("--eye-height", type=float, default=None,
                     help="eye above the world's lowest point, world units (default 1.7, at "
                          "most half the world's height)")
    gen.add_argument("--clearance", type=float, default=None,
                     help="distance kept from every triangle, world units (default 0.3, at most "
                          "1/20 of the world's shorter side)")
    gen.add_argument("--profile", default="ipaq-hx2490b",
                     help=PROFILE_HELP + ": the screen whose item buffers count visible "
                          "triangles (default ipaq-hx2490b)")
    gen.add_argument("--fix-winding", action="store_true", help=FIX_WINDING_HELP)
    gen.add_argument("--quiet", action="store_true", help="no status lines on stderr")
    return parser


def run(args) -> int:
    import numpy as np

    from ..files.atomic import check_destination
    from ..errors import VisMobileError
    from ..device.profile import get_profile
    from ..progress import Status
    from ..files.loader import open_world
    from ..world.trajectory import MAX_FRAMES, Trajectory
    from ..app.walk import counts, walk, waypoints

    if not 2 <= args.length <= MAX_FRAMES:
        raise VisMobileError(f"--length must be 2..{MAX_FRAMES:,} frames, got {args.length}")
    for name, value in (("--eye-height", args.eye_height), ("--clearance", args.clearance)):
        if value is not None and not value > 0:
            raise VisMobileError(f"{name} must be a positive number, got {value}")
    profile = get_profile(args.profile)
    if args.out:
        check_destination(args.out)
    with Status(f"trajectory {args.world}", enabled=not args.quiet) as status:
        status("loading the world")
        world = fix_winding(open_world(args.world), args.fix_winding)
        low, high = world.extent
        wide = float(max(high[0] - low[0], high[2] - low[2]))
        tall = float(high[1] - low[1])
        if args.eye_height is not None and args.eye_height >= tall:
            raise VisMobileError(f"--eye-height {args.eye_height:g} is at or above the top of "
                                 f"{args.world} ({tall:g} above its lowest point)")
        if args.clearance is not None and 2 * args.clearance >= wide:
            raise VisMobileError(f"--clearance {args.clearance:g} blocks the whole of "
                                 f"{args.world} ({wide:g} wide); give less than {wide / 2:g}")
        status(f"{world.triangle_count:,} triangles; free space at eye height")
        poses, kind, space = walk(world, args.length, args.seed, args.eye_height,
                                  args.clearance)
        out = args.out or Path(f"{world.name}-{kind.replace('-', '')}.csv")
        check_destination(out)
        trajectory = Trajectory(poses)
        status(f"{kind} of {len(trajectory)} frames; counting what each frame sees")
        in_frustum, frames, visible = counts(world, trajectory, profile)
        trajectory.waypoints = waypoints(in_frustum, frames, visible)
    trajectory.save(out)
    steps = np.linalg.norm(np.diff(poses[:, :3], axis=0), axis=1) if len(poses) > 1 else [0]
    where = (f"at eye height y = {space.eye:.3g} (free space on a {space.cell:.3g}-unit grid)"
             if kind == "walk" else f"at y = {poses[0, 1]:.3g}, above the top")
    print(f"wrote {out}: {kind} of {len(trajectory)} frames {where}, "
          f"{float(np.sum(steps)):.4g} units long")
    seen = dict(zip(frames.tolist(), visible.tolist()))
    for label, frame in trajectory.waypoints.items():
        shown = f", {seen[frame]:,} visible" if frame in seen else ""
        print(f"  {label:17s} frame {frame:5d}: {in_frustum[frame]:,} triangles in the "
              f"frustum{shown}")
    print(f"  triangles in the frustum on {np.mean(in_frustum > 0):.0%} of frames; "
          f"visible on {np.mean(visible > 0):.0%} of {len(frames)} sampled frames")
    return 0


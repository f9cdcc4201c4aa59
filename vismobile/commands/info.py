"""`vismobile info WORLD`: triangles, objects, bounds, size and winding of a world or mesh."""
from pathlib import Path

from . import FIX_WINDING_HELP, REPAIR_HELP, REPAIRS, WORLD_HELP


def add_parser(sub):
    parser = sub.add_parser("info", help="print a world's triangles, objects, bounds, size and "
                                         "winding (consistency, closed rooms, open edges)")
    parser.add_argument("world", help=WORLD_HELP)
    parser.add_argument("--fix-winding", action="store_true", help=FIX_WINDING_HELP
                        + "; prints the winding before and after")
    parser.add_argument("--repair", choices=REPAIRS, default="none", help=REPAIR_HELP)
    parser.add_argument("-o", "--out", type=Path, default=None,
                        help="write the world (after --repair and --fix-winding) as an OBJ file")
    return parser


def run(args) -> int:
    from ..files.atomic import check_destination
    from ..progress import Status
    from ..scenes.lookup import world_file
    from ..world.winding import check_winding, fixed_world
    from ..files.loader import load_world

    if args.out:
        check_destination(args.out)
    with Status(f"info {args.world}") as status:
        status("loading the world")
        path = world_file(args.world)
        world = load_world(path)
        if args.repair != "none":
            from ..files.loader import repaired

            status("repairing the world")
            source, world = world, repaired(world, args.repair, path)
        status("checking the winding")
        report = check_winding(world)
        if args.fix_winding:
            fixed, _ = fixed_world(world, report)
            after = check_winding(fixed)
    low, high = world.extent
    print(f"file       {path}")
    print(f"triangles  {world.triangle_count:,}")
    print(f"vertices   {len(world.vertices):,}")
    print(f"objects    {len(world.object_names)}")
    if args.repair != "none":
        print(f"repair     {args.repair}: {source.triangle_count:,} -> "
              f"{world.triangle_count:,} triangles (ids change)")
    print(f"bounds     min ({low[0]:.4g}, {low[1]:.4g}, {low[2]:.4g})"
          f"  max ({high[0]:.4g}, {high[1]:.4g}, {high[2]:.4g})")
    print(f"file size  {path.stat().st_size / 1024:,.1f} KB")
    _print_winding("winding", report.lines())
    if args.fix_winding:
        world = fixed
        _print_winding("fixed", after.lines())
    elif report.to_fix:
        print("           (reverse them with --fix-winding here or on partition, play, tune)")
    if args.out:
        world.to_obj(args.out)
        print(f"wrote {args.out}")
    return 0


def _print_winding(label, lines):
    for i, line in enumerate(lines):
        print(f"{label if i == 0 else '':10} {line}")

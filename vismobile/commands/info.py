"""`vismobile info WORLD`: triangles, objects, bounds and file size of a thesis world or mesh."""
from . import WORLD_HELP


def add_parser(sub):
    parser = sub.add_parser("info", help="print a world's triangles, objects, bounds and size")
    parser.add_argument("world", help=WORLD_HELP)
    return parser


def run(args) -> int:
    from ..scenes.lookup import world_file
    from ..world import World

    path = world_file(args.world)
    world = World.from_file(path)
    low, high = world.extent
    print(f"file       {path}")
    print(f"triangles  {world.triangle_count:,}")
    print(f"vertices   {len(world.vertices):,}")
    print(f"objects    {len(world.object_names)}")
    print(f"bounds     min ({low[0]:.4g}, {low[1]:.4g}, {low[2]:.4g})"
          f"  max ({high[0]:.4g}, {high[1]:.4g}, {high[2]:.4g})")
    print(f"file size  {path.stat().st_size / 1024:,.1f} KB")
    return 0

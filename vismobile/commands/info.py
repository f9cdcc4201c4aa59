"""`vismobile info WORLD.obj`: triangles, objects, bounds and file size."""
from pathlib import Path


def add_parser(sub):
    parser = sub.add_parser("info", help="print a world's triangles, objects, bounds and size")
    parser.add_argument("world", type=Path, help="OBJ file")
    return parser


def run(args) -> int:
    from ..world import World

    world = World.from_obj(args.world)
    low, high = world.extent
    print(f"file       {args.world}")
    print(f"triangles  {world.triangle_count:,}")
    print(f"vertices   {len(world.vertices):,}")
    print(f"objects    {len(world.object_names)}")
    print(f"bounds     min ({low[0]:.4g}, {low[1]:.4g}, {low[2]:.4g})"
          f"  max ({high[0]:.4g}, {high[1]:.4g}, {high[2]:.4g})")
    print(f"file size  {args.world.stat().st_size / 1024:,.1f} KB")
    return 0

"""`vismobile terrain build|info`: heightmap terrain worlds (.vmt) from DEMs, files or fractals."""
from pathlib import Path


def add_parser(sub):
    parser = sub.add_parser("terrain", help="build or inspect a heightmap terrain world (.vmt)")
    actions = parser.add_subparsers(dest="action", required=True)
    build = actions.add_parser(
        "build", help="write a .vmt terrain from a DEM (jacksboro, topobathy), a file or a fractal")
    build.add_argument("source", help="jacksboro | topobathy | fractal | FILE.npy/.png/.tif")
    build.add_argument("-o", "--out", type=Path, required=True, help="output .vmt file")
    build.add_argument("--size", type=int, default=None,
                       help="samples per side, 2^n+1 (default: 1025 for fractal, else the "
                            "next 2^n+1 at or above the source)")
    build.add_argument("--seed", type=int, default=0, help="fractal and object placement seed")
    build.add_argument("--roughness", type=float, default=0.55, help="fractal octave ratio")
    build.add_argument("--spacing", type=float, default=1.0,
                       help="world units between samples (files and fractals)")
    build.add_argument("--vertical", type=float, default=1.0, help="file value to world units")
    build.add_argument("--objects", type=int, default=0, help="shared models placed on the ground")
    build.add_argument("--object-height", type=float, default=None,
                       help="object height in world units (default 8 spacings)")
    build.add_argument("--obj", type=Path, default=None, help="also export an OBJ world")
    build.add_argument("--obj-stride", type=int, default=1,
                       help="sample stride of the exported mesh (power of two)")
    info = actions.add_parser("info", help="print a .vmt terrain's size, scale and objects")
    info.add_argument("terrain", type=Path)
    return parser


def run(args) -> int:
    if args.action == "info":
        return _info(args)
    from ..errors import WorldError
    from ..terrain import sources, store
    from ..terrain.mesh import terrain_world
    from ..terrain.placement import Placement, place_objects

    if args.size is not None and sources.grid_exponent(args.size) is None:
        raise WorldError(args.out, f"--size must be 2^n+1 (e.g. 1025), got {args.size}")
    from ..progress import Status

    with Status(f"terrain build {args.source}") as status:
        status("making the heightmap")
        if args.source in sources.DEMS:
            heightmap = sources.dem(args.source, args.size)
        elif args.source == sources.SYNTHETIC:
            heightmap = sources.diamond_square(args.size or 1025, args.seed, args.roughness,
                                               spacing=args.spacing)
        else:
            heightmap = sources.load_file(args.source, args.size, args.spacing, args.vertical)
        status("placing objects and writing")
        placement = (place_objects(heightmap, args.objects, args.seed, args.object_height)
                     if args.objects > 0 else Placement.empty())
        store.save(args.out, heightmap, placement)
    print(f"wrote {args.out}: {heightmap.size}^2 samples, spacing {heightmap.spacing:.4g}, "
          f"heights {heightmap.bounds()[0, 1]:.4g}..{heightmap.bounds()[1, 1]:.4g}, "
          f"{len(placement)} objects, {args.out.stat().st_size / 1024:,.0f} KB")
    if args.obj is not None:
        with Status(f"terrain build {args.source}") as status:
            status("exporting the OBJ")
            world = terrain_world(heightmap, placement, args.obj_stride)
            world.to_obj(args.obj)
        print(f"wrote {args.obj}: {world.triangle_count:,} triangles")
    return 0


def _info(args) -> int:
    from ..terrain import store

    heightmap, placement = store.load(args.terrain)
    low, high = heightmap.bounds()
    print(f"file       {args.terrain}")
    print(f"name       {heightmap.name}")
    print(f"samples    {heightmap.size} x {heightmap.size} (2^{heightmap.exponent}+1)")
    print(f"spacing    {heightmap.spacing:.6g}  (extent {heightmap.extent:.6g})")
    print(f"heights    {low[1]:.6g} .. {high[1]:.6g}  (step {heightmap.z_scale:.4g})")
    print(f"full mesh  {2 * (heightmap.size - 1) ** 2:,} triangles")
    print(f"objects    {len(placement)}")
    print(f"file size  {args.terrain.stat().st_size / 1024:,.1f} KB")
    return 0

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
                       help="samples per side, 2^n+1 (default: 1025 for a fractal, else the "
                            "next 2^n+1 at or above the source)")
    build.add_argument("--seed", type=int, default=0, help="fractal and object placement seed (default 0)")
    build.add_argument("--roughness", type=float, default=0.55, help="fractal octave ratio (default 0.55)")
    build.add_argument("--spacing", type=float, default=None,
                       help="world units between samples (files and fractals; default 1, or a "
                            "GeoTIFF's pixel scale)")
    build.add_argument("--vertical", type=float, default=1.0, help="file value to world units (default 1)")
    build.add_argument("--fit", choices=("pad", "resample"), default="pad",
                       help="a file of another size than 2^n+1: pad (default: every sample kept "
                            "at --spacing, the padding no data) or resample (bilinear over the "
                            "same extent)")
    build.add_argument("--nodata", type=float, default=None, metavar="VALUE",
                       help="a file's no-data value (NaN is always no data; a GeoTIFF's own "
                            "GDAL_NODATA tag is read); holes are cut when drawn")
    build.add_argument("--objects", type=int, default=0, help="shared models placed on the ground (default 0)")
    build.add_argument("--object-height", type=float, default=None,
                       help="object height in world units (default 8 spacings)")
    build.add_argument("--obj", type=Path, default=None,
                       help="also export an OBJ world (a 1025^2 terrain at stride 1: 2 M "
                            "triangles, about 80 MB; --obj-stride 2 quarters it; default none)")
    build.add_argument("--obj-stride", type=int, default=1,
                       help="sample stride of the exported mesh (power of two; default 1)")
    tile = actions.add_parser(
        "tile", help="write a .vmtiles file: the terrain's tile pyramid, paged in by tiles under "
                     "a memory budget when played (play t.vmtiles --page-budget MB); from a "
                     "GeoTIFF it is built out of core, strip by strip within --memory")
    tile.add_argument("terrain", type=Path,
                      help="a .vmt terrain, or a GeoTIFF DEM (.tif/.tiff) of any size up to "
                           "8193 samples a side, padded onto the next 2^n+1 grid")
    tile.add_argument("-o", "--out", type=Path, required=True,
                      help="output .vmtiles file (tiles), or .vmrpages (Röttger's blocks in "
                           "pages, paged by play t.vmrpages)")
    tile.add_argument("--memory", type=float, default=256.0, metavar="MB",
                      help="a GeoTIFF's build: memory for its strips, bands of rows and the "
                           "tiles' statistics (default 256; refused below what the grid needs)")
    tile.add_argument("--nodata", type=float, default=None, metavar="VALUE",
                      help="a GeoTIFF's no-data value (default: its GDAL_NODATA tag)")
    tile.add_argument("--spacing", type=float, default=None,
                      help="a GeoTIFF's world units between samples (default: its pixel scale, "
                           "else 1)")
    tile.add_argument("--vertical", type=float, default=1.0,
                      help="a GeoTIFF's value to world units (default 1)")
    info = actions.add_parser("info", help="print a .vmt terrain's size, scale and objects")
    info.add_argument("terrain", type=Path)
    return parser


def run(args) -> int:
    if args.action == "info":
        return _info(args)
    if args.action == "tile":
        return _tile(args)
    from ..terrain import sources, store
    from ..terrain.mesh import terrain_world
    from ..terrain.placement import Placement, place_objects

    from ..files.atomic import check_destination

    check_destination(args.out)
    if args.obj is not None:
        check_destination(args.obj)
    from ..progress import Status

    with Status(f"terrain build {args.source}") as status:
        status("making the heightmap")
        if args.source in sources.DEMS:
            heightmap = sources.dem(args.source, args.size)
        elif args.source == sources.SYNTHETIC:
            heightmap = sources.diamond_square(args.size or 1025, args.seed, args.roughness,
                                               spacing=args.spacing or 1.0)
        else:
            heightmap = sources.load_file(args.source, args.size, args.spacing, args.vertical,
                                          args.fit, args.nodata)
        _check_fit(args, heightmap)  # before the first write: no .vmt without its OBJ
        status("placing objects and writing")
        placement = (place_objects(heightmap, args.objects, args.seed, args.object_height)
                     if args.objects > 0 else Placement.empty())
        store.save(args.out, heightmap, placement)
    print(f"wrote {args.out}: {heightmap.size}^2 samples, spacing {heightmap.spacing:.4g}, "
          f"heights {heightmap.bounds()[0, 1]:.4g}..{heightmap.bounds()[1, 1]:.4g}, "
          f"{len(placement)} objects, {args.out.stat().st_size / 1024:,.0f} KB")
    if args.obj is not None:
        with Status(f"terrain build {args.source}") as status:
            status("meshing the OBJ")
            world = terrain_world(heightmap, placement, args.obj_stride)
            status(f"writing {world.triangle_count:,} triangles to {args.obj}")
        from ..progress import Progress

        bar = Progress(f"terrain build: writing {args.obj}")
        try:
            world.to_obj(args.obj, progress=bar)
        finally:
            bar.close()
        print(f"wrote {args.obj}: {world.triangle_count:,} triangles")
    return 0


# Ground triangles of an exported OBJ (a 2049^2 map at stride 1: 8.4 M, ~3 GB as a World).
MAX_OBJ_TRIANGLES = 1 << 23


def _check_fit(args, heightmap) -> None:
    """Limits that need the heightmap: --obj-stride divides its cells and keeps the OBJ within
    MAX_OBJ_TRIANGLES; objects stand inside the square (VisMobileError naming the option)."""
    from ..errors import VisMobileError

    cells = heightmap.size - 1
    if args.obj is not None:
        if args.obj_stride > cells:
            raise VisMobileError(f"--obj-stride {args.obj_stride} exceeds the {cells} cells per "
                                 f"side of a {heightmap.size}^2 terrain")
        triangles = 2 * (cells // args.obj_stride) ** 2
        if triangles > MAX_OBJ_TRIANGLES:
            raise VisMobileError(f"--obj at stride {args.obj_stride} would hold {triangles:,} "
                                 f"triangles (at most {MAX_OBJ_TRIANGLES:,}); pass a larger "
                                 "--obj-stride")
    height = 8 * heightmap.spacing if args.object_height is None else args.object_height
    if args.objects > 0 and 4 * height > heightmap.extent:  # place_objects keeps a margin
        given = "--object-height" if args.object_height is not None else \
            "the default object height (8 spacings)"
        raise VisMobileError(f"{given} {height:g} exceeds a quarter of the terrain's width "
                             f"({heightmap.extent:g}); pass a larger --size or a smaller "
                             "--object-height")


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
    if heightmap.valid is not None:
        print(f"no data    {int((~heightmap.valid).sum()):,} samples (holes, cut when drawn)")
    print(f"file size  {args.terrain.stat().st_size / 1024:,.1f} KB")
    return 0


def _tile(args) -> int:
    from ..errors import VisMobileError
    from ..files.atomic import check_destination
    from ..progress import Status

    check_destination(args.out)
    pages = args.out.suffix.lower() == ".vmrpages"
    if args.terrain.suffix.lower() in (".tif", ".tiff"):
        from ..terrain.outofcore import build_tiles

        with Status(f"terrain tile {args.terrain}") as status:
            info = build_tiles(args.terrain, args.out, args.nodata, args.spacing, args.vertical,
                               budget_bytes=int(args.memory * (1 << 20)), status=status)
        what = "Röttger pages" if pages else "tiles"
        print(f"wrote {args.out}: {args.out.stat().st_size / (1 << 20):,.1f} MB of {what} of "
              f"{info['size']}^2 samples, built out of core in {info['seconds']:.1f} s "
              f"(bands of {info['band_rows']} rows)")
        return 0
    given = [o for o, v in (("--nodata", args.nodata), ("--spacing", args.spacing),
                            ("--vertical", None if args.vertical == 1.0 else 1)) if v is not None]
    if given:
        raise VisMobileError(f"{', '.join(given)}: for a GeoTIFF source only ({args.terrain} "
                             "is a .vmt terrain, which holds its own scale)")
    from ..terrain import store
    from ..terrain.paged import write_tiles
    from ..terrain.tiles import TilePyramid

    heightmap, _ = store.load(args.terrain)
    with Status(f"terrain tile {args.terrain}") as status:
        if pages:
            from ..terrain.paged_roettger import write_pages
            from ..terrain.roettger import Roettger

            status("Röttger's block statistics and pages")
            write_pages(Roettger(heightmap), args.out)
            print(f"wrote {args.out}: {args.out.stat().st_size / (1 << 20):,.1f} MB of Röttger "
                  f"pages of {heightmap.size}^2 samples (the objects stay in {args.terrain})")
            return 0
        status("the tile pyramid's statistics and records")
        write_tiles(TilePyramid.build(heightmap, 16), args.out)
    print(f"wrote {args.out}: {args.out.stat().st_size / (1 << 20):,.1f} MB of tiles of "
          f"{heightmap.size}^2 samples (the objects stay in {args.terrain})")
    return 0

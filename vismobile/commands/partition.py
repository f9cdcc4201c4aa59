"""`vismobile partition WORLD --structure KIND [params] -o OUT.vmp`: build and save."""
from __future__ import annotations

import time
from pathlib import Path

from . import WORLD_HELP


def add_parser(sub):
    parser = sub.add_parser("partition", help="partition a world into a .vmp file")
    parser.add_argument("world", help=WORLD_HELP + ", or a world directory "
                        "(tools/make_big_world.py) for the out-of-core octree build (streamed, "
                        "memory-mapped)")
    parser.add_argument("--structure", "-s", choices=("grid", "octree", "portal", "bsp"),
                        default="octree")
    parser.add_argument("-o", "--output", type=Path, required=True, help=".vmp file to write")
    parser.add_argument("--depth", type=int, help="octree depth 1..8 (default 5); portal 1..3 (2)")
    parser.add_argument("--slabs", action="append", default=[], metavar="AXIS:SPEC",
                        help="grid/portal cells on one axis: x:0.2,0.2,0.3,0.3 (shares) or z:4 "
                             "(count); axes not given get one slab")
    parser.add_argument("--auto", action="store_true", help="grid/portal: automatic cells")
    parser.add_argument("--cells", type=int, help="grid/portal --auto: target cell count")
    parser.add_argument("--min-leaf", type=int, default=8, help="bsp: smallest splittable node")
    parser.add_argument("--max-depth", type=int, default=32, help="bsp: deepest level")
    parser.add_argument("--candidates", type=int, default=64, help="bsp: planes tried per node")
    parser.add_argument("--rule", choices=("balanced", "thesis"), default="balanced",
                        help="bsp: 'thesis' stops when no split has h+/h- in [0.8, 1.25]")
    parser.add_argument("--seed", type=int, default=0, help="bsp: candidate sampling seed")
    parser.add_argument("--jobs", type=int, default=1,
                        help="world directory: worker processes for the chunked octree build")
    return parser


def parse_slabs(items):
    """['x:0.2,0.2,0.3,0.3', 'z:4'] -> per-axis specs (count or shares), 1 for missing axes."""
    slabs = [1, 1, 1]
    for item in items:
        axis, _, spec = item.partition(":")
        if axis not in ("x", "y", "z") or not spec:
            raise ValueError(f"--slabs {item!r}: expected AXIS:SPEC with AXIS x, y or z")
        values = [v for v in spec.split(",") if v]
        try:
            slabs["xyz".index(axis)] = (int(values[0]) if len(values) == 1 and values[0].isdigit()
                                        else tuple(float(v) for v in values))
        except ValueError:
            raise ValueError(f"--slabs {item!r}: SPEC must be a count or comma-separated shares") from None
    return tuple(slabs)


def run(args) -> int:
    from ..atomic import check_destination
    from ..errors import PartitionError
    from ..partition import partition
    from ..progress import Progress
    from ..scenes.lookup import world_file
    from ..world import World

    check_destination(args.output)  # before a long build, not after
    if Path(args.world).is_dir():
        args.world = Path(args.world)
        return run_out_of_core(args)
    args.world = world_file(args.world)
    world = World.from_file(args.world)
    kind = args.structure
    params = {}
    try:
        if kind in ("octree", "portal") and args.depth is not None:
            params["depth"] = args.depth
        if kind in ("grid", "portal"):
            if args.slabs:
                params["slabs"] = parse_slabs(args.slabs)
            else:
                params["auto"] = True if kind == "grid" else False
            if args.cells is not None:
                params["cells"] = args.cells
        if kind == "bsp":
            params.update(min_leaf=args.min_leaf, max_depth=args.max_depth,
                          candidates=args.candidates, seed=args.seed, rule=args.rule)
        bar = Progress(f"{kind} {args.world.name}")
        start = time.perf_counter()
        try:
            result = partition(world, kind, progress=bar, **params)
        finally:
            bar.close()
    except ValueError as error:
        raise PartitionError(f"{args.world}: {error}") from None
    elapsed = time.perf_counter() - start
    result.save(args.output)
    stats = result.stats()
    size = args.output.stat().st_size
    print(f"structure   {kind} {result.params}")
    print(f"build time  {elapsed:.2f} s")
    print(f"nodes       {stats['nodes']:,}")
    print(f"leaves      {stats['leaves']:,}")
    print(f"refs/tri    {stats['refs_per_triangle']:.3f}")
    print(f"file        {args.output} {size / 1024:,.1f} KB "
          f"({size / args.world.stat().st_size:.2f} x the OBJ)")
    return 0


def run_out_of_core(args) -> int:
    """Octree of a memory-mapped world directory, built in chunks and streamed to the file."""
    from ..errors import PartitionError
    from ..mapped import MappedWorld
    from ..partition.external import build_octree_file

    if args.structure != "octree":
        raise PartitionError(f"{args.world}: a world directory is partitioned out of core as an "
                             f"octree only (got --structure {args.structure})")
    world = MappedWorld.open(args.world)
    try:
        stats = build_octree_file(world, args.output, depth=5 if args.depth is None else args.depth,
                                  jobs=max(1, args.jobs))
    except ValueError as error:
        raise PartitionError(f"{args.world}: {error}") from None
    print(f"structure   octree (out of core, {stats['chunks']} chunks, {args.jobs} jobs)")
    print(f"build time  {sum(stats['seconds'].values()):.2f} s")
    print(f"nodes       {stats['nodes']:,}")
    print(f"refs/tri    {stats['references'] / world.triangle_count:.3f}")
    print(f"file        {args.output} {stats['bytes'] / 1024:,.1f} KB")
    return 0

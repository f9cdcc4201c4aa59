"""`vismobile partition WORLD --structure KIND [params] -o OUT.vmp`: build and save."""
from __future__ import annotations

import time
from pathlib import Path

from . import FIX_WINDING_HELP, REPAIR_HELP, REPAIRS, STRUCTURE_HELP, WORLD_HELP, fix_winding


def add_parser(sub):
    parser = sub.add_parser("partition", help="partition a world into a .vmp file")
    parser.add_argument("world", help=WORLD_HELP + ", or a world directory "
                        "(tools/make_big_world.py) for the out-of-core octree build (streamed, "
                        "memory-mapped)")
    parser.add_argument("--structure", "-s", default="octree",
                        help=f"{STRUCTURE_HELP} (default octree, depth 5); ,pvs=conservative "
                             "bakes a PVS coarsened to budget=0.25 of the OBJ's bytes unless "
                             "budget=F or budget=none (the exact sets) is given; the options "
                             "below set the same parameters")
    parser.add_argument("-o", "--out", "--output", dest="out", type=Path, required=True,
                        help=".vmp file to write")
    parser.add_argument("--depth", type=int, help="octree depth 1..8 (default 5); portal 1..3 (2)")
    parser.add_argument("--slabs", action="append", default=[], metavar="AXIS:SPEC",
                        help="grid/portal cells on one axis: x:0.2,0.2,0.3,0.3 (shares) or z:4 "
                             "(count); axes not given get one slab")
    parser.add_argument("--auto", action="store_true", help="grid/portal: automatic cells")
    parser.add_argument("--cells", type=int, help="grid/portal --auto: target cell count")
    parser.add_argument("--min-leaf", type=int, help="bsp/kdtree: smallest splittable node (default 8/1)")
    parser.add_argument("--max-depth", type=int, help="bsp/kdtree: deepest level (default 32/automatic)")
    parser.add_argument("--candidates", type=int, help="bsp: planes tried per node (default 64)")
    parser.add_argument("--rule", choices=("balanced", "thesis"),
                        help="bsp: balanced (default) or thesis: stop when no split has h+/h- "
                             "in [0.8, 1.25]")
    parser.add_argument("--seed", type=int, help="bsp: candidate sampling seed (default 0)")
    parser.add_argument("--jobs", type=int, default=1,
                        help="world directory: worker processes for the chunked octree build; "
                             "pvs=conservative: processes for the bake, or Dask workers with "
                             "--scheduler dask (default 1)")
    parser.add_argument("--scheduler", default=None,
                        help="pvs=conservative: spread the bake over Dask, as compare spreads "
                             "its runs: dask (a LocalCluster of --jobs worker processes) or "
                             "the address of a running dask.distributed scheduler, "
                             "tcp://host:8786")
    parser.add_argument("--fix-winding", action="store_true",
                        help=FIX_WINDING_HELP + "; the .vmp carries the fixed world")
    parser.add_argument("--repair", choices=REPAIRS + ("auto",), default="auto",
                        help=REPAIR_HELP + "; the .vmp carries the repaired world; auto "
                        "(default): tjunctions when a conservative PVS is baked and the world "
                        "has T-junctions (its cracks would join every room: docs/partition.md), "
                        "else none")
    parser.add_argument("--lod", action="store_true",
                        help="also build each object's level-of-detail chain (meshoptimizer) "
                             "and store it in the .vmp (play --lod-tau uses it)")
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
    from ..files.atomic import check_destination
    from ..errors import PartitionError
    from ..partition import partition, save_partition
    from ..partition.spec import HELP, format_spec, parse_spec
    from ..progress import Progress
    from ..scenes.lookup import world_file
    from ..files.loader import load_world

    check_destination(args.out)  # before a long build, not after
    if Path(args.world).is_dir():
        args.world = Path(args.world)
        return run_out_of_core(args)
    from ..progress import Status

    with Status(f"partition {args.world}") as status:
        status("loading the world")
        args.world = world_file(args.world)
        given = None if args.repair == "auto" else args.repair
        world = fix_winding(load_world(args.world, given), args.fix_winding)
    try:
        kind, params = parse_spec(args.structure)
        if kind is None:
            raise ValueError("--structure none builds nothing; choose " + HELP)
        options = {"depth": args.depth,
                   "slabs": parse_slabs(args.slabs) if args.slabs else None,
                   "auto": True if args.auto else None, "cells": args.cells,
                   "min_leaf": args.min_leaf, "max_depth": args.max_depth,
                   "candidates": args.candidates, "rule": args.rule, "seed": args.seed}
        for key, value in options.items():
            if value is None:
                continue
            if key in params and params[key] != value:
                raise ValueError(f"{key} given twice: {params[key]} in --structure, {value} "
                                 "as an option")
            params[key] = value
        if kind == "grid" and "slabs" not in params:
            params["auto"] = True
        mode = params.pop("pvs", None)
        if mode is not None and str(mode).startswith("sampled"):
            mode = f"sampled:{_samples(mode)}"
        from ..partition.pvs import fly_option

        fly = fly_option(params.pop("fly", "off"))
        if fly and mode != "conservative":
            raise ValueError("fly=on bakes fly-over cells into a conservative PVS: add "
                             ",pvs=conservative")
        budget = params.pop("budget", None)
        if budget is not None and mode != "conservative":
            raise ValueError("budget= coarsens a conservative PVS to a share of the "
                             "OBJ's bytes: add ,pvs=conservative")
        if mode == "conservative":  # budget=0.25 unless given (budget=none: exact sets)
            from ..partition.pvs_coarsen import budget_param

            budget = budget_param(budget)
        if args.repair == "auto" and mode == "conservative":
            world = _auto_repair(world)
        if args.scheduler is not None:
            from ..study.distributed import scheduler_address

            scheduler_address(args.scheduler)  # refused before a long build, not after
            if mode != "conservative":
                raise ValueError("--scheduler spreads the pvs=conservative bake; this "
                                 "structure bakes none (add ,pvs=conservative)")
        bar = Progress(f"{kind} {args.world.name}")
        from ..timing import fresh_compiles

        compiled = fresh_compiles()
        start = time.perf_counter()
        try:
            if mode is not None:
                from ..partition.pvs import MODES

                if mode not in MODES and not str(mode).startswith("sampled:"):
                    raise ValueError(f"unknown pvs mode {mode!r}; valid: "
                                     f"{', '.join(MODES)}, sampled:N")
            result = partition(world, kind, progress=bar, **params)
        finally:
            bar.close()
        if fly:
            result.params["fly"] = "on"  # read by the bake (partition/pvs.py)
        if budget is not None:
            result.params["budget"] = budget  # read by the bake (pvs.stored_sets)
        if mode is not None:
            result, bake = _bake(result, mode, args, args.world.name)
    except ValueError as error:
        raise PartitionError(f"{args.world}: {error}") from None
    elapsed = time.perf_counter() - start
    compiled = fresh_compiles() != compiled  # numba compiled code during the build
    if args.lod:
        from ..lod.simplify import build_chains

        bar = Progress(f"lod chains {args.world.name}")
        try:
            chains = build_chains(world, progress=bar)
        finally:
            bar.close()
        result.extras.update(chains.to_extras())
        print(f"lod chains  {chains.level_count:,} levels, {chains.triangle_count:,} "
              f"triangles, {chains.nbytes / 1024:,.1f} KB, {chains.build_seconds:.2f} s")
    save_partition(result, args.out)
    stats = result.stats()
    size = args.out.stat().st_size
    print(f"structure   {format_spec(kind, result.params)}")
    print(f"build time  {elapsed:.2f} s" + (" (includes numba's first-use compile: run "
                                             "again for the build alone)" if compiled else ""))
    print(f"nodes       {stats['nodes']:,}")
    print(f"leaves      {stats['leaves']:,}")
    print(f"refs/tri    {stats['refs_per_triangle']:.3f}")
    print(f"file        {args.out} {size / 1024:,.1f} KB "
          f"({size / args.world.stat().st_size:.2f} x the {_input_kind(args.world)})")
    if mode is not None:
        print(f"pvs         {mode}: {bake['cells']:,} view cells, bake {bake['seconds']:.1f} s, "
              f"{bake['bytes'] / 1024:,.1f} KB ({bake['bytes'] / args.world.stat().st_size:.2f} "
              f"x the {_input_kind(args.world)}), mean set {bake['mean_set']:.1%} of the world")
        if bake.get("budget"):  # a conservative bake's budget (budget=none: exact sets)
            from ..partition.pvs_coarsen import describe

            print(f"pvs budget  {describe(bake['budget'])}")
    return 0


def _auto_repair(world):
    """world with its T-junctions repaired (world/tjunctions.py) when it has any, saying so: a
    conservative PVS lets sight lines through every crease's crack, which joins the rooms
    through the hollow walls (W1's default bake sent 0.977x vfc+tbfc as built, 0.403x of the
    world as built's vfc+tbfc repaired)."""
    from ..world.tjunctions import repair_tjunctions

    fixed, repair = repair_tjunctions(world)
    if not repair.junctions:
        return world
    print(f"repair      tjunctions (auto for pvs=conservative; --repair none keeps the world "
          f"as given): {repair.junctions:,} junctions, {world.triangle_count:,} -> "
          f"{fixed.triangle_count:,} triangles")
    return fixed


def _samples(text) -> int:
    """'sampled:64' -> 64 (ValueError naming the grammar otherwise)."""
    _, _, count = str(text).partition(":")
    if not count.isdigit() or int(count) < 1:
        raise ValueError(f"pvs={text}: expected pvs=sampled:N with N >= 1 sample points per cell")
    return int(count)


def _bake(result, mode, args, name) -> tuple:
    """(the partition with its PVS baked, bake statistics) through study.engine.bake_pvs, the
    bake path compare and tune use: over --jobs processes, or over Dask with --scheduler (the
    cluster compare's runs use, study/distributed.py); a progress line per source cell chunk."""
    from ..progress import Progress
    from ..study.engine import bake_pvs

    where = ("dask" if args.scheduler == "dask" else f"dask {args.scheduler}"
             if args.scheduler else
             f"{args.jobs} jobs" if args.jobs > 1 and mode == "conservative" else "1 job")
    bar = Progress(f"pvs {mode} {name} ({where})")
    client = cluster = None
    try:
        if args.scheduler is not None:
            from ..study.distributed import open_client, quiet_dask_logs

            quiet_dask_logs()
            client, cluster = open_client(args.scheduler, max(1, args.jobs))
        return bake_pvs(result, mode, progress=bar, jobs=max(1, args.jobs), executor=client)
    finally:
        bar.close()
        if client is not None:
            client.close()
        if cluster is not None:
            cluster.close()


def run_out_of_core(args) -> int:
    """Octree of a memory-mapped world directory, built in chunks and streamed to the file."""
    from ..errors import PartitionError
    from ..world.mapped import MappedWorld

    if args.fix_winding or args.repair not in ("none", "auto"):
        raise PartitionError(f"{args.world}: --fix-winding and --repair need a mesh file, not "
                             "a world directory")
    if args.scheduler is not None:
        raise PartitionError(f"{args.world}: --scheduler spreads a PVS bake; a world directory "
                             "is partitioned out of core over --jobs processes")
    from ..partition.external import build_octree_file
    from ..partition.spec import parse_spec

    try:
        kind, params = parse_spec(args.structure)
    except ValueError as error:
        raise PartitionError(f"{args.world}: {error}") from None
    if kind != "octree" or set(params) - {"depth"}:
        raise PartitionError(f"{args.world}: a world directory is partitioned out of core as an "
                             f"octree only, octree[:N] (got --structure {args.structure})")
    depth = args.depth if args.depth is not None else params.get("depth", 5)
    world = MappedWorld.open(args.world)
    try:
        stats = build_octree_file(world, args.out, depth=depth, jobs=max(1, args.jobs))
    except ValueError as error:
        raise PartitionError(f"{args.world}: {error}") from None
    print(f"structure   octree (out of core, {stats['chunks']} chunks, {args.jobs} jobs)")
    print(f"build time  {sum(stats['seconds'].values()):.2f} s")
    print(f"nodes       {stats['nodes']:,}")
    print(f"refs/tri    {stats['references'] / world.triangle_count:.3f}")
    print(f"file        {args.out} {stats['bytes'] / 1024:,.1f} KB")
    return 0


def _input_kind(path) -> str:
    """'OBJ', 'GLB', 'PLY.GZ', ... : what the input file is, for the size comparison."""
    from pathlib import Path

    suffixes = [x.lstrip(".").upper() for x in Path(path).suffixes[-2:]]
    if len(suffixes) == 2 and suffixes[1] != "GZ":
        suffixes = suffixes[1:]
    return ".".join(suffixes) + " input" if suffixes else "input"

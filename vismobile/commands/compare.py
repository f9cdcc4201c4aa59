"""`vismobile compare`: the thesis's chapter-5 matrix (SPEC §6) in one command, with a report."""
from pathlib import Path

from . import CULL_HELP, FRAMES_HELP, PROFILE_NAMES


def add_parser(sub):
    parser = sub.add_parser(
        "compare", help="run the comparison matrix (parallel, resumable) and write a report",
        description="Example: vismobile compare --worlds w1,w2 --structures "
                    "grid,octree:3-6,portal:1-3,bsp --cull all --profiles "
                    "ipaq-hx2490b,nokia-n82")
    parser.add_argument("--worlds", default="all",
                        help="comma-separated thesis worlds w1..w6, all, or mesh file paths "
                             "(a file needs --trajectory) (default all)")
    parser.add_argument("--trajectory", type=Path, default=None,
                        help="trajectory CSV for the worlds given as files")
    parser.add_argument("--structures", default="grid,octree:3-6,portal:1-3,bsp",
                        help="comma-separated grid, octree[:N or A-B], portal[:N or A-B], bsp "
                             "or all (default the thesis's: grid,octree:3-6,portal:1-3,bsp)")
    parser.add_argument("--cull", default="all",
                        help="comma-separated combinations: all, thesis (its 8), ours, or "
                             "combinations of " + CULL_HELP.split("; stages: ")[1]
                             + " joined by + (default all)")
    parser.add_argument("--profiles", default="ipaq-hx2490b,nokia-n82",
                        help="comma-separated device profiles: " + ", ".join(PROFILE_NAMES)
                             + " (default ipaq-hx2490b,nokia-n82)")
    parser.add_argument("--frames", default="all", help=FRAMES_HELP + " (default all)")
    parser.add_argument("-o", "--out", type=Path, default=Path("out/compare"),
                        help="results folder (runs/<key>.json, runs.csv, runs.json)")
    parser.add_argument("--report", type=Path, default=None,
                        help="HTML report path (default OUT/report.html)")
    parser.add_argument("--worlds-dir", type=Path, default=None,
                        help="where thesis worlds are built and kept (default: $VISMOBILE_WORLDS, "
                             "worlds/ in a source checkout, else ~/.cache/vismobile/worlds)")
    parser.add_argument("--cache", type=Path, default=Path("out/cache"),
                        help="partition and ground-truth cache")
    parser.add_argument("--jobs", type=int, default=None, help="worker processes (default: cores)")
    parser.add_argument("--scheduler", default="local",
                        help="local (a pool of --jobs processes, the default), dask (a Dask "
                             "LocalCluster of --jobs worker processes) or the address of a "
                             "running dask.distributed scheduler, e.g. tcp://host:8786 (its "
                             "workers must see the same worlds, cache and out paths)")
    parser.add_argument("--agreement", type=int, default=2,
                        help="frames per world for the raster/ray-cast check (0: skip)")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
    return parser


def run(args) -> int:
    import json

    from ..atomic import check_destination
    from ..study.matrix import expand, parse_worlds
    from ..study.thesis import WORLDS
    from ..study.report import write_report
    from ..study.runner import Context, agreement, reusable_runs, run_matrix
    from ..world import atomic_write_bytes

    trajectories = ({w: str(args.trajectory.resolve()) for w in parse_worlds(args.worlds)
                     if w not in WORLDS} if args.trajectory else None)
    specs = expand(args.worlds, args.structures, args.cull, args.profiles, args.frames,
                   trajectories)
    for path in (args.out / "runs.csv", args.out / "runs" / "x.json",
                 args.report or args.out / "report.html"):
        check_destination(path)  # before hours of runs, not after
    context = Context(".", args.out, args.worlds_dir, args.cache)
    reused = reusable_runs(specs, context)
    print(f"{len(specs)} runs -> {args.out}/runs/: {reused} reused from earlier, "
          f"{len(specs) - reused} to run", flush=True)
    records = run_matrix(specs, context, args.jobs, progress=not args.quiet,
                         scheduler=args.scheduler)
    from ..progress import Status

    checks = []
    with Status("compare", enabled=not args.quiet) as status:
        for world in parse_worlds(args.worlds) if args.agreement > 0 else []:
            status(f"raster/ray-cast agreement on {world}")
            checks += agreement(world, context, specs[0].profile, args.agreement,
                                (trajectories or {}).get(world))
        if checks:
            atomic_write_bytes(args.out / "agreement.json",
                               json.dumps(checks, indent=1).encode())
        status("writing the report")
        report = write_report(records, args.report or args.out / "report.html",
                              agreement=checks)
    failed = sum("error" in r for r in records)
    print(f"wrote {args.out / 'runs.csv'}, {args.out / 'runs.json'} and {report}"
          + (f"; {failed} runs failed (listed in the report)" if failed else ""))
    return 1 if failed else 0

"""`vismobile worlds build [--out DIR]`: generate the six thesis worlds and W7 (ours, with its
motion file) and print their table."""
from pathlib import Path


def add_parser(sub):
    parser = sub.add_parser("worlds", help="build the six thesis worlds (Table 5.2) and W7 "
                                           "(ours: it moves)")
    actions = parser.add_subparsers(dest="action", required=True)
    build = actions.add_parser("build", help="generate W1-W7 as OBJ files (W7 also "
                                             "w7.motion.json), deterministically")
    build.add_argument("-o", "--out", type=Path, default=None,
                       help="output directory (default: $VISMOBILE_WORLDS, worlds/ in a source "
                            "checkout, else ~/.cache/vismobile/worlds)")
    build.add_argument("--only", default=None,
                       help="comma-separated subset of w1, w2, w3, w4, w5, w6, w7 (default "
                            "all)")
    return parser


def run(args) -> int:
    from ..scenes.thesis import TARGETS, build_all

    names = tuple(n.strip().lower() for n in args.only.split(",")) if args.only else tuple(TARGETS)
    unknown = [n for n in names if n not in TARGETS]
    if unknown:
        from ..errors import VisMobileError

        raise VisMobileError(f"unknown world(s) {', '.join(unknown)}; expected "
                             f"{', '.join(TARGETS)}")
    print(f"{'world':6}{'triangles':>11}{'target':>9}{'dev %':>8}{'objects':>9}"
          f"{'OBJ KB':>9}{'thesis KB':>11}{'seconds':>9}")
    total, rows = 0.0, []
    from ..progress import Status

    for name in names:  # one row as each world is built: W2 alone takes a while
        with Status("worlds build") as status:
            status(f"building {name}")
            row = build_all(args.out, (name,))[0]
        rows.append(row)
        total += row["seconds"]
        print(f"{row['name']:6}{row['triangles']:>11,}{row['target']:>9,}"
              f"{100 * row['deviation']:>+8.2f}{row['objects']:>9}{row['kilobytes']:>9,.0f}"
              f"{row['thesis_kilobytes']:>11,}{row['seconds']:>9.2f}", flush=True)
    print(f"wrote {len(rows)} worlds to {rows[0]['path'].parent} in {total:.1f} s")
    return 0

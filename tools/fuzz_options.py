"""Fuzz targets of command-line option texts (tools/fuzz.py imports them): compare's --cull
lists (cull, issue 31), partition's --structure text (structure), compare's and tune's
--structures lists with baked PVS labels (selection) and --scheduler addresses (scheduler,
issue 29), play's --page-budget values (budget, issue 30), compare's and tune's --repair values
(studyrepair, issue 29): their seeds and entry points. Each entry parses or ends in a
VisMobileError."""
from __future__ import annotations

# compare's --cull texts (issue 31's grammar: + joins stages, ';' or ',' separates them).
CULL_TEXTS = [b"vfc+bfc;vfc+occlusion", b"thesis,ours", b"vfc,bfc",
              b"vfc+cbfc+tbfc none; portals+vfc"]
# The structure grammar's seeds: every kind, its parameters and the PVS bake (fly=on is
# refused on the cube, a world without street cells: tests/partition/test_pvs_fly.py; budget=
# a share of the OBJ's bytes in (0, 64], 0.25 when not given, or none/off for the exact sets,
# partition/pvs_coarsen.py).
STRUCTURE_TEXTS = [b"grid:4", b"octree:3", b"portal:depth=1,pvs=conservative",
                   b"portal:1,pvs=conservative,fly=off",
                   b"portal:1,pvs=conservative,budget=0.25", b"bsp:pvs=conservative,budget=1e-3",
                   b"portal:1,pvs=conservative,budget=none", b"bsp:pvs=conservative,budget=OFF",
                   b"portal:1,walls=true", b"bsp:min_leaf=16",
                   b"kdtree:split=median,max_depth=6,min_leaf=4", b"kdtree:ratio=8,bins=16"]
CUBE_OBJ = ("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n"
            "f 1 3 2\nf 1 4 3\nf 5 6 7\nf 5 7 8\nf 1 2 6\nf 1 6 5\nf 3 4 8\nf 3 8 7\n"
            "f 2 3 7\nf 2 7 6\nf 1 5 8\nf 1 8 4\n")


def run_option(argv, option, text):
    """The CLI run with argv: accepted (rc 0) or refused in one line (rc 2, raised as
    VisMobileError naming option and text); any other outcome is a finding (RuntimeError)."""
    from vismobile.app.cli import main as cli
    from vismobile.errors import VisMobileError

    try:
        rc = cli(argv)
    except SystemExit as exit:  # argparse's own refusal
        rc = exit.code
    if rc == 2:
        raise VisMobileError(f"{option} {text!r} refused")
    if rc != 0:
        raise RuntimeError(f"{argv[0]} {option} {text!r}: exit code {rc}")


def load_structure(path):
    """partition's --structure text, through the CLI on a cube (run_option)."""
    text = path.read_bytes()[:256].decode("utf-8", errors="replace").replace("\x00", "")
    cube = path.with_name("cube.obj")
    if not cube.exists():
        cube.write_text(CUBE_OBJ)
    run_option(["partition", str(cube), f"--structure={text}", "-o",
                str(path.with_suffix(".vmp"))], "--structure", text)


# compare's and tune's --structures lists: depth ranges, baked PVS labels (+pvs, +pvs=...).
SELECTION_TEXTS = [b"grid,octree:3-6,portal:1-3,bsp,kdtree", b"portal:2+pvs,bsp+pvs",
                   b"grid+pvs=sampled:8,octree:2-3+pvs=conservative", b"all,kdtree+pvs"]


def load_selection(path):
    """A --structures list: parsed (SelectionError, a VisMobileError, when refused), and every
    label's partition parameters and PVS mode read back as engine.load_structure reads them."""
    from vismobile.study.matrix import parse_structures, pvs_of, structure_params

    text = path.read_bytes()[:4096].decode("utf-8", errors="replace")
    for label in parse_structures(text):
        params = structure_params(label)
        assert pvs_of(label) in (None, "conservative") or pvs_of(label).startswith("sampled:")
        assert set(params) <= {"auto", "depth", "pvs"}, params


# --scheduler values (partition's PVS bake, compare's runs), checked before anything connects.
SCHEDULER_TEXTS = [b"dask", b"tcp://127.0.0.1:8786", b"scheduler.local:8786"]


def load_scheduler(path):
    """A --scheduler value: accepted as an address (nothing connects) or SchedulerError."""
    from vismobile.study.distributed import scheduler_address

    text = path.read_bytes()[:1024].decode("utf-8", errors="replace")
    assert scheduler_address(text) == text.strip()


def load_cull_list(path):
    """compare's --cull text (issue 31's grammar: + joins stages, ';' or ',' separates
    combinations): parsed, and the ambiguity note computed."""
    from vismobile.study.matrix import ambiguous_commas, parse_culls

    text = path.read_bytes()[:4096].decode("utf-8", errors="replace")
    ambiguous_commas(text)
    parse_culls(text)
    parse_culls(text.split("\n"))  # as repeated --cull options


# play --page-budget values in MB (commands/options.py RANGES: (0, 2^20]).
BUDGET_TEXTS = [b"16", b"0.5", b"4", b"1048576"]


def load_page_budget(path):
    """--page-budget text through play's parser and its RANGES check."""
    from vismobile.app.cli import build_parser
    from vismobile.commands import options
    from vismobile.errors import VisMobileError

    text = path.read_bytes()[:256].decode("utf-8", errors="replace")
    try:
        args = build_parser().parse_args(["play", "t.vmtiles", "-o", str(path) + ".out",
                                          "--page-budget", text])
    except SystemExit:  # argparse's own refusal (exit 2, one usage line)
        raise VisMobileError(f"--page-budget {text!r}: not a number") from None
    options.check(args)
    assert 0.0 < args.page_budget <= 1 << 20


# compare's and tune's --repair values (issue 29; info's, partition's: fuzz_repair.py).
STUDY_REPAIR_TEXTS = [b"tjunctions", b"none"]


def load_study_repair(path):
    """A --repair value through compare's and tune's parsers (argparse's refusal: exit 2, one
    line), then a floor and wall meeting at T-junctions (fuzz_repair.TJUNCTION_OBJ) loaded as
    their runs load a world (study/engine.load_world): repaired exactly when asked. Running
    the commands themselves (tests/study/test_repair_study.py) takes over the case's time
    limit in a fresh process (numba's first compile)."""
    from fuzz_repair import TJUNCTION_OBJ

    from vismobile.app.cli import build_parser
    from vismobile.errors import VisMobileError
    from vismobile.study import engine

    text = path.read_bytes()[:256].decode("utf-8", errors="replace").replace("\x00", "")
    world = path.with_name("tjunction.obj")
    if not world.exists():
        world.write_bytes(TJUNCTION_OBJ)
    parser = build_parser()
    try:
        compare = parser.parse_args(["compare", "--worlds", str(world), f"--repair={text}"])
        tune = parser.parse_args(["tune", str(world), f"--repair={text}"])
    except SystemExit:
        raise VisMobileError(f"--repair {text!r} refused") from None
    assert compare.repair == tune.repair == text
    loaded = engine.load_world(str(world), None, compare.repair)
    plain = engine.load_world(str(world), None, "none")
    assert (loaded.repair == "tjunctions") == (text == "tjunctions")
    assert loaded.triangle_count > plain.triangle_count if text == "tjunctions" else \
        loaded is plain


SEEDS = {"cull": CULL_TEXTS, "structure": STRUCTURE_TEXTS, "selection": SELECTION_TEXTS,
         "scheduler": SCHEDULER_TEXTS, "budget": BUDGET_TEXTS,
         "studyrepair": STUDY_REPAIR_TEXTS}
ENTRY = {"cull": (load_cull_list, ".txt"), "structure": (load_structure, ".txt"),
         "selection": (load_selection, ".txt"), "scheduler": (load_scheduler, ".txt"),
         "budget": (load_page_budget, ".txt"), "studyrepair": (load_study_repair, ".txt")}

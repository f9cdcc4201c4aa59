"""Command-line entry point: `vismobile <command> ...`; each command lives in commands/."""
from __future__ import annotations

# The top-level --help: what the tool is for and the first commands to try.
DESCRIPTION = """\
Which spatial structure and which visibility culling for a world on constrained hardware?
vismobile measures it: it partitions a triangle world, culls and renders camera paths through
it as an OpenGL ES 1.1-class device would, and reports time against an exact item-buffer
ground truth. A WORLD is a thesis world (w1..w6, built on first use) or a mesh file."""
EPILOG = """\
first steps:
  vismobile info w2                                  triangles, objects, bounds, winding
  vismobile play w2 -o runs/w2                       the thesis's path, octree:4, vfc
  vismobile play w2 --structure octree:5 --cull vfc+bfc+occlusion -o runs/w2b
  vismobile tune w2                                  the fastest configuration that drops
                                                     nothing visible
  vismobile view w2                                  fly through it (F1 lists the keys)
  vismobile trajectory generate room.glb -o walk.csv a camera path for your own mesh
  vismobile compare --worlds w1,w2 --structures octree:3-5 --cull "thesis;vfc+occlusion"

Stages are joined by + (vfc+bfc); compare lists combinations with ';' or repeated --cull.
vismobile COMMAND --help lists every option and its valid values."""
import argparse
import sys
import time
import warnings
from importlib import import_module

from ..errors import VisMobileError, one_line

# Each module in commands/ offers add_parser(subparsers) and run(args) -> int.
COMMANDS = ("worlds", "info", "partition", "play", "compare", "tune", "trajectory", "terrain",
            "view")


def build_parser() -> argparse.ArgumentParser:
    from .. import __version__
    from ..commands import options

    parser = argparse.ArgumentParser(prog="vismobile", description=DESCRIPTION, epilog=EPILOG,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--version", action="version", version=f"vismobile {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, title="commands",
                                metavar="COMMAND")
    ranged = set()
    for name in COMMANDS:
        try:
            module = import_module(f"vismobile.commands.{name}")
        except ModuleNotFoundError as error:
            if error.name != f"vismobile.commands.{name}":
                raise
            continue
        command = module.add_parser(sub)
        command.set_defaults(handler=module.run)
        ranged |= options.annotate(command, name)  # each option's valid range in its help
    parser.ranged = ranged  # (command, option) pairs annotated (tests: the whole table)
    return parser


def main(argv=None) -> int:
    from .. import progress

    started = time.perf_counter()
    args = build_parser().parse_args(argv)
    progress.COMMAND_START = started
    try:
        return _run(args)
    finally:
        progress.COMMAND_START = None


def _run(args) -> int:
    with warnings.catch_warnings():
        warnings.simplefilter("default")
        warnings.formatwarning = lambda message, *rest: f"warning: {message}\n"
        try:
            from ..commands import options, overwrite

            options.check(args)  # every range before anything is loaded or written
            overwrite.check(args)  # no output is one of the inputs
            return int(args.handler(args) or 0)
        except VisMobileError as error:
            print(f"vismobile: error: {one_line(error)}", file=sys.stderr)
            return 2
        except OSError as error:  # an input or output the commands did not foresee
            where = f"{error.filename}: " if error.filename else ""
            print(f"vismobile: error: {one_line(where)}{one_line(error.strerror or error)}",
                  file=sys.stderr)
            return 2
        except KeyboardInterrupt:
            print("vismobile: interrupted", file=sys.stderr)
            return 130


if __name__ == "__main__":
    sys.exit(main())

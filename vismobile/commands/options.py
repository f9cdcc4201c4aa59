"""Every numeric (and must-not-be-empty) option's valid range, in one table that both `--help`
and the checks read: cli.build_parser appends each range to its option's help (annotate), and
cli runs check(args) before any command loads or writes anything, so an out-of-range value
exits 2 with one line naming the option. Cross-option limits that need the input (a terrain's
width, a world's size) stay in the commands, checked before their first write.

Kept free of heavy imports (`--help` must stay quick); tests/test_cli_options.py checks the
limits against the constants they mirror (heightmap.MAX_LEVEL, trajectory.MAX_FRAMES, ...).
"""
from __future__ import annotations

import argparse
import math
from dataclasses import dataclass

SEED_MAX = 2 ** 32 - 1
MAX_FRAMES = 200_000  # trajectory.MAX_FRAMES
MAX_TERRAIN_SIZE = 8193  # 2^heightmap.MAX_LEVEL + 1
MAX_OBJECTS = 200  # terrain.placement.MAX_OBJECTS: up to 5,288 triangles each
MAX_JOBS = 256
WORLD_UNITS = 1e6  # spacings, heights and distances in world units (OBJ coordinates: 1e30)


@dataclass(frozen=True)
class Range:
    """A closed range [low, high] of ints or finite floats; `above`: low itself excluded;
    `rule`: "2^n+1", "power of two" or "non-empty" (a string option)."""

    low: float | None = None
    high: float | None = None
    kind: type = int
    above: bool = False
    rule: str = ""

    def text(self) -> str:
        if self.rule == "non-empty":
            return "not empty"
        fmt = (lambda v: f"{v:,}") if self.kind is int else (lambda v: f"{v:g}")
        if self.low is not None and self.high is not None and not self.above:
            span = f"{fmt(self.low)}..{fmt(self.high)}"
        else:
            parts = ([f"{'>' if self.above else '>='} {fmt(self.low)}"] if self.low is not None
                     else []) + ([f"<= {fmt(self.high)}"] if self.high is not None else [])
            span = " and ".join(parts)
        return f"{'a ' * (self.rule == 'power of two')}{self.rule} in {span}" if self.rule \
            else span

    def problem(self, value) -> str | None:
        """None when value is valid, else what is wrong (the range)."""
        if self.rule == "non-empty":  # a repeated option (action="append"): each one
            items = value if isinstance(value, (list, tuple)) else [value]
            empty = not items or any(not str(v).strip(" ,;+") for v in items)
            return "must not be empty" if empty else None
        number = float(value)
        bad = (not math.isfinite(number)
               or (self.low is not None and (number <= self.low if self.above
                                             else number < self.low))
               or (self.high is not None and number > self.high))
        if not bad and self.rule == "2^n+1":
            bad = int(value) < 3 or (int(value) - 1) & (int(value) - 2) != 0
        if not bad and self.rule == "power of two":
            bad = int(value) < 1 or int(value) & (int(value) - 1) != 0
        return f"must be {self.text()}" if bad else None


def _positive(high=WORLD_UNITS):
    return Range(0.0, high, float, above=True)


NOT_EMPTY = Range(rule="non-empty")
FPS = Range(0.0, 1e4, float, above=True)  # an animated scene's frames per second (issue 25)

# command ("terrain build" for an action) -> option -> Range
RANGES = {
    "terrain build": {
        "--size": Range(3, MAX_TERRAIN_SIZE, rule="2^n+1"),
        "--seed": Range(0, SEED_MAX),
        "--roughness": Range(0.0, 1.0, float),
        "--spacing": _positive(),
        "--vertical": _positive(),
        "--objects": Range(0, MAX_OBJECTS),
        "--object-height": _positive(),
        "--obj-stride": Range(1, MAX_TERRAIN_SIZE - 1, rule="power of two"),
    },
    "terrain tile": {"--memory": Range(1.0, 1 << 20, float), "--spacing": _positive(),
                     "--vertical": _positive()},
    "trajectory generate": {
        "--seed": Range(0, SEED_MAX),
        "--length": Range(2, MAX_FRAMES),
        "--eye-height": _positive(),
        "--clearance": _positive(),
    },
    "tune": {"--probe": Range(1, MAX_FRAMES), "--structures": NOT_EMPTY,
             "--max-error-px": Range(0.0, 1e6, float)},
    "partition": {
        "--depth": Range(1, 8),
        "--cells": Range(1, 1 << 20),
        "--min-leaf": Range(1, 2 ** 31 - 1),
        "--max-depth": Range(0, 256),
        "--candidates": Range(1, 4096),
        "--seed": Range(0, SEED_MAX),
        "--jobs": Range(1, MAX_JOBS),
    },
    "play": {"--images": Range(0, MAX_FRAMES), "--limit": Range(1, None),
             "--lod-tau": Range(0.0, 1e6, float), "--page-budget": Range(0.0, 1 << 20, float, above=True),
             "--cull": NOT_EMPTY, "--frames": NOT_EMPTY, "--fps": FPS,
             "--regional": NOT_EMPTY},
    "compare": {
        "--jobs": Range(1, MAX_JOBS),
        "--agreement": Range(0, 1000),
        "--worlds": NOT_EMPTY, "--structures": NOT_EMPTY, "--cull": NOT_EMPTY,
        "--profiles": NOT_EMPTY, "--methods": NOT_EMPTY, "--taus": NOT_EMPTY,
        "--paths": NOT_EMPTY,
    },
    "view": {"--scale": Range(1, 8), "--cull": NOT_EMPTY,
             "--lod": Range(0.0, 1e6, float, above=True), "--fps": FPS},
}


# Structure parameters with a numeric range (--structure KIND:...,key=value, and the API's
# partition(..., key=value)): partition/ cannot import this layer, so partition() checks them
# through the constant each mirrors (budget: partition/pvs_coarsen.BUDGET_MAX, a share of the
# OBJ's bytes); tests/test_cli_options.py checks they agree.
STRUCTURE = {"budget": Range(0.0, 64.0, float, above=True)}


def _dest(option: str) -> str:
    return option.lstrip("-").replace("-", "_")


def annotate(parser: argparse.ArgumentParser, command: str) -> set:
    """Append each option's range from RANGES to its help, in parser and its action
    subparsers ("terrain build"); returns the (command, option) pairs found."""
    found = set()
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                found |= annotate(sub, f"{command} {name}")
            continue
        for option in action.option_strings:
            limit = RANGES.get(command, {}).get(option)
            if limit is not None and action.help not in (None, argparse.SUPPRESS):
                action.help += f" [{limit.text()}]"
                found.add((command, option))
    return found


def command_of(args) -> str:
    """The RANGES key of parsed args: "partition", "terrain build", ..."""
    action = getattr(args, "action", None)
    return f"{args.command} {action}" if action else args.command


def check(args) -> None:
    """VisMobileError (one line, exit 2) on the first option of args outside its range."""
    from ..errors import VisMobileError

    for option, limit in RANGES.get(command_of(args), {}).items():
        value = getattr(args, _dest(option), None)
        if value is None:
            continue
        problem = limit.problem(value)
        if problem:
            shown = value[-1] if isinstance(value, list) and value else value
            raise VisMobileError(f"{option} {problem}, got {shown!r}")

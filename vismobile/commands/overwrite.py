"""No command writes over one of its inputs (issue 28: `partition m.obj -o m.obj` replaced its
own input). One table names, per command, the options read and the outputs written; cli runs
check(args) before the command starts. Paths are compared as files (os.path.samefile: through
symlinks and hard links) when both exist, else by their resolved paths."""
from __future__ import annotations

import os
from pathlib import Path

# command -> (input options, file outputs, folder outputs {option: names written inside it}).
# A folder output's names: files and subfolders the command writes there.
PLAY_FILES = ("frames.csv", "summary.json", "run.gif", "frames")
COMPARE_FILES = ("runs.csv", "runs.json", "report.html", "agreement.json", "terrain.csv",
                 "terrain.json", "runs", "fixed")
IO = {
    "partition": (("world",), ("out",), {}),
    "play": (("world", "trajectory", "motion"), (), {"out": PLAY_FILES}),
    "compare": (("worlds", "trajectory", "terrain"), ("report",), {"out": COMPARE_FILES}),
    "tune": (("world", "trajectory"), ("out",), {}),
    "trajectory generate": (("world",), ("out",), {}),
    "terrain build": (("source",), ("out", "obj"), {}),
    "terrain tile": (("terrain",), ("out",), {}),
    "view": (("world", "trajectory", "motion"), ("record_to",), {}),
    "info": (("world",), ("out",), {}),
}


def _same(a, b) -> bool:
    try:
        return os.path.samefile(a, b)
    except (OSError, ValueError):
        return os.path.realpath(a) == os.path.realpath(b)


def _inside(path, folder) -> bool:
    """path is folder or lies below it (resolved)."""
    path, folder = Path(os.path.realpath(path)), Path(os.path.realpath(folder))
    return path == folder or folder in path.parents


def _inputs(args, names) -> list:
    """Existing input files among the options (comma lists for --worlds)."""
    found = []
    for name in names:
        value = getattr(args, name, None)
        if value is None:
            continue
        items = str(value).split(",") if name == "worlds" else [str(value)]
        found += [item for item in items if item and os.path.isfile(item)]
    return found


def _input_folders(args, names) -> list:
    """Input options naming a folder (a world directory, vismobile.world.mapped)."""
    values = [getattr(args, name, None) for name in names if name != "worlds"]
    return [str(v) for v in values if v is not None and os.path.isdir(str(v))]


def check(args) -> None:
    """OutputError naming the output when it is (or would replace) an input, or when two
    outputs are one file."""
    from ..errors import OutputError
    from .options import command_of

    spec = IO.get(command_of(args))
    if spec is None:
        return
    input_names, file_names, folder_names = spec
    inputs = _inputs(args, input_names)
    outputs = [Path(v) for v in (getattr(args, n, None) for n in file_names) if v is not None]
    for output in outputs:
        for source in inputs:
            if _same(output, source):
                raise OutputError(output, f"is an input ({source}); refusing to overwrite it")
        for folder in _input_folders(args, input_names):  # a world directory's own files
            if os.path.isfile(output) and _inside(output, folder):
                raise OutputError(output, f"is a file of the input {folder}; refusing to "
                                          "overwrite it")
    for i, output in enumerate(outputs):
        for other in outputs[i + 1:]:
            if _same(output, other):
                raise OutputError(output, f"is given twice as an output ({other})")
    for name, written in folder_names.items():
        folder = getattr(args, name, None)
        if folder is None:
            continue
        for source in inputs:
            if _same(folder, source):
                raise OutputError(folder, f"is an input ({source}); give a folder for the output")
            for child in written:
                if _inside(source, Path(folder) / child):
                    raise OutputError(folder, f"would replace its input {source} "
                                              f"({Path(folder) / child})")

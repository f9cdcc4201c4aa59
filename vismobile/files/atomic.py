"""Atomic output: every file is written to a temporary sibling and renamed over its destination,
so a reader (or a later run after kill -9) never sees part of a file.

Temporary names are `.NAME.PID.tmp` beside the destination; the first write into a directory
removes those left by processes that no longer run. Destinations that are not regular files
(directories, devices, pipes) are refused: a rename would replace the node itself.
"""
from __future__ import annotations

import contextlib
import os
import re
import shutil
import stat
from pathlib import Path

from ..errors import OutputError

TEMP_NAME = re.compile(r"^\.(?P<name>.+)\.(?P<pid>\d{1,10})\.tmp$")
# Directories already swept of stale temporary files by this process.
_swept: set = set()


def temp_path(path: Path) -> Path:
    """The temporary sibling this process writes before renaming onto path."""
    return path.with_name(f".{path.name}.{os.getpid()}.tmp")


def _alive(pid: int) -> bool:
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OverflowError):
        return pid < 1 << 22  # exists but not ours (or out of range: not a pid at all)
    return True


def sweep_stale(directory: Path) -> None:
    """Remove `.NAME.PID.tmp` files and folders whose writing process is gone (once per folder)."""
    key = str(directory)
    if key in _swept:
        return
    _swept.add(key)
    try:
        entries = list(os.scandir(directory))
    except OSError:
        return
    for entry in entries:
        match = TEMP_NAME.match(entry.name)
        if not match or _alive(int(match["pid"])):
            continue
        with contextlib.suppress(OSError):
            if entry.is_dir(follow_symlinks=False):
                shutil.rmtree(entry.path)
            else:
                os.unlink(entry.path)


def check_destination(path) -> Path:
    """path as a Path, or OutputError when it cannot be a regular output file.

    Refused: an existing directory, device, pipe or socket (also behind a symlink), and a path
    whose parent is an existing non-directory.
    """
    path = Path(path)
    if not path.name or path.name in (".", ".."):
        raise OutputError(path, "is a directory, not a file name")
    try:
        mode = os.stat(path).st_mode
    except FileNotFoundError:
        mode = None
    except NotADirectoryError:
        raise OutputError(path, f"{_file_ancestor(path)} is a file, not a directory") from None
    except OSError as error:
        raise OutputError(path, error.strerror or str(error)) from None
    if mode is not None and stat.S_ISDIR(mode):
        raise OutputError(path, "is a directory; give a file name")
    if mode is not None and not stat.S_ISREG(mode):
        raise OutputError(path, "is not a regular file (device, pipe or socket); refusing to "
                                "replace it")
    ancestor = _file_ancestor(path)
    if ancestor is not None:
        raise OutputError(path, f"{ancestor} is a file, not a directory")
    return path


def _file_ancestor(path: Path):
    """The nearest existing ancestor of path that is not a directory, or None."""
    for parent in path.parents:
        try:
            mode = os.stat(parent).st_mode
        except (FileNotFoundError, NotADirectoryError):
            continue
        except OSError:
            return None
        return None if stat.S_ISDIR(mode) else parent
    return None


def make_dirs(directory) -> Path:
    """mkdir -p, or OutputError naming the folder."""
    directory = Path(directory)
    ancestor = _file_ancestor(directory / "x")
    if ancestor is not None:
        raise OutputError(directory, f"{ancestor} is a file, not a directory")
    try:
        directory.mkdir(parents=True, exist_ok=True)
    except OSError as error:
        raise OutputError(directory, f"cannot create folder: {error.strerror or error}") from None
    return directory


def atomic_write_bytes(path, data: bytes) -> None:
    """Write data to path through a temporary file and a rename: readers never see a part.

    Raises OutputError naming path when it is not a regular file's place, or when writing
    fails (read-only or full file system); no temporary file is left behind.
    """
    with atomic_writer(path) as handle:
        handle.write(data)


@contextlib.contextmanager
def atomic_writer(path):
    """Yield a binary handle on path's temporary sibling; on success it is synced and renamed
    onto path (a file too large to hold as bytes, written as it is made). On an exception,
    or when writing fails (OutputError naming path), no temporary file is left behind."""
    path = check_destination(path)
    make_dirs(path.parent)
    sweep_stale(path.parent)
    tmp = temp_path(path)
    try:
        with open(tmp, "wb") as handle:
            yield handle
            handle.flush()
            os.fsync(handle.fileno())
        os.replace(tmp, path)
    except OSError as error:
        raise OutputError(path, f"cannot write: {error.strerror or error}") from None
    finally:
        with contextlib.suppress(OSError):
            os.unlink(tmp)


@contextlib.contextmanager
def staged_directory(out, marker="summary.json"):
    """Write a run folder consistently: yields a staging folder to fill; on success its files
    move into `out`, the marker file last, so a folder with the marker holds one whole run.

    A new `out` appears by one rename of the staging folder; an existing one first loses its
    marker, then gets the new files (each by a rename), then the new marker. On an exception
    the staging folder is removed and `out` keeps its old marker-less or complete state.
    """
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise OutputError(out, "is a file; give a folder for the run")
    make_dirs(out.parent)
    sweep_stale(out.parent)
    stage = temp_path(out)
    if stage.exists():
        shutil.rmtree(stage)
    make_dirs(stage)
    try:
        try:
            yield stage
        except OutputError as error:  # name the run folder, not the hidden staging one
            where = Path(error.path)
            if where != stage and stage not in where.parents:
                raise
            raise OutputError(out / where.relative_to(stage),
                              str(error)[len(error.path) + 2:]) from None
        try:
            if not out.exists():
                os.rename(stage, out)
                return
            with contextlib.suppress(FileNotFoundError):
                os.unlink(out / marker)
            files = sorted(p for p in stage.rglob("*") if not p.is_dir())
            for source in sorted(files, key=lambda p: p.name == marker and p.parent == stage):
                target = out / source.relative_to(stage)
                check_destination(target)
                target.parent.mkdir(parents=True, exist_ok=True)
                os.replace(source, target)
        except OSError as error:
            raise OutputError(out, f"cannot write: {error.strerror or error}") from None
    finally:
        if stage.exists():
            shutil.rmtree(stage, ignore_errors=True)

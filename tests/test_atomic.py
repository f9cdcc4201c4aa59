"""Atomic output: refused destinations, no temporary file left, stale ones swept, staged runs."""
import errno
import os
import subprocess
import sys

import pytest

from vismobile.files import atomic
from vismobile.files.atomic import atomic_write_bytes, staged_directory
from vismobile.errors import OutputError


def leftovers(folder):
    return sorted(p.name for p in folder.rglob("*.tmp"))


def test_write_replaces_a_file_and_leaves_no_temporary(tmp_path):
    target = tmp_path / "a" / "b.bin"
    atomic_write_bytes(target, b"one")
    atomic_write_bytes(target, b"two")
    assert target.read_bytes() == b"two" and leftovers(tmp_path) == []


@pytest.mark.parametrize("where", ["directory", "under_a_file", "device"])
def test_refused_destinations_name_the_path(tmp_path, where):
    (tmp_path / "file").write_text("x")
    target = {"directory": tmp_path, "under_a_file": tmp_path / "file" / "out.vmp",
              "device": "/dev/null"}[where]
    with pytest.raises(OutputError) as info:
        atomic_write_bytes(target, b"data")
    assert str(target) in str(info.value)
    assert os.path.exists("/dev/null") and not os.path.isfile("/dev/null")
    assert leftovers(tmp_path) == []


def test_a_failing_file_system_is_an_output_error_without_leftovers(tmp_path, monkeypatch):
    def read_only(*args):
        raise OSError(errno.EROFS, "Read-only file system")

    monkeypatch.setattr(atomic.os, "replace", read_only)
    with pytest.raises(OutputError, match="Read-only file system"):
        atomic_write_bytes(tmp_path / "x.csv", b"data")
    assert leftovers(tmp_path) == [] and not (tmp_path / "x.csv").exists()


def test_stale_temporaries_of_dead_processes_are_swept(tmp_path):
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"],
                          capture_output=True, text=True).stdout.strip()
    stale_file = tmp_path / f".w2.vmp.{dead}.tmp"
    stale_dir = tmp_path / f".run.{dead}.tmp"
    live = tmp_path / f".w2.vmp.{os.getppid()}.tmp"  # the parent still runs
    stale_file.write_bytes(b"part")
    stale_dir.mkdir()
    (stale_dir / "frames.csv").write_text("part")
    live.write_bytes(b"in progress")
    atomic_write_bytes(tmp_path / "w2.vmp", b"whole")
    assert not stale_file.exists() and not stale_dir.exists() and live.exists()


def test_staged_run_folder_appears_whole(tmp_path):
    out = tmp_path / "run"
    with staged_directory(out) as stage:
        atomic_write_bytes(stage / "frames.csv", b"new")
        assert not out.exists()
        atomic_write_bytes(stage / "summary.json", b"{}")
    assert sorted(p.name for p in out.iterdir()) == ["frames.csv", "summary.json"]
    assert leftovers(tmp_path) == [] and sorted(tmp_path.iterdir()) == [out]


def test_a_failed_run_leaves_no_new_file_beside_an_old_summary(tmp_path):
    out = tmp_path / "run"
    out.mkdir()
    (out / "frames.csv").write_text("old")
    (out / "summary.json").write_text("old")
    with pytest.raises(RuntimeError):
        with staged_directory(out) as stage:
            atomic_write_bytes(stage / "frames.csv", b"new")
            raise RuntimeError("killed")
    assert (out / "frames.csv").read_text() == "old" and (out / "summary.json").exists()
    with staged_directory(out) as stage:
        atomic_write_bytes(stage / "frames.csv", b"new")
        atomic_write_bytes(stage / "summary.json", b"new")
    assert (out / "frames.csv").read_text() == "new" == (out / "summary.json").read_text()
    assert leftovers(tmp_path) == []

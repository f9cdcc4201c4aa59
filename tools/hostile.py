"""Issue 28's crafted hostile inputs: mesh formats (PLY, STL, OFF, glTF/GLB: accessors, indices,
buffer URIs, node graphs, instancing, matrices), .gz, .vmt, .vmp and trajectories as special
files, and heightmap files. Each case writes its files into a folder and gives the CLI
arguments that read them; `run` plays one in a child process and reports how it ended. The
mesh and scene cases are in hostile_meshes.py, the terrain ones in hostile_terrain.py (their
format writers in hostile_writers.py), the special files here.

A clean case: exit code 2, one stderr line naming the file, no traceback, nothing left in the
folder but the inputs, and the child's peak RSS under 2 GiB (read from os.wait4's rusage).

Usage (also `tools/fuzz.py hostile`):
  .venv/bin/python tools/hostile.py [NAME ...]     # all cases, or the named ones
"""
from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tools"))  # the cases' modules

import hostile_meshes  # noqa: E402 - mesh and scene files
import hostile_terrain  # noqa: E402 - .vmt, heightmaps, GeoTIFFs, .vmrpages
from hostile_writers import TRAJECTORY  # noqa: E402

RSS_LIMIT = 2 << 30  # bytes: the bound for any input
ADDRESS_LIMIT = 6 << 30  # the child's address space cap: a runaway case fails, not the machine
TIME_LIMIT = 120  # seconds per case (a hang is a failure, not a wait)


# ---- special files: FIFOs and devices where files are read ----------------------------------
def _special(folder, name, make, argv):
    path = folder / name
    make(path)
    return [a if a != "{}" else path for a in argv], path


SPECIAL = {}
SPECIAL["vmt_fifo"] = lambda folder: _special(folder, "t.vmt", os.mkfifo,
                                              ["terrain", "info", "{}"])
SPECIAL["vmt_dev_zero"] = lambda folder: _special(
    folder, "t.vmt", lambda p: os.symlink("/dev/zero", p), ["terrain", "info", "{}"])
SPECIAL["vmt_dev_urandom"] = lambda folder: _special(
    folder, "t.vmt", lambda p: os.symlink("/dev/urandom", p), ["terrain", "info", "{}"])
SPECIAL["vmp_fifo_play"] = lambda folder: _special(
    folder, "w.vmp", os.mkfifo, ["play", "{}", "--trajectory", TRAJECTORY, "-o",
                                 folder / "run", "--quiet"])
SPECIAL["vmp_dev_zero_play"] = lambda folder: _special(
    folder, "w.vmp", lambda p: os.symlink("/dev/zero", p),
    ["play", "{}", "--trajectory", TRAJECTORY, "-o", folder / "run", "--quiet"])
SPECIAL["trajectory_fifo"] = lambda folder: _special(
    folder, "t.csv", os.mkfifo, ["play", "w1", "--trajectory", "{}", "-o", folder / "run",
                                 "--quiet"])
SPECIAL["obj_fifo"] = lambda folder: _special(folder, "m.obj", os.mkfifo, ["info", "{}"])
SPECIAL["ply_dev_zero"] = lambda folder: _special(
    folder, "m.ply", lambda p: os.symlink("/dev/zero", p), ["info", "{}"])


# name -> write(folder) -> (argv, the file the error must name)
CASES = {**hostile_meshes.CASES, **hostile_terrain.CASES, **SPECIAL}


# ---- running a case ---------------------------------------------------------------------------
def _cap():
    import resource

    resource.setrlimit(resource.RLIMIT_AS, (ADDRESS_LIMIT, ADDRESS_LIMIT))


def listing(folder: Path) -> list:
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*"))


def run(name: str, folder: Path | None = None) -> dict:
    """Play case `name` in a child `python -m vismobile`: {name, rc, stderr, seconds, rss_mb,
    clean, why}. clean: rc 2, one stderr line naming the file, no traceback, no new file,
    peak RSS under RSS_LIMIT."""
    with tempfile.TemporaryDirectory(prefix="hostile-") as tmp:
        folder = Path(tmp) if folder is None else folder
        argv, named = CASES[name](folder)
        before = listing(folder)
        env = dict(os.environ, PYTHONPATH=str(ROOT), VISMOBILE_STATUS="off")  # no status lines
        start = time.perf_counter()
        with tempfile.TemporaryFile() as err:
            child = subprocess.Popen([sys.executable, "-m", "vismobile", *map(str, argv)],
                                     stdout=subprocess.DEVNULL, stderr=err, env=env,
                                     cwd=folder, preexec_fn=_cap)
            timer = __import__("threading").Timer(TIME_LIMIT, child.kill)
            timer.start()
            try:
                _, status, usage = os.wait4(child.pid, 0)
            finally:
                timer.cancel()
            child.returncode = os.waitstatus_to_exitcode(status)
            err.seek(0)
            stderr = err.read().decode("utf-8", "replace")
        seconds = time.perf_counter() - start
        lines = stderr.strip().splitlines()
        rss = usage.ru_maxrss * 1024
        after = listing(folder)
        why = []
        if child.returncode != 2:
            why.append(f"rc {child.returncode}")
        if len(lines) != 1:
            why.append(f"{len(lines)} stderr lines")
        if "Traceback" in stderr:
            why.append("traceback")
        if lines and str(named) not in lines[-1]:
            why.append("file not named")
        if after != before:
            why.append(f"left {sorted(set(after) - set(before))}")
        if rss >= RSS_LIMIT:
            why.append(f"peak RSS {rss / 2**20:.0f} MB")
        return {"name": name, "rc": child.returncode, "stderr": lines[-1] if lines else "",
                "seconds": round(seconds, 2), "rss_mb": round(rss / 2 ** 20, 1),
                "clean": not why, "why": ", ".join(why)}


def main(names=None) -> int:
    names = names or list(CASES)
    clean = 0
    for name in names:
        result = run(name)
        clean += result["clean"]
        mark = "clean" if result["clean"] else f"FAIL ({result['why']})"
        print(f"{name:34s} {mark:10s} rc {result['rc']:3d} {result['seconds']:6.2f} s "
              f"{result['rss_mb']:7.1f} MB  {result['stderr'][:110]}", flush=True)
    print(f"{clean} of {len(names)} cases clean")
    return 0 if clean == len(names) else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))

"""numba's on-disk cache gets one folder per content of the package's sources
(vismobile._kernel_cache_dir): an edit in any file, even one a kernel only inlines from,
starts a fresh folder, so no stale kernel runs; folders unused for a week are removed."""
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PROBE = ("import os, vismobile\n"
         "from vismobile.partition import dynamic\n"
         "print(os.environ['NUMBA_CACHE_DIR'])\n"
         "print(dynamic._refit._cache._cache_path)\n")


def cache_folders(package_parent: Path, base: Path) -> list:
    env = dict(os.environ, PYTHONPATH=str(package_parent), NUMBA_CACHE_DIR=str(base))
    out = subprocess.run([sys.executable, "-c", PROBE], env=env, cwd=package_parent,
                         capture_output=True, text=True, timeout=300, check=True).stdout.split()
    return [Path(p) for p in out]


def test_a_source_change_gives_a_fresh_cache_folder(tmp_path):
    base = tmp_path / "cache"
    stale = base / "vismobile-0000000000000000"
    stale.mkdir(parents=True)
    week_ago = time.time() - 8 * 86400
    os.utime(stale, (week_ago, week_ago))
    recent = base / "vismobile-1111111111111111"
    recent.mkdir()
    copy = tmp_path / "pkg"
    shutil.copytree(ROOT / "vismobile", copy / "vismobile",
                    ignore=shutil.ignore_patterns("__pycache__"))
    folder, kernel = cache_folders(copy, base)
    assert folder.parent == base and folder.name.startswith("vismobile-")
    assert kernel.is_relative_to(folder)  # the kernels cache there
    assert not stale.exists() and recent.exists()  # a week unused goes, the rest stays
    assert cache_folders(copy, base)[0] == folder  # same sources, same folder
    callee = copy / "vismobile" / "culling" / "hiz" / "buffer.py"
    callee.write_text(callee.read_text() + "\n# an edit a caller elsewhere inlines\n")
    assert cache_folders(copy, base)[0] != folder

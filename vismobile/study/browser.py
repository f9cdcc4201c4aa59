"""Headless Debian chromium for the report: screenshots and the rendered DOM, offline.

Used by tests/study/test_report_browser.py (the report renders, every figure loads) and
tools/report_screenshot.py (docs/report_first_screen.png). chromium runs with no network
access it could start on its own (no component updates, sync, QUIC or background networking)
and a fresh, empty profile folder.
"""
from __future__ import annotations

import shutil
import subprocess
import tempfile
from pathlib import Path

FLAGS = ("--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync",
         "--hide-scrollbars")


def chromium() -> str | None:
    """Path of the chromium executable, or None when it is not installed."""
    return shutil.which("chromium") or shutil.which("chromium-browser")


def run(page, *args, timeout: float = 120.0) -> subprocess.CompletedProcess:
    """chromium FLAGS args file://page with an empty --user-data-dir; raises FileNotFoundError
    when chromium is missing, subprocess.TimeoutExpired after timeout seconds."""
    executable = chromium()
    if executable is None:
        raise FileNotFoundError("chromium is not installed (Debian: apt-get install chromium)")
    with tempfile.TemporaryDirectory(prefix="vismobile-chromium-") as profile:
        return subprocess.run([executable, *FLAGS, f"--user-data-dir={profile}", *args,
                               Path(page).resolve().as_uri()],
                              capture_output=True, text=True, timeout=timeout, check=False)


def dump_dom(page, budget_ms: int = 10000) -> str:
    """The DOM after the page loaded and its scripts ran (virtual time budget_ms)."""
    return run(page, f"--virtual-time-budget={budget_ms}", "--dump-dom").stdout


def screenshot(page, png, width: int = 1280, height: int = 900) -> Path:
    """PNG of the page's first width x height pixels (the first screen)."""
    png = Path(png).resolve()
    png.parent.mkdir(parents=True, exist_ok=True)
    done = run(page, f"--window-size={width},{height}", f"--screenshot={png}")
    if not png.is_file():
        raise RuntimeError(f"chromium wrote no screenshot: {done.stderr.strip()[-300:]}")
    return png

"""Viewer start-up: seconds from the first import to the first frame on screen, per window
library, and the viewer's own start (world, octree, Culler, first rendered frame).

Run under a display, e.g.  xvfb-run -a .venv/bin/python tools/bench_viewer.py [--runs 5]
Each sample is a fresh process (imports are part of start-up); medians are printed, and the
ratio against pyglet measured in the same run. moderngl-window is measured when importable
(it is not a dependency: to compare, run this with an interpreter that has it).
"""
from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

SNIPPETS = {
    "pyglet": """
import time; start = time.perf_counter()
import pyglet
pyglet.options["shadow_window"] = False
window = pyglet.window.Window(840, 640, vsync=False)
window.dispatch_events(); window.clear(); window.flip()
print(time.perf_counter() - start)
""",
    "moderngl-window": """
import time; start = time.perf_counter()
import moderngl_window
from moderngl_window.conf import settings
settings.WINDOW["class"] = "moderngl_window.context.pyglet.Window"
settings.WINDOW["size"] = (840, 640)
settings.WINDOW["vsync"] = False
window = moderngl_window.create_window_from_settings()
window.ctx.clear(0.0, 0.0, 0.0); window.swap_buffers()
print(time.perf_counter() - start)
""",
    "vismobile view w1 (first frame)": """
import time; start = time.perf_counter()
from vismobile.viewer import Session
from vismobile.viewer.window import run
session = Session.open("worlds/w1.obj", "octree:4", "vfc")
run(session, 2, script=[(0, "down", "UP"), (0, "up", "UP")])
print(time.perf_counter() - start)
""",
}


def sample(code: str) -> float | None:
    result = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True,
                            text=True, timeout=300)
    if result.returncode != 0:
        print(f"  failed: {result.stderr.strip().splitlines()[-1]}", file=sys.stderr)
        return None
    return float(result.stdout.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--runs", type=int, default=5)
    args = parser.parse_args()
    medians = {}
    for name, code in SNIPPETS.items():
        times = []
        for _ in range(args.runs):
            seconds = sample(code)
            if seconds is None:
                break
            times.append(seconds)
        if not times:
            print(f"{name}: not measured")
            continue
        medians[name] = statistics.median(times)
        ratio = medians[name] / medians["pyglet"] if "pyglet" in medians else float("nan")
        print(f"{name}: median {medians[name] * 1000:.0f} ms over {len(times)} runs "
              f"({ratio:.2f}x pyglet)")


if __name__ == "__main__":
    main()

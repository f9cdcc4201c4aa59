"""README figure: frames at the waypoints of the indoor (A-G, W2) and outdoor (A-D, W6) paths.

Usage: .venv/bin/python tools/waypoint_strip.py [PATH] (default docs/waypoints.png)

Each frame is the whole world drawn by the renderer at the iPaq's 240x320 with back faces
culled, so it can be set beside the view the thesis describes at that waypoint (Tables 5.5,
5.6); the label gives the frame and the triangles the item buffer shows there.
"""
from __future__ import annotations

import argparse
import io
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from vismobile.device.profile import get_profile  # noqa: E402
from vismobile.render import Renderer, item_buffer_renderer  # noqa: E402
from vismobile.render.images import labelled_strip  # noqa: E402
from vismobile.world.trajectory import Trajectory  # noqa: E402
from vismobile.world.world import atomic_write_bytes  # noqa: E402

ROWS = (("w2", "indoor.csv", "W2, indoor path (thesis Table 5.5)"),
        ("w6", "outdoor.csv", "W6, outdoor path (thesis Table 5.6)"))
LIMIT_BYTES = 500_000


def waypoint_frames(world, trajectory, profile):
    """[(label, (H, W, 3) uint8)] for each waypoint, in frame order."""
    renderer = Renderer(world, profile)
    ids = item_buffer_renderer(world, profile)
    every = np.arange(world.triangle_count)
    items = []
    for label, frame in sorted(trajectory.waypoints.items(), key=lambda item: item[1]):
        camera = trajectory.camera(frame, profile.aspect)
        image = renderer.render_rgb(every, camera, cull_back=True)
        visible = len(ids.visible(every, camera, cull_back=True))
        items.append((f"{label}  frame {frame}  {visible:,} visible", image))
    return items


def main(argv=None):
    from PIL import Image
    from vismobile.scenes import build_world

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("path", nargs="?", type=Path, default=ROOT / "docs" / "waypoints.png")
    args = parser.parse_args(argv)
    profile = get_profile("ipaq-hx2490b")
    rows = []
    for name, trajectory_file, title in ROWS:
        trajectory = Trajectory.load(ROOT / "trajectories" / trajectory_file)
        rows.append((title, waypoint_frames(build_world(name), trajectory, profile)))
    strip = labelled_strip(rows)
    # A 256-colour palette keeps the figure small; the shading is smooth, so little is lost.
    picture = Image.fromarray(strip).quantize(colors=256, method=Image.Quantize.MEDIANCUT,
                                              dither=Image.Dither.NONE)
    buffer = io.BytesIO()
    picture.save(buffer, format="PNG", optimize=True)
    data = buffer.getvalue()
    if len(data) > LIMIT_BYTES:
        raise SystemExit(f"strip is {len(data):,} bytes, over the {LIMIT_BYTES:,} byte limit")
    atomic_write_bytes(args.path, data)
    print(f"wrote {args.path} ({strip.shape[1]}x{strip.shape[0]}, {len(data) / 1024:.0f} KB)")


if __name__ == "__main__":
    main()

"""Two configurations on one walk, compared frame by frame, with a plot.

    python examples/compare_two.py [--frames 60] [--out compare_two.png]

It walks a circle through the room of own_mesh.py and plays it twice: an octree with view-
frustum culling, and a BSP tree with frustum and conservative back-face culling. It prints
each run's triangles sent and modelled iPaq frame time, and plots triangles sent per frame.
"""
import argparse
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # files only, no window
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from own_mesh import demo_room  # noqa: E402

from vismobile import Scene, Trajectory, partition, play  # noqa: E402

CONFIGURATIONS = (("octree", {"depth": 3}, "vfc"), ("bsp", {}, "vfc+cbfc"))


def circle_walk(frames: int) -> Trajectory:
    """Eye height 1.6 m on a 2.5 m circle, looking along the walk."""
    angle = np.linspace(0, 2 * np.pi, frames, endpoint=False)
    poses = np.column_stack([2.5 * np.cos(angle), np.full(frames, 1.6), 2.5 * np.sin(angle),
                             -np.degrees(angle), np.full(frames, -5.0)])
    return Trajectory(poses, {"start": 0})


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=60, help="frames on the circle")
    parser.add_argument("--out", default="compare_two.png", help="plot to write")
    args = parser.parse_args(argv)

    world, walk = demo_room(), circle_walk(args.frames)
    plt.figure(figsize=(7, 3.5))
    for kind, params, cull in CONFIGURATIONS:
        scene = Scene(world, partition(world, kind, **params), kind)
        run = play(scene, walk, cull, "ipaq-hx2490b")
        sent = run.frames["triangles_sent"]
        ipaq = run.summary["model"]["ipaq-hx2490b"]["frame_ms"]["mean"]
        print(f"{kind:7} {cull:9} {sent.mean():7.1f} triangles sent, {ipaq:6.2f} ms/frame "
              "(iPaq model)")
        plt.plot(run.frames["frame"], sent, label=f"{kind}, {cull}")
    plt.xlabel("frame")
    plt.ylabel("triangles sent")
    plt.legend()
    plt.tight_layout()
    plt.savefig(args.out, dpi=80)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

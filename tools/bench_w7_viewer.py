"""The viewer's frame time on W7 with many moving objects (issue 25 target 4), headless: the
viewer's own frame function (viewer.Session.render: pose upload, cull, draw, overlays, god
view, HUD) along W7's path, its frames replayed in play mode.

    .venv/bin/python tools/bench_w7_viewer.py [--walkers 1000] [--frames 60] [--profile desktop]

Three scenes, interleaved frame by frame after a warm-up: W7 frozen (its motion dropped: the
baseline), W7 with its own 67 moving objects, and W7 plus --walkers people walking loops round
the blocks (scenes/crowd.street_walkers). Median and p95 ms of Session.render per scene, and
the pose upload's share. Also run by tools/bench_w7.py --viewer N.
"""
from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from vismobile.app.playback import Scene  # noqa: E402
from vismobile.partition import partition  # noqa: E402
from vismobile.scenes import build_world, crowd  # noqa: E402
from vismobile.scenes.thesis import motion_path  # noqa: E402
from vismobile.viewer import Session  # noqa: E402
from vismobile.world.animated import AnimatedWorld  # noqa: E402
from vismobile.world.world import World  # noqa: E402

PATH = ROOT / "trajectories" / "hybrid.csv"
STRUCTURE, STAGES = "octree:4", ("vfc", "tbfc")


def crowded(walkers: int, folder: Path) -> AnimatedWorld:
    """W7 plus `walkers` street walkers, with W7's motion and theirs."""
    base = build_world("w7")
    parts = crowd.street_walkers(walkers)
    extra = [World(v, t, None, [name], name) for name, v, t, _ in parts]
    world = World.concatenate([base] + extra, name=f"w7+{walkers}")
    document = json.loads(Path(motion_path("w7")).read_text())
    document["objects"].update({name: entry for name, _, _, entry in parts})
    path = folder / "crowd.json"
    path.write_text(json.dumps(document))
    return AnimatedWorld.from_motion_file(world, path)


def session(world, animated, profile) -> Session:
    built = partition(animated or world, STRUCTURE)
    scene = Scene(world, built, STRUCTURE, animated, 30.0)
    s = Session(scene, STAGES, profile, str(PATH), structures=(STRUCTURE,))
    s.press("play")
    return s


def viewer_times(walkers: int = 1000, frames: int = 60, profile: str = "desktop") -> dict:
    with tempfile.TemporaryDirectory() as tmp:
        big = crowded(walkers, Path(tmp))
        own = AnimatedWorld.from_motion_file(build_world("w7"), motion_path("w7"))
        sessions = {"frozen": session(build_world("w7"), None, profile),
                    "67 moving": session(own.world, own, profile),
                    f"{len(big.motion)} moving": session(big.world, big, profile)}
        times = {k: [] for k in sessions}
        poses = {k: [] for k in sessions}
        for k, s in sessions.items():  # warm-up: numba compiles, first uploads
            for _ in range(3):
                s.update(1 / 30)
                s.render()
        for _ in range(frames):
            for k, s in sessions.items():
                for _ in range(20):  # every 20th frame of the path
                    s.update(1 / 30)
                start = time.perf_counter()
                frame = s.render()
                times[k].append((time.perf_counter() - start) * 1e3)
                poses[k].append(frame.info.get("pose_ms", 0.0))
    print(f"4. viewer (Session.render, {profile}, {STRUCTURE} {'+'.join(STAGES)}), "
          f"{frames} frames each, interleaved:")
    out = {}
    for k in sessions:
        t = np.array(times[k])
        out[k] = (float(np.median(t)), float(np.percentile(t, 95)), float(np.median(poses[k])))
        print(f"   {k:14s} median {out[k][0]:7.2f} ms  p95 {out[k][1]:7.2f} ms  "
              f"({1000 / out[k][0]:.0f} fps)  pose upload median {out[k][2]:.2f} ms")
    return out


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--walkers", type=int, default=1000)
    parser.add_argument("--frames", type=int, default=60)
    parser.add_argument("--profile", default="desktop")
    args = parser.parse_args(argv)
    viewer_times(args.walkers, args.frames, args.profile)
    return 0


if __name__ == "__main__":
    sys.exit(main())

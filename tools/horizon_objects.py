"""Sweep of the `horizon` stage's proof obligation on object worlds: no triangle the item buffer
shows is dropped by vfc+horizon+tbfc, on the outdoor paths (level and pitched) and on random
cameras (anywhere in the world's box and below it, yaw and pitch +-89 at random, near 1e-3 to
1), for W5, W6 and a terrain world with objects (a 257^2 fractal at stride 2 with 60 shared
models standing on it), on octree 4 and the kd-tree.

    .venv/bin/python tools/horizon_objects.py [--worlds w5,w6,terrain] [--random 2000]
        [--modes float32,fixed16.16] [--fixed-random 200] [--structures octree:4,kdtree]
        [--screen]

Prints one row per world, structure and mode: cameras, cameras with a dropped triangle,
triangles dropped, and the triangles the stage culled (so a row that culls nothing is seen).
Truth: the item buffer (float32), or what a fixed16.16 device shows three ways (its transform,
the rounding alone, the exact world). --screen also checks the stage with the profile's screen
(triangles covering no pixel centre dropped too) against the same truth, in extra rows.
Exit code 1 when anything was dropped. Run one world at a
time on the shared machine (a few minutes each).
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from vismobile.world.camera import Camera  # noqa: E402
from vismobile.culling import Culler, device_options  # noqa: E402
from vismobile.partition import partition  # noqa: E402
from vismobile.partition.spec import parse_spec  # noqa: E402
from vismobile.device.profile import get_profile  # noqa: E402
from vismobile.render import SENTINEL, item_buffer  # noqa: E402
from vismobile.render.device_view import device_buffers, shown_ids  # noqa: E402
from vismobile.scenes import build_world  # noqa: E402
from vismobile.world.trajectory import Trajectory  # noqa: E402

TERRAIN_SIZE, TERRAIN_OBJECTS = 257, 60


def terrain_objects_world(size: int = TERRAIN_SIZE, objects: int = TERRAIN_OBJECTS):
    """(World, Heightmap): a fractal terrain at stride 2 with shared models standing on it."""
    from vismobile.terrain import sources
    from vismobile.terrain.mesh import terrain_world
    from vismobile.terrain.placement import place_objects

    hm = sources.diamond_square(size, seed=1, roughness=0.5, relief=0.12)
    placement = place_objects(hm, objects, seed=3, height=6.0 * hm.spacing)
    return terrain_world(hm, placement, stride=2), hm


def world_and_paths(name, aspect):
    """(World, {path label: [Camera]}) of a world: W5/W6 on the outdoor paths (every 25th
    frame), the terrain world on its valley and circle paths."""
    if name == "terrain":
        from vismobile.terrain.paths import path_cameras

        world, hm = terrain_objects_world()
        return world, {kind: path_cameras(hm, kind, "fast", frames=40, eye_height=2.0,
                                          aspect=aspect, every=5)
                       for kind in ("valley", "circle")}
    world = build_world(name)
    paths = {}
    for path in ("outdoor", "outdoor_pitched"):
        traj = Trajectory.load(ROOT / "trajectories" / f"{path}.csv")
        paths[path] = [traj.camera(int(f), aspect) for f in range(0, len(traj), 25)]
    return world, paths


def random_cameras(world, count, aspect, seed):
    """Cameras in the world's box widened below and above, any yaw, pitch +-89, near 1e-3-1."""
    rng = np.random.default_rng(seed)
    low, high = world.extent
    size = high - low
    cams = []
    for i in range(count):
        pos = rng.uniform(low - [0, 0.05 * size[1], 0], high + [0, 0.2 * size[1], 0])
        if i % 2:  # half of them near the ground's height, where the horizon has most to hide
            pos[1] = low[1] + rng.uniform(0.01, 3.0)
        cams.append(Camera(pos, yaw=rng.uniform(0, 360), pitch=rng.uniform(-89, 89),
                           aspect=aspect, near=float(rng.choice([1e-3, 0.1, 1.0]))))
    return cams


def truth_of(world, cam, profile):
    """ids shown: the item buffer (float32), or on fixed16.16 what the device shows three ways
    (render/device_view.py: its transform, the rounding alone, the exact world)."""
    if profile.fixed:
        return shown_ids(device_buffers(world, cam, profile, True))
    ids = np.unique(item_buffer(world, None, cam, profile, cull_back=True))
    return ids[ids != SENTINEL]


def sweep(world, cameras, part, profile, screen=False):
    """[(cameras with a drop, triangles dropped, triangles culled by the stage, of them
    covering no pixel centre)]: the stage in the profile's arithmetic, and with screen also
    with the profile's screen (device_options: horizon's `screen`), against the same truth."""
    options = [{"arithmetic": profile.vertex_format}] + ([device_options(profile)] if screen
                                                         else [])
    cullers = [Culler(part, "vfc,horizon,tbfc", **o) for o in options]
    counts = [[0, 0, 0, 0] for _ in cullers]
    for cam in cameras:
        truth = truth_of(world, cam, profile)
        for culler, count in zip(cullers, counts):
            result = culler.cull(cam)
            subpixel = result.stats.get("horizon.triangles_subpixel", 0)
            count[2] += result.stats.get("horizon.triangles_culled", 0) + subpixel
            count[3] += subpixel
            missing = len(np.setdiff1d(truth, result.triangles))
            count[0] += missing > 0
            count[1] += missing
    return counts


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--worlds", default="w5,w6,terrain")
    ap.add_argument("--random", type=int, default=2000, help="random cameras per world")
    ap.add_argument("--modes", default="float32,fixed16.16")
    ap.add_argument("--fixed-random", type=int, default=200,
                    help="random cameras in fixed16.16 (three renders each; default 200)")
    ap.add_argument("--structures", default="octree:4,kdtree")
    ap.add_argument("--profile", default="ipaq-hx2490b")
    ap.add_argument("--screen", action="store_true",
                    help="also check the stage with the profile's screen (triangles covering "
                         "no pixel centre dropped too), against the same truth")
    args = ap.parse_args(argv)
    print("| world | cameras | structure | mode | cameras dropping | triangles dropped | "
          "triangles culled (no centre) | s |")
    print("| --- | --- | --- | --- | ---: | ---: | ---: | ---: |")
    failed = False
    for name in args.worlds.split(","):
        base = get_profile(args.profile)
        world, paths = world_and_paths(name, base.aspect)
        sets = dict(paths)
        sets[f"random {args.random}"] = random_cameras(world, args.random, base.aspect,
                                                       seed=len(name))
        for spec in args.structures.split(","):
            kind, params = parse_spec(spec)
            part = partition(world, kind, **params)
            for mode in args.modes.split(","):
                profile = get_profile(args.profile, mode)
                for label, cameras in sets.items():
                    if profile.fixed and label.startswith("random"):
                        cameras = cameras[:args.fixed_random]
                        label = f"random {len(cameras)}"
                    start = time.perf_counter()
                    rows = sweep(world, cameras, part, profile, args.screen)
                    seconds = time.perf_counter() - start
                    for k, (bad, dropped, culled, sub) in enumerate(rows):
                        failed |= dropped > 0
                        mode_label = f"{mode} @screen" if k else mode
                        print(f"| {name} | {label} ({len(cameras)}) | {spec} | {mode_label} | "
                              f"{bad} | {dropped} | {culled} ({sub}) | {seconds:.0f} |",
                              flush=True)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())

"""Sweep: does the horizon stage ever drop an object triangle the GPU draws over an LOD
terrain? (issue 30: `play t.vmt`'s objects, culled over the heightmap sunk by the LOD's error)

Random low cameras (eyes 1 cm to 5 m above the ground, log-uniform; near 1e-3 to 1,
log-uniform; any heading; pitch -30..20) over a steep and a noisy map with placed models, for
each LOD method at tau 1 px and each arithmetic (desktop in float32, the iPaq's screen in
16.16: `--profiles NAME:VERTEX_FORMAT`, the registered profiles being float32). Each camera
runs the TerrainScene frame (LOD, vfc+horizon over an octree), then draws the drawn LOD ground
and every object into the item buffer: an object triangle that shows must have been kept.
Prints per map, method and profile the cameras, the cameras with a drop, the dropped
triangles and the object triangles the horizon removed; exit code 1 on any drop. `--holes`:
the same maps with no-data holes (lakes, single samples, a one-sample gap), drawn cut by the
alpha test in the shaded and the item buffer alike.

    nice -n 5 python tools/terrain_objects_sweep.py --cameras 100   # ~5 min on one core
    nice -n 5 python tools/terrain_objects_sweep.py --cameras 100 --holes
"""
from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from vismobile.app.terrain_scene import METHODS, TerrainScene
from vismobile.device.profile import get_profile
from vismobile.render.terrain import TerrainRenderer
from vismobile.terrain import sources, store
from vismobile.terrain.placement import place_objects
from vismobile.world.camera import Camera


def holed(hm, seed):
    """The map with no-data holes (seed 002): lakes (disks of 3-15 samples' radius), a few
    single samples and a gap one sample wide across part of the map."""
    from vismobile.terrain.heightmap import quantize

    rng = np.random.default_rng(seed)
    h = hm.heights.astype(np.float64)
    n = hm.size
    i, j = np.mgrid[0:n, 0:n]
    for _ in range(6):
        ci, cj = rng.uniform(0.1, 0.9, 2) * n
        h[(i - ci) ** 2 + (j - cj) ** 2 < rng.uniform(3, 15) ** 2] = np.nan
    h[rng.integers(0, n, 40), rng.integers(0, n, 40)] = np.nan
    row = int(rng.integers(n // 4, 3 * n // 4))
    h[row, n // 5: 4 * n // 5] = np.nan
    return quantize(h, hm.spacing, hm.name + "-holes")


def maps(holes=False):
    out = {"steep": sources.diamond_square(129, seed=7, roughness=0.6, relief=0.35),
           "noisy": sources.diamond_square(129, seed=21, roughness=0.85, relief=0.12)}
    if holes:
        out = {f"{k}-holes": holed(v, len(k)) for k, v in out.items()}
    return out


def cameras(hm, count, seed):
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(count):
        x, z = rng.uniform(0.05, 0.95, 2) * hm.extent
        y = float(hm.height_at(x, z)) + 10 ** rng.uniform(-2, np.log10(5.0))
        out.append(Camera((x, y, z), yaw=rng.uniform(0, 360), pitch=rng.uniform(-30, 20),
                          fov=60, aspect=240 / 320, near=10 ** rng.uniform(-3, 0),
                          far=2 * hm.extent))
    return out


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--cameras", type=int, default=100)
    parser.add_argument("--objects", type=int, default=60)
    parser.add_argument("--holes", action="store_true",
                        help="the maps with no-data holes (lakes, single samples, a gap)")
    parser.add_argument("--methods", default=",".join(METHODS))
    parser.add_argument("--profiles", default="desktop,ipaq-hx2490b:fixed16.16",
                        help="NAME or NAME:VERTEX_FORMAT (the Culler's arithmetic is the "
                             "profile's vertex format; the registered profiles are float32)")
    args = parser.parse_args(argv)
    failed = False
    with tempfile.TemporaryDirectory() as folder:
        for name, hm in maps(args.holes).items():
            path = Path(folder) / f"{name}.vmt"
            store.save(path, hm, place_objects(hm, args.objects, seed=3, height=4.0))
            views = cameras(hm, args.cameras, seed=len(name))
            for label in args.profiles.split(","):
                name_, _, vertex_format = label.partition(":")
                profile = get_profile(name_, vertex_format or None)
                for method in args.methods.split(","):
                    start = time.perf_counter()
                    scene = TerrainScene(path, method, 1.0, ("vfc", "horizon"), "octree:3",
                                         profile)
                    renderer = TerrainRenderer(scene.heightmap, scene.profile)
                    bad = dropped = removed = 0
                    for camera in views:
                        f = scene.frame(camera)
                        lost = scene.visible_dropped(camera, renderer)
                        bad += lost > 0
                        dropped += lost
                        removed += f.triangles_hidden
                    failed |= bad > 0
                    print(f"{name:>6} {method:>9} {label:>24}: {len(views)} cameras, "
                          f"{bad} with a drop, {dropped} visible triangles dropped, "
                          f"{removed:,} object triangles removed by the horizon "
                          f"({time.perf_counter() - start:.0f} s)", flush=True)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())

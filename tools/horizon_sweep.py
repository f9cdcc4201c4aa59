"""Sweep: does the terrain horizon ever drop something the GPU draws? (issue 30)

Random low cameras over steep and noisy maps: eyes 1 cm to 5 m above the ground (log-uniform),
near planes 1e-3 to 1 (log-uniform), any heading, pitch -40..30 degrees. Each camera draws the
full-resolution ground (finest tiles, frustum-culled) plus boxes standing on it (bases 0.5
below the ground) into the item buffer; a tile or box the horizon hides must show no pixel.
Both arithmetics (float64, fixed16.16). Prints per map and arithmetic the cameras with a drop
and the largest drop in triangles; exit code 1 if anything visible was dropped.

    nice -n 5 python tools/horizon_sweep.py --cameras 2000    # ~4 min on one core
"""
from __future__ import annotations

import argparse
import sys
import time

import numpy as np

from vismobile.world.camera import Camera
from vismobile.device.profile import get_profile
from vismobile.geometry.boxes import box_mesh
from vismobile.render import SENTINEL
from vismobile.render.terrain import TerrainRenderer
from vismobile.terrain import sources
from vismobile.terrain.heightmap import quantize
from vismobile.terrain.horizon import HorizonCaster
from vismobile.terrain.tiles import TilePyramid, drop_hidden, full_selection, selection_mesh

BASE = 1 << 28


def steep_ridges(size: int = 129) -> object:
    """Parallel ridges with 60-70 degree flanks plus a little noise (a steep map)."""
    x = np.arange(size, dtype=np.float64)
    xx, zz = np.meshgrid(x, x)
    rng = np.random.default_rng(3)
    h = 6.0 * np.abs(((xx + 0.3 * zz) / 8.0) % 2.0 - 1.0) * 4.0 + rng.uniform(0, 0.5, xx.shape)
    return quantize(h, 1.0, "ridges")


def maps() -> dict:
    return {"ridges": steep_ridges(),
            "steep": sources.diamond_square(129, seed=21, roughness=0.6, relief=0.5),
            "noisy": sources.diamond_square(129, seed=8, roughness=0.85, relief=0.25)}


def ground_boxes(heightmap, count, seed):
    rng = np.random.default_rng(seed)
    xz = rng.uniform(0.05, 0.95, (count, 2)) * heightmap.extent
    size = rng.uniform(0.2, 4.0, count)
    ground = heightmap.height_at(xz[:, 0], xz[:, 1])
    low = np.c_[xz[:, 0] - size / 2, ground - 0.5, xz[:, 1] - size / 2]
    high = np.c_[xz[:, 0] + size / 2, ground + size, xz[:, 1] + size / 2]
    return np.stack([low, high], axis=1)


def low_cameras(heightmap, count, seed):
    """Random low cameras (eye 1 cm - 5 m above the ground, near 1e-3 - 1)."""
    rng = np.random.default_rng(seed)
    w = heightmap.extent
    xz = rng.uniform(0.1, 0.9, (count, 2)) * w
    up = 10.0 ** rng.uniform(-2, np.log10(5), count)
    near = 10.0 ** rng.uniform(-3, 0, count)
    yaw = rng.uniform(0, 360, count)
    pitch = rng.uniform(-40, 30, count)
    fov = float(np.degrees(2 * np.arctan(np.tan(np.radians(30.0)) / (240 / 320))))
    ground = heightmap.height_at(xz[:, 0], xz[:, 1])
    return [Camera((x, g + u, z), yaw=float(a), pitch=float(p), fov=fov, near=float(n),
                   far=1.5 * w) for (x, z), g, u, n, a, p in zip(xz, ground, up, near, yaw, pitch)]


def dropped_visible(renderer, pyramid, caster, camera, boxes, mesh) -> tuple:
    """(visible ground triangles on hidden tiles + visible triangles of hidden boxes,
    tiles hidden, boxes hidden) for one camera (horizon cast over the full-resolution ground)."""
    selection = full_selection(pyramid, camera)
    renderer.draw(*selection_mesh(pyramid, selection), camera, kind="item")
    renderer.draw_mesh_items(*mesh, camera, BASE)
    ids = renderer.read_ids()
    ids = ids[ids != SENTINEL].astype(np.int64)
    horizon = caster.cast(camera)
    kept = drop_hidden(pyramid, selection, horizon)
    per_tile = len(pyramid.templates[0])
    hidden_tile = np.ones(len(selection.level), bool)
    keys = selection.ti * (1 << 20) + selection.tj
    hidden_tile[np.isin(keys, kept.ti * (1 << 20) + kept.tj)] = False
    ground = np.unique(ids[ids < BASE])
    lost = int(hidden_tile[ground // per_tile].sum())
    hidden_box = horizon.hidden(boxes)
    seen_box = np.unique(ids[ids >= BASE] - BASE)
    lost += int(hidden_box[seen_box // 12].sum())
    return lost, int(hidden_tile.sum()), int(hidden_box.sum())


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cameras", type=int, default=2000, help="cameras in all (over maps)")
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args(argv)
    profile = get_profile("ipaq-hx2490b")
    failed = False
    heightmaps = maps()
    per_map = max(1, args.cameras // len(heightmaps))
    for name, hm in heightmaps.items():
        pyramid = TilePyramid.build(hm, 8)
        renderer = TerrainRenderer(hm, profile)
        boxes = ground_boxes(hm, 300, args.seed)
        mesh = box_mesh(boxes)
        cameras = low_cameras(hm, per_map, args.seed)
        for arithmetic in ("float64", "fixed16.16"):
            caster = HorizonCaster(hm, bands=60, step=0.02, arithmetic=arithmetic)
            start = time.perf_counter()
            bad, worst, tiles, hidden_boxes = 0, 0, 0, 0
            for camera in cameras:
                lost, t, b = dropped_visible(renderer, pyramid, caster, camera, boxes, mesh)
                bad += lost > 0
                worst = max(worst, lost)
                tiles += t
                hidden_boxes += b
            failed |= bad > 0
            print(f"{name:7s} {arithmetic:10s} cameras {len(cameras):5d}  with a visible drop "
                  f"{bad:4d}  worst {worst:5d} tris/boxes  tiles hidden {tiles:7d}  boxes hidden "
                  f"{hidden_boxes:6d}  {time.perf_counter() - start:6.1f} s", flush=True)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())

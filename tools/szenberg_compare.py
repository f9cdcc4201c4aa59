"""Szenberg's column ray caster against the triangle render of the same map (issue 30, seed 001).

For random level cameras (Szenberg's: heading, eye 2-40 spacings above the ground, the eye's
row `incl` 60-300 of 320) over a fractal and jacksboro (257^2), 240x320, 60 degrees:
- PSNR of the ray-cast colour image against the full-resolution triangle render (same
  per-vertex lighting; the caster's colour map is pre-lit), for Szenberg's slices with the
  Prof[] depth table (float64 and fixed16.16) and for the refined caster (grid-line crossings
  tested, exact crossing per pixel);
- 300 boxes 0.5-4 spacings wide standing on the ground (bases 0.5 spacing below it), drawn by OpenGL and Z-buffered into
  the ray-cast depth image: objects visible in one image and not in the other, and object
  pixels that differ, against the triangle render's item buffer;
- time: ray cast (each arithmetic), the triangle render of the full mesh (upload, draw,
  glFinish), medians over the views after a warm-up (Szenberg's Tables 8.1-8.3 in kind).

    nice -n 5 python tools/szenberg_compare.py [--views 20]
"""
from __future__ import annotations

import argparse
import sys
import time

import numpy as np

from vismobile.device.profile import get_profile
from vismobile.geometry.boxes import box_mesh
from vismobile.render import SENTINEL
from vismobile.render.szenberg import ColumnCaster, LevelCamera, composite_objects
from vismobile.render.terrain import TerrainRenderer
from vismobile.terrain import sources
from vismobile.terrain.tiles import TilePyramid, full_selection, selection_mesh

BASE = 1 << 28


def psnr(a, b) -> float:
    mse = float(np.mean((a.astype(np.float64) - b.astype(np.float64)) ** 2))
    return float("inf") if mse == 0 else 10 * np.log10(255.0 ** 2 / mse)


def ground_boxes(hm, count, seed):
    rng = np.random.default_rng(seed)
    xz = rng.uniform(0.05, 0.95, (count, 2)) * hm.extent
    size = rng.uniform(0.5, 4.0, count) * hm.spacing
    ground = hm.height_at(xz[:, 0], xz[:, 1])
    low = np.c_[xz[:, 0] - size / 2, ground - 0.5 * hm.spacing, xz[:, 1] - size / 2]
    high = np.c_[xz[:, 0] + size / 2, ground + size, xz[:, 1] + size / 2]
    return np.stack([low, high], axis=1)


def level_cameras(hm, count, seed, resolution):
    rng = np.random.default_rng(seed)
    xz = rng.uniform(0.1, 0.9, (count, 2)) * hm.extent
    up = rng.uniform(2, 40, count) * hm.spacing
    ground = hm.height_at(xz[:, 0], xz[:, 1])
    return [LevelCamera((x, g + u, z), float(a), resolution, float(i), near=0.1 * hm.spacing,
                        far=2 * hm.extent)
            for (x, z), g, u, a, i in zip(xz, ground, up, rng.uniform(0, 360, count),
                                          rng.uniform(60, 300, count))]


def objects_agree(sz_ids, tri_ids) -> tuple:
    """(objects only in one image, object pixels that differ, object pixels in the triangle
    render)."""
    a = sz_ids != SENTINEL
    b = (tri_ids != SENTINEL) & (tri_ids >= BASE)
    seen_a = set(np.unique((sz_ids[a] - BASE) // 12).tolist())
    seen_b = set(np.unique((tri_ids[b] - BASE) // 12).tolist())
    return len(seen_a ^ seen_b), int((a != b).sum()), int(b.sum())


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--views", type=int, default=20, help="views per map")
    parser.add_argument("--size", type=int, default=257)
    args = parser.parse_args(argv)
    profile = get_profile("ipaq-hx2490b")
    failed = False
    for name, hm in (("fractal", sources.diamond_square(args.size, seed=5, roughness=0.5,
                                                         relief=0.15)),
                     ("jacksboro", sources.dem("jacksboro", args.size))):
        pyramid = TilePyramid.build(hm, 16)
        mesh = selection_mesh(pyramid, full_selection(pyramid))
        renderer = TerrainRenderer(hm, profile)
        casters = {"float64": ColumnCaster(hm), "fixed16.16": ColumnCaster(hm, "fixed16.16")}
        boxes = ground_boxes(hm, 300, 2)
        vertices, triangles = box_mesh(boxes)
        cameras = level_cameras(hm, args.views, 7, profile.resolution)
        for caster in casters.values():  # warm-up: numba's compile stays out of the times
            caster.render(cameras[0])
        casters["float64"].render(cameras[0], refine=True)
        rows = {key: [] for key in ("table", "fixed", "refined")}
        times = {key: [] for key in ("table", "fixed", "refined", "triangles")}
        for camera in cameras:
            stats = renderer.draw(*mesh, camera)
            reference = renderer.read_rgb()
            times["triangles"].append(stats.render_ms)
            renderer.draw(*mesh, camera, kind="item")
            renderer.draw_mesh_items(vertices, triangles, camera, BASE)
            tri_ids = renderer.read_ids()
            for key, caster, refine in (("table", casters["float64"], False),
                                        ("fixed", casters["fixed16.16"], False),
                                        ("refined", casters["float64"], True)):
                start = time.perf_counter()
                image = caster.render(camera, refine=refine)
                times[key].append((time.perf_counter() - start) * 1000)
                sz_ids = composite_objects(image, renderer, vertices, triangles, camera, BASE)
                rows[key].append((psnr(image.rgb, reference),) + objects_agree(sz_ids, tri_ids))
        for key, values in rows.items():
            v = np.array(values, dtype=np.float64)
            worst = v[:, 0].min()
            failed |= worst < 30
            print(f"{name:9s} {key:8s} views {len(v):3d}  PSNR min {worst:5.1f} median "
                  f"{np.median(v[:, 0]):5.1f} dB  objects differing {int(v[:, 1].sum()):3d}  "
                  f"object pixels differing {int(v[:, 2].sum()):5d} of {int(v[:, 3].sum()):6d}  "
                  f"cast ms median {np.median(times[key]):6.1f}", flush=True)
        print(f"{name:9s} triangle render of the full mesh ({2 * (hm.size - 1) ** 2:,} "
              f"triangles) ms median {np.median(times['triangles']):6.1f}", flush=True)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())

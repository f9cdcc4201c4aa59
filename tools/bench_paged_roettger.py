"""Röttger paged in by pages (.vmrpages) against the in-memory method, frame by frame.

Usage: nice -n 5 .venv/bin/python tools/bench_paged_roettger.py [--size 1025] [--tau 2]
       [--path circle] [--speed fast] [--frames 40] [--every 10] [--budget-pages 300]
       [--render]
A diamond-square map (seed 3, roughness 0.5, relief 0.1) is built in memory, its pages written
to a temporary file, then each frame runs the in-memory Roettger (select and fan emission) and
the paged one (select with wanted pages read at once, fans), interleaved, after one untimed
warm-up frame each; --render also draws both fans (TerrainRenderer.draw_samples, vertices
gathered from the heightmap or from the pages). Prints medians of the LOD and render ms, the
pages a frame uses, misses, pages read ahead, evictions and bytes held, and whether every
frame's leaves were equal.
"""
from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=1025)
    parser.add_argument("--tau", type=float, default=2.0)
    parser.add_argument("--path", default="circle")
    parser.add_argument("--speed", default="fast")
    parser.add_argument("--frames", type=int, default=40)
    parser.add_argument("--every", type=int, default=10)
    parser.add_argument("--budget-pages", type=int, default=300)
    parser.add_argument("--render", action="store_true")
    args = parser.parse_args(argv)
    import numpy as np

    from vismobile.device.profile import get_profile
    from vismobile.render.terrain import TerrainRenderer
    from vismobile.render.tile_arena import PagedRenderer
    from vismobile.terrain import sources
    from vismobile.terrain.paged_roettger import PagedRoettger, write_pages
    from vismobile.terrain.paths import path_cameras
    from vismobile.terrain.roettger import Roettger

    hm = sources.diamond_square(args.size, seed=3, roughness=0.5, relief=0.1)
    roettger = Roettger(hm)
    profile = get_profile("ipaq-hx2490b")
    cameras = path_cameras(hm, args.path, args.speed, frames=args.frames + 1, every=args.every)
    held = sum(getattr(roettger, k).nbytes for k in ("d2", "hmin", "hmax", "centres",
                                                     "skip_error", "stamp", "lists"))
    held += hm.samples.nbytes + hm.heights.nbytes
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "t.vmrpages"
        start = time.perf_counter()
        write_pages(roettger, path)
        write_s = time.perf_counter() - start
        probe = PagedRoettger(path, thread=False)
        budget = probe.coarse * 48 + probe.grid.nbytes + args.budget_pages * probe.slot_bytes
        probe.close()
        paged = PagedRoettger(path, budget_bytes=budget)
        plain = TerrainRenderer(hm, profile) if args.render else None
        pager = PagedRenderer(paged, profile) if args.render else None
        rows = {k: [] for k in ("mem_lod", "paged_lod", "mem_draw", "paged_draw", "used",
                                "misses", "ahead", "held")}
        equal = True
        try:
            for k, camera in enumerate(cameras):
                start = time.perf_counter()
                fans = roettger.update(camera, profile.resolution, args.tau).triangles
                mem_lod = (time.perf_counter() - start) * 1000
                start = time.perf_counter()
                paged.select(camera, profile.resolution, args.tau)
                paged_fans = paged.triangles()
                paged_lod = (time.perf_counter() - start) * 1000
                equal &= np.array_equal(fans, paged_fans)
                draws = (0.0, 0.0)
                if args.render:
                    draws = (plain.draw_samples(fans, camera).render_ms,
                             pager.draw_samples(paged_fans, camera).render_ms)
                if k == 0:
                    continue  # warm-up: numba and the first pages
                for key, value in zip(rows, (mem_lod, paged_lod, *draws, len(paged._used()),
                                             paged.misses, paged.prefetched,
                                             paged.memory_bytes())):
                    rows[key].append(value)
                time.sleep(0.005)  # the loader thread's turn, as between real frames
        finally:
            paged.close()
        med = {k: float(np.median(v)) for k, v in rows.items()}
        print(f"{args.size}^2, tau {args.tau} px, {args.path} {args.speed}, {args.frames} "
              f"frames {args.every} apart; file {path.stat().st_size / (1 << 20):.1f} MB "
              f"written in {write_s:.2f} s; {paged.pages} pages of {paged.slot_bytes:,} bytes")
        print(f"LOD ms median: in memory {med['mem_lod']:.2f}, paged {med['paged_lod']:.2f} "
              f"({med['paged_lod'] / med['mem_lod']:.2f}x); leaves and fans equal: {equal}")
        if args.render:
            print(f"render ms median: in memory {med['mem_draw']:.1f}, paged "
                  f"{med['paged_draw']:.1f} ({med['paged_draw'] / med['mem_draw']:.2f}x)")
        print(f"pages a frame: median {med['used']:.0f} (max {max(rows['used'])}); misses "
              f"{sum(rows['misses'])} (first frame excluded), read ahead {sum(rows['ahead'])}, "
              f"evicted {paged.evicted}, grown {paged.grown}; held "
              f"{max(rows['held']) / (1 << 20):.2f} "
              f"MB (budget {budget / (1 << 20):.2f} MB) against the in-memory method's "
              f"{held / (1 << 20):.1f} MB")
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""The .vmtiles build from a GeoTIFF: in memory (sources.load_file, the .vmt round trip,
TilePyramid.build, write_tiles) against out of core (terrain/outofcore.build_tiles within
--memory); wall time and tracemalloc's peak of each, and whether the files are identical.
--pages builds Röttger's .vmrpages instead (in memory: Roettger and paged_roettger.write_pages;
out of core: terrain/outofcore_pages.py).

Usage: nice -n 5 .venv/bin/python tools/bench_tile_build.py [--rows 1900] [--cols 1700]
       [--memory 16] [--skip-memory-path] [--pages]
The DEM (float32, deflate with predictor 3, strips of 8 rows, a GDAL no-data lake and row) is
generated strip by strip into a temporary folder; numba is warmed up on a small one first.
--skip-memory-path builds out of core only (a DEM too large for the in-memory path).
"""
from __future__ import annotations

import argparse
import sys
import tempfile
import time
import tracemalloc
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))


def dem_rows(height, width):
    import numpy as np

    def rows(r0, r1):
        i, j = np.mgrid[r0:r1, 0:width]
        a = (np.sin(i / 37.0) * np.cos(j / 23.0) * 50 + (i * 7 + j * 13) % 17 + 100)
        a[(i - height // 3) ** 2 + (j - width // 2) ** 2 < (height // 7) ** 2] = -9999
        a[i == height // 2] = -9999
        return a.astype(np.float32)
    return rows


def measured(function):
    tracemalloc.start()
    start = time.perf_counter()
    try:
        result = function()
        return result, time.perf_counter() - start, tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rows", type=int, default=1900)
    parser.add_argument("--cols", type=int, default=1700)
    parser.add_argument("--memory", type=float, default=16.0, help="MB for the build")
    parser.add_argument("--skip-memory-path", action="store_true")
    parser.add_argument("--pages", action="store_true", help="Röttger's .vmrpages")
    args = parser.parse_args(argv)
    from vismobile.terrain import sources, store
    from vismobile.terrain.geotiff import write_tiff
    from vismobile.terrain.outofcore import build_tiles
    from vismobile.terrain.paged import write_tiles
    from vismobile.terrain.tiles import TilePyramid

    suffix = ".vmrpages" if args.pages else ".vmtiles"
    with tempfile.TemporaryDirectory() as folder:
        folder = Path(folder)
        source = folder / "dem.tif"
        write_tiff(source, (args.rows, args.cols), dem_rows(args.rows, args.cols), predictor=3,
                   rows_per_strip=8, nodata=-9999.0, spacing=10.0)
        write_tiff(folder / "warm.tif", (60, 50), dem_rows(60, 50), nodata=-9999.0)
        build_tiles(folder / "warm.tif", folder / f"warm{suffix}")
        hm = sources.load_file(folder / "warm.tif", None, None)
        write_tiles(TilePyramid.build(hm, 16), folder / "warm2.vmtiles")
        raster_mb = args.rows * args.cols * 4 / (1 << 20)
        print(f"DEM {args.rows} x {args.cols} float32 ({raster_mb:.1f} MB raw, "
              f"{source.stat().st_size / (1 << 20):.1f} MB deflated)")
        info, seconds, peak = measured(lambda: build_tiles(
            source, folder / f"ooc{suffix}", budget_bytes=int(args.memory * (1 << 20))))
        print(f"out of core  {info['size']}^2 grid: {seconds:7.2f} s, peak "
              f"{peak / (1 << 20):7.2f} MB (--memory {args.memory:g}; bands of "
              f"{info['band_rows']} rows), file "
              f"{(folder / f'ooc{suffix}').stat().st_size / (1 << 20):.1f} MB")
        if args.skip_memory_path:
            return 0

        def in_memory():
            heightmap = sources.load_file(source, None, None)
            store.save(folder / "dem.vmt", heightmap)
            heightmap, _ = store.load(folder / "dem.vmt")
            if args.pages:
                from vismobile.terrain.paged_roettger import write_pages
                from vismobile.terrain.roettger import Roettger

                write_pages(Roettger(heightmap), folder / "mem.vmrpages")
            else:
                write_tiles(TilePyramid.build(heightmap, 16), folder / "mem.vmtiles")

        _, seconds, peak = measured(in_memory)
        same = (folder / f"ooc{suffix}").read_bytes() == (folder / f"mem{suffix}").read_bytes()
        print(f"in memory    {seconds:7.2f} s, peak {peak / (1 << 20):7.2f} MB; files "
              f"identical: {same}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

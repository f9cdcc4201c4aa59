"""A .vmtiles built out of core from a GeoTIFF (terrain/outofcore.py, terrain/geotiff.py): the
streaming reader agrees with Pillow both ways, the build is byte for byte the in-memory
`terrain build` + `terrain tile` within a memory cap smaller than the raster (tracemalloc's
peak), and malformed files or budgets are refused in one line with nothing written."""
import tracemalloc

import numpy as np
import pytest
from PIL import Image

from vismobile.errors import VisMobileError, WorldError
from vismobile.terrain import sources, store
from vismobile.terrain.geotiff import TiffRaster, write_tiff
from vismobile.terrain.outofcore import build_tiles, minimum_budget
from vismobile.terrain.paged import PagedTiles, write_tiles
from vismobile.terrain.tiles import TilePyramid

LAYOUTS = [dict(dtype="<f4", predictor=3, rows_per_strip=7),
           dict(dtype=">f4", compression="none", rows_per_strip=64),
           dict(dtype="<i2", predictor=2, tile=(32, 48)),
           dict(dtype=">u2", predictor=2, tile=(16, 16)),
           dict(dtype="<f4", predictor=3, tile=(64, 32))]


def dem_rows(height, width, lake=True):
    """rows(r0, r1) of a smooth DEM with a no-data lake (-9999) and a no-data row."""
    def rows(r0, r1):
        i, j = np.mgrid[r0:r1, 0:width]
        a = (np.sin(i / 37.0) * np.cos(j / 23.0) * 50 + (i * 7 + j * 13) % 17 + 100)
        if lake:
            a[(i - height // 3) ** 2 + (j - width // 2) ** 2 < (height // 7) ** 2] = -9999
            a[i == height // 2] = -9999
        return a.astype(np.float32)
    return rows



def build_traced(tmp_path, source, out, warm, cap):
    """build_tiles(source, out) within cap, after numba's first load on a small warm-up DEM of
    shape warm to the same kind of file; returns (its info, tracemalloc's peak)."""
    write_tiff(tmp_path / "warm.tif", warm, dem_rows(*warm), nodata=-9999.0)
    build_tiles(tmp_path / "warm.tif", tmp_path / f"warm{out.suffix}")
    tracemalloc.start()
    try:
        info = build_tiles(source, out, budget_bytes=cap)
        return info, tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


def stored(tmp_path, heightmap):
    """heightmap saved as a .vmt and loaded back (the in-memory build's input)."""
    store.save(tmp_path / "dem.vmt", heightmap)
    return store.load(tmp_path / "dem.vmt")[0]


@pytest.mark.parametrize("layout", LAYOUTS)
def test_the_streaming_reader_and_pillow_agree_both_ways(tmp_path, layout):
    values = dem_rows(203, 157)(0, 203)
    values = values.astype(np.dtype(layout["dtype"]).newbyteorder("="))
    path = tmp_path / "w.tif"
    write_tiff(path, values.shape, lambda r0, r1: values[r0:r1], nodata=-9999.0, spacing=30.0,
               **layout)
    with TiffRaster(path) as raster:
        assert raster.nodata == -9999.0 and raster.spacing == 30.0
        assert np.array_equal(raster.rows(50, 120), values[50:120].astype(np.float64))
        assert np.array_equal(raster.rows(0, 203), values.astype(np.float64))
    assert np.array_equal(np.asarray(Image.open(path)), values)  # Pillow reads ours
    for compression in ("tiff_lzw", "packbits", "tiff_adobe_deflate", "raw"):
        if values.dtype.kind == "u" and values.dtype.itemsize == 2 or values.dtype == np.float32:
            Image.fromarray(values).save(tmp_path / "p.tif", compression=compression)
            with TiffRaster(tmp_path / "p.tif") as raster:  # we read Pillow's
                assert np.array_equal(raster.rows(0, 203), values.astype(np.float64))


def test_a_dem_larger_than_the_cap_builds_the_in_memory_file_within_it(tmp_path):
    height, width = 900, 700  # a 1025^2 grid; 2.4 MB of float32 raster, 8 MB as float64
    source = tmp_path / "dem.tif"
    write_tiff(source, (height, width), dem_rows(height, width), predictor=3,
               rows_per_strip=8, nodata=-9999.0, spacing=2.5)
    cap = int(2.2 * (1 << 20))
    assert minimum_budget(1025) <= cap < height * width * 4
    info, peak = build_traced(tmp_path, source, tmp_path / "ooc.vmtiles", (40, 30), cap)
    assert peak <= cap and info["band_rows"] < 1025  # coarse levels went band by band
    heightmap = stored(tmp_path, sources.load_file(source, None, None))  # the in-memory path
    write_tiles(TilePyramid.build(heightmap, 16), tmp_path / "mem.vmtiles")
    assert (tmp_path / "ooc.vmtiles").read_bytes() == (tmp_path / "mem.vmtiles").read_bytes()
    paged = PagedTiles(tmp_path / "ooc.vmtiles", thread=False)
    assert paged.heightmap.holes and paged.heightmap.spacing == 2.5
    paged.close()
    assert not list(tmp_path.glob(".*tmp"))  # no scratch left


def test_terrain_tile_from_a_geotiff_then_play_pages_it(tmp_path, capsys):
    import csv

    from vismobile.app.cli import main

    source = tmp_path / "dem.tif"
    write_tiff(source, (150, 260), dem_rows(150, 260), dtype="<i2", predictor=2,
               tile=(32, 32), nodata=-9999.0)
    out = tmp_path / "dem.vmtiles"
    assert main(["terrain", "tile", str(source), "-o", str(out), "--memory", "8"]) == 0
    assert main(["play", str(out), "--limit", "4", "--page-budget", "0.05", "--quiet", "-o",
                 str(tmp_path / "run")]) == 0
    rows = list(csv.DictReader(open(tmp_path / "run" / "frames.csv")))
    assert len(rows) == 4 and int(rows[0]["page_misses"]) > 0
    capsys.readouterr()
    data = source.read_bytes()
    write_tiff(tmp_path / "wide.tif", (20, 1100), dem_rows(20, 1100))  # a 2049^2 grid
    cases = [("short.tif", data[:len(data) // 2], []), ("magic.tif", b"XX" + data[2:], []),
             ("wide.tif", (tmp_path / "wide.tif").read_bytes(), ["--memory", "1"]),
             ("dem.tif", data, ["--memory", "0.5"]),  # below the option's range
             ("dem.tif", data, ["--nodata", "0", "-o", str(source)])]  # the input itself
    for name, content, extra in cases:
        (tmp_path / name).write_bytes(content)
        target = tmp_path / "bad.vmtiles"
        args = ["terrain", "tile", str(tmp_path / name), "-o", str(target)] + extra
        assert main(args) == 2, (name, extra)
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and ("--memory" in err[0] or name in err[0]), err
        assert not target.exists() and not list(tmp_path.glob(".*tmp"))
    assert source.read_bytes() == data
    store.save(tmp_path / "t.vmt", sources.diamond_square(65, seed=1))
    assert main(["terrain", "tile", str(tmp_path / "t.vmt"), "-o", str(target),
                 "--nodata", "0"]) == 2
    assert "GeoTIFF source only" in capsys.readouterr().err


def test_malformed_directories_are_refused_naming_the_file(tmp_path):
    import struct

    source = tmp_path / "d.tif"
    write_tiff(source, (40, 30), dem_rows(40, 30), rows_per_strip=8)
    data = source.read_bytes()
    ifd = struct.unpack("<I", data[4:8])[0]
    bad = {"big_count.tif": data[:ifd] + struct.pack("<H", 5000) + data[ifd + 2:],
           "offset.tif": data[:4] + struct.pack("<I", len(data) + 10) + data[8:],
           "empty.tif": b""}
    for name, content in bad.items():
        (tmp_path / name).write_bytes(content)
        with pytest.raises(WorldError, match=name):
            build_tiles(tmp_path / name, tmp_path / "o.vmtiles")
    with pytest.raises(VisMobileError, match="--memory"):
        build_tiles(source, tmp_path / "o.vmtiles", budget_bytes=1 << 16)
    assert not (tmp_path / "o.vmtiles").exists()


def test_roettger_pages_built_out_of_core_are_the_in_memory_file_within_the_cap(tmp_path):
    """terrain tile dem.tif -o dem.vmrpages: Röttger's pages from the scratch grid (finer
    blocks page row by page row over bands, coarse blocks over bands of rows) are byte for byte
    paged_roettger.write_pages(Roettger(load_file(...))), within a cap below the raster's
    size (tracemalloc's peak)."""
    from vismobile.terrain.outofcore_pages import pages_minimum
    from vismobile.terrain.paged_roettger import PagedRoettger
    from vismobile.terrain.paged_roettger import write_pages as write_roettger_pages
    from vismobile.terrain.roettger import Roettger

    height, width = 1000, 1025  # float64: 8.2 MB of raster, a 1025^2 grid
    source = tmp_path / "dem.tif"
    write_tiff(source, (height, width), dem_rows(height, width), dtype="<f8", predictor=3,
               rows_per_strip=4, nodata=-9999.0, spacing=3.0)
    cap = int(6.6 * (1 << 20))
    assert pages_minimum(1025) <= cap < height * width * 8
    _, peak = build_traced(tmp_path, source, tmp_path / "ooc.vmrpages", (60, 50), cap)
    assert peak <= cap
    (tmp_path / "npy").mkdir()  # Pillow reads no float64 TIFF: the same samples as .npy
    np.save(tmp_path / "npy" / "dem.npy", dem_rows(height, width)(0, height).astype("<f8"))
    heightmap = stored(tmp_path, sources.load_file(tmp_path / "npy" / "dem.npy", None, 3.0,
                                                   nodata=-9999.0))
    write_roettger_pages(Roettger(heightmap), tmp_path / "mem.vmrpages")
    assert (tmp_path / "ooc.vmrpages").read_bytes() == (tmp_path / "mem.vmrpages").read_bytes()
    PagedRoettger(tmp_path / "ooc.vmrpages", thread=False).close()
    assert not list(tmp_path.glob(".*tmp"))
    with pytest.raises(VisMobileError, match="--memory"):  # below the pages build's need
        build_tiles(source, tmp_path / "low.vmrpages", budget_bytes=4 << 20)

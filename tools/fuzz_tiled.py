"""Issue 30's out-of-core build targets (tools/fuzz.py imports them): GeoTIFF DEMs streamed
into a .vmtiles file (`terrain tile dem.tif`, tifstream) and `terrain tile --memory` values
(memory): their seeds and entry points. Each entry builds or ends in a VisMobileError, never
leaving an output or a scratch file behind."""
from __future__ import annotations

from pathlib import Path

# terrain tile --memory values in MB (commands/options.py RANGES: [1, 2^20]).
MEMORY_TEXTS = [b"256", b"1.5", b"64", b"1048576"]


def tiled_seeds(folder: Path) -> dict:
    """Seeds: small GeoTIFFs in each layout the streaming reader takes (strips of float32 with
    predictor 3 and a GDAL no-data value, tiles of big-endian int16 with predictor 2, a
    BigTIFF of float64 strips, uncompressed uint16 strips), written by geotiff.write_tiff."""
    import numpy as np

    from vismobile.terrain.geotiff import write_tiff

    i, j = np.mgrid[0:40, 0:37]
    heights = (np.sin(i / 5.0) * 20 + j).astype(np.float32)
    heights[10:14, 5:9] = -9999
    layouts = [dict(dtype="<f4", predictor=3, rows_per_strip=8, nodata=-9999.0, spacing=30.0),
               dict(dtype=">i2", predictor=2, tile=(16, 16), nodata=-9999.0),
               dict(dtype="<f8", predictor=3, rows_per_strip=16, bigtiff=True),
               dict(dtype="<u2", compression="none", rows_per_strip=5)]
    out = []
    for k, layout in enumerate(layouts):
        values = np.abs(heights) if layout["dtype"] == "<u2" else heights
        write_tiff(folder / f"seed{k}.tif", values.shape, lambda r0, r1: values[r0:r1],
                   **layout)
        out.append((folder / f"seed{k}.tif").read_bytes())
    return {"tifstream": out, "memory": MEMORY_TEXTS}


def load_tif_stream(path):
    """A GeoTIFF through the out-of-core builds into a .vmtiles and a .vmrpages beside it
    (8 MB budget), each then opened paged; a refusal leaves neither the output nor a scratch
    file."""
    from vismobile.terrain.outofcore import build_tiles
    from vismobile.terrain.paged import PagedTiles
    from vismobile.terrain.paged_roettger import PagedRoettger

    for suffix, opener in ((".vmtiles", PagedTiles), (".vmrpages", PagedRoettger)):
        out = path.with_suffix(suffix)
        out.unlink(missing_ok=True)
        try:
            build_tiles(path, out, budget_bytes=8 << 20)
        finally:
            left = [p.name for p in path.parent.glob(f".{out.name}.*")]
            assert not left, f"scratch files left: {left}"
        opener(out, thread=False).close()


def load_memory(path):
    """--memory text through terrain tile's parser and its RANGES check."""
    from vismobile.app.cli import build_parser
    from vismobile.commands import options
    from vismobile.errors import VisMobileError

    text = path.read_bytes()[:256].decode("utf-8", errors="replace")
    try:
        args = build_parser().parse_args(["terrain", "tile", "t.tif", "-o", str(path) + ".out",
                                          "--memory", text])
    except SystemExit:  # argparse's own refusal (exit 2, one usage line)
        raise VisMobileError(f"--memory {text!r}: not a number") from None
    options.check(args)
    assert 1.0 <= args.memory <= 1 << 20


def pages_seeds(folder: Path) -> dict:
    """Seeds of .vmrpages files (terrain tile t.vmt -o t.vmrpages): a 65^2 fractal (4 pages)
    and one with no-data samples (the holes flag, the no-data normal bytes)."""
    import numpy as np

    from vismobile.terrain import sources
    from vismobile.terrain.heightmap import quantize
    from vismobile.terrain.paged_roettger import write_pages
    from vismobile.terrain.roettger import Roettger

    base = sources.diamond_square(65, seed=1)
    holed = base.heights.astype(np.float64)
    holed[20:30, 5:40] = np.nan
    out = []
    for k, heightmap in enumerate((base, quantize(holed, 1.0, "holes"))):
        write_pages(Roettger(heightmap), folder / f"seed{k}.vmrpages")
        out.append((folder / f"seed{k}.vmrpages").read_bytes())
    return {"vmrpages": out}


def load_pages(path):
    """A .vmrpages terrain (issue 30's paged Röttger): opened, every page read, a frame refined
    (pages wanted read at once) and its fans' vertices gathered from the pages."""
    from vismobile.device.profile import get_profile
    from vismobile.terrain.paged_roettger import PagedRoettger
    from vismobile.world.camera import Camera

    paged = PagedRoettger(path, budget_bytes=1 << 16, thread=False)
    try:
        for page in range(paged.pages):
            paged._read(page)
        hm = paged.heightmap
        camera = Camera((hm.extent / 2, hm.high + hm.extent / 4, hm.extent / 2), 0.0, -40.0,
                        fov=60, far=10 * hm.extent + 10, near=0.01 * hm.extent + 1e-3)
        paged.select(camera, get_profile("ipaq-hx2490b").resolution, 1.0)
        paged.vertex_records(paged.triangles().ravel())
    finally:
        paged.close()


ENTRY = {"tifstream": (load_tif_stream, ".tif"), "memory": (load_memory, ".txt"),
         "vmrpages": (load_pages, ".vmrpages")}

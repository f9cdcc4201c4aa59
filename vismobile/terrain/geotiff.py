"""A GeoTIFF DEM read by rows in bounded memory (the out-of-core build, terrain/outofcore.py),
and written.

`TiffRaster(path, budget_bytes)` reads the first image's directory with tifffile and decodes
only the strips or tile rows that cover the rows asked for (`rows(r0, r1)`, through
tifffile's TiffPage.decode and imagecodecs: none, deflate, LZW, PackBits, predictors 2 and 3),
keeping the last one decoded: a DEM larger than memory is read strip by strip, never whole.
One sample per pixel of 8-32 bit integers or 32/64-bit floats; GDAL's no-data tag and the
GeoTIFF pixel scale (geotiff_tags). A truncated, inconsistent or oversized
directory, strip or tile, or one whose decoded strip or tile row exceeds the budget, is a
WorldError naming the file. terrain/sources.load_file reads TIFF heightmaps through it too.

`write_tiff(path, shape, rows, ...)` writes one from a function of a row range, atomically:
tile rows stream; strips are written from the whole raster.
"""
from __future__ import annotations

import logging
import os
from pathlib import Path

import numpy as np
import tifffile

from ..errors import WorldError

# tifffile logs the tags it skips; a malformed file is our one-line WorldError, not a log.
logging.getLogger("tifffile").setLevel(logging.CRITICAL)

MAX_SIDE = 1 << 20
KINDS = {"u1", "u2", "u4", "i1", "i2", "i4", "f4", "f8"}  # a DEM's sample types

GDAL_NODATA = 42113  # GDAL's TIFF tag: the no-data value as ASCII
MODEL_PIXEL_SCALE = 33550  # GeoTIFF's ModelPixelScaleTag: (sx, sy, sz) per pixel


def geotiff_tags(path, tags) -> tuple:
    """(nodata or None, spacing or None) of a TIFF's tags (code: value): GDAL_NODATA and the
    GeoTIFF pixel scale (square pixels only; WorldError naming the file otherwise)."""
    nodata = spacing = None
    text = tags.get(GDAL_NODATA)
    if text is not None:
        try:
            nodata = float(str(text).strip().strip("\x00"))
        except ValueError:
            raise WorldError(path, f"GDAL_NODATA tag {str(text)[:40]!r} is not a number") from None
    scale = tags.get(MODEL_PIXEL_SCALE)
    if scale is not None:
        try:
            sx, sy = float(scale[0]), float(scale[1])
        except (TypeError, ValueError, IndexError):
            raise WorldError(path, "ModelPixelScaleTag is not (sx, sy, sz)") from None
        if not (np.isfinite([sx, sy]).all() and sx > 0 and sy > 0):
            raise WorldError(path, f"ModelPixelScaleTag ({sx:g}, {sy:g}) must be finite and > 0")
        if not np.isclose(sx, sy, rtol=1e-9):
            raise WorldError(path, f"pixels are not square ({sx:g} x {sy:g}); pass --spacing")
        spacing = sx
    return nodata, spacing


class TiffRaster:
    """The first image of a TIFF, read by row ranges (module doc).

    shape : (rows, cols); dtype: numpy dtype of the samples; nodata, spacing: from the GDAL
    and GeoTIFF tags (None when absent); chunk_rows: rows of one strip or tile row.
    """

    def __init__(self, path, budget_bytes: int = 64 << 20):
        self.path = Path(path)
        self.budget = int(budget_bytes)
        try:
            self.size = os.stat(self.path).st_size
            self.file = tifffile.TiffFile(self.path)
        except OSError as error:
            raise WorldError(path, f"cannot read ({error.strerror or error})") from None
        except Exception as error:  # tifffile raises many types for a malformed directory
            raise WorldError(path, f"not a readable TIFF ({type(error).__name__}: "
                                   f"{str(error)[:80]})") from None
        try:
            self._check()
        except WorldError:
            self.close()
            raise
        except Exception as error:  # tifffile's lazy tags and arrays, on a malformed file
            self.close()
            raise WorldError(path, f"not a readable TIFF ({type(error).__name__}: "
                                   f"{str(error)[:80]})") from None
        self._cached = (-1, None)

    def close(self) -> None:
        if getattr(self, "file", None) is not None:
            self.file.close()
            self.file = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def _bad(self, message):
        return WorldError(self.path, message)

    def _check(self) -> None:
        page = self.page = self.file.pages.first
        height, width = int(page.imagelength), int(page.imagewidth)
        samples, dtype = int(page.samplesperpixel), page.dtype
        tags = {code: page.tags[code].value for code in (GDAL_NODATA, MODEL_PIXEL_SCALE)
                if code in page.tags}
        if not (2 <= width <= MAX_SIDE and 2 <= height <= MAX_SIDE):
            raise self._bad(f"TIFF of {width} x {height} pixels (2 to {MAX_SIDE:,} a side)")
        if samples != 1 or int(page.imagedepth) != 1:
            raise self._bad("TIFF has more than one sample per pixel (a DEM has one band)")
        if dtype is None or dtype.str[1:] not in KINDS:
            raise self._bad(f"TIFF samples of type {dtype} (a DEM needs 8-32 bit integers or "
                            "32/64-bit floats)")
        self.dtype, self.shape = np.dtype(dtype.str[1:]), (height, width)
        if page.is_tiled:
            tl, tw = int(page.tilelength), int(page.tilewidth)
            if not (16 <= tw <= MAX_SIDE and 16 <= tl <= MAX_SIDE):
                raise self._bad(f"TIFF tiles of {tw} x {tl}")
            self.tile, self.chunk_rows = (tl, tw), tl
            chunks = -(-height // tl) * -(-width // tw)
            self.chunk_bytes = tl * tw * self.dtype.itemsize
        else:
            self.tile, self.chunk_rows = None, max(1, min(int(page.rowsperstrip), height))
            chunks = -(-height // self.chunk_rows)
            self.chunk_bytes = self.chunk_rows * width * self.dtype.itemsize
        offsets = np.asarray(page.dataoffsets, np.int64)
        counts = np.asarray(page.databytecounts, np.int64)
        if len(offsets) != chunks or len(counts) != chunks:
            raise self._bad(f"TIFF needs {chunks} strip or tile offsets and byte counts")
        if (offsets < 0).any() or (counts < 0).any() or (offsets + counts > self.size).any():
            raise self._bad("TIFF strips or tiles lie past the end of the file (truncated)")
        # A decoded strip or tile row as float64 beside its bytes must fit the budget.
        need = self.chunk_rows * width * (8 + self.dtype.itemsize)
        if need > self.budget:
            raise self._bad(f"TIFF strips or tile rows of {need / (1 << 20):.1f} MB decoded "
                            f"exceed the memory budget ({self.budget / (1 << 20):.1f} MB)")
        if (counts > 2 * self.chunk_bytes + 4096).any():
            raise self._bad("TIFF strip or tile byte counts exceed their decoded size")
        self.offsets, self.counts = offsets, counts
        self.nodata, self.spacing = geotiff_tags(self.path, tags)

    def _decode(self, k) -> np.ndarray:
        """(rows, width) native samples of strip or tile k."""
        handle = self.file.filehandle
        handle.seek(int(self.offsets[k]))
        data = handle.read(int(self.counts[k]))
        rows = self.chunk_rows if self.tile else \
            min(self.chunk_rows, self.shape[0] - k * self.chunk_rows)
        width = self.tile[1] if self.tile else self.shape[1]
        try:
            values = self.page.decode(data, int(k))[0]
        except Exception as error:  # a corrupt stream: the codec's own error
            raise self._bad(f"TIFF strip or tile {k} is corrupt ({type(error).__name__}: "
                            f"{str(error)[:60]})") from None
        if values is None or values.size != rows * width:
            raise self._bad(f"TIFF strip or tile {k} does not hold {rows} x {width} samples")
        return values.reshape(rows, width).astype(self.dtype, copy=False)

    def _chunk(self, k) -> np.ndarray:
        """(rows, width) native samples of strip or tile row k (the last one kept)."""
        if self._cached[0] == k:
            return self._cached[1]
        self._cached = (-1, None)  # free the previous one before decoding the next
        if self.tile is None:
            values = self._decode(k)
        else:
            tl, tw = self.tile
            across = -(-self.shape[1] // tw)
            values = np.empty((tl, across * tw), self.dtype)
            for t in range(across):
                values[:, t * tw:(t + 1) * tw] = self._decode(k * across + t)
            values = values[:min(tl, self.shape[0] - k * tl), :self.shape[1]]
        self._cached = (k, values)
        return values

    def rows(self, r0: int, r1: int) -> np.ndarray:
        """(r1 - r0, cols) float64 samples of rows [r0, r1)."""
        out = np.empty((r1 - r0, self.shape[1]))
        r = r0
        while r < r1:
            k = r // self.chunk_rows
            chunk = self._chunk(k)
            top = k * self.chunk_rows
            take = min(r1, top + len(chunk)) - r
            out[r - r0:r - r0 + take] = chunk[r - top:r - top + take]
            r += take
        return out


def write_tiff(path, shape, rows, dtype="<f4", compression="deflate", predictor=1,
               rows_per_strip=16, tile=None, nodata=None, spacing=None, bigtiff=False) -> None:
    """Write a one-band TIFF of shape (rows, cols) whose samples rows(r0, r1) returns
    ((r1 - r0, cols) arrays), in strips of rows_per_strip or in tiles (length, width), with
    the GDAL no-data and GeoTIFF pixel-scale tags when given, through a temporary file and a
    rename. compression "deflate" or "none"; predictor 1, 2 (integers) or 3 (floats). Tiles
    are produced a tile row at a time (a raster larger than memory); strips need the whole
    raster (tifffile encodes strips from whole images)."""
    from ..files.atomic import atomic_writer

    dtype = np.dtype(dtype)
    height, width = shape

    def band(r0, r1):
        block = np.asarray(rows(r0, r1)).astype(dtype)
        if block.shape != (r1 - r0, width):
            raise ValueError(f"rows({r0}, {r1}) gave {block.shape}, not {(r1 - r0, width)}")
        return block

    def tiles():
        tl, tw = tile
        for r0 in range(0, height, tl):
            padded = np.zeros((tl, -(-width // tw) * tw), dtype)
            padded[:min(tl, height - r0), :width] = band(r0, min(height, r0 + tl))
            for c0 in range(0, padded.shape[1], tw):
                yield padded[:, c0:c0 + tw]

    extratags = []
    if spacing is not None:
        extratags.append((MODEL_PIXEL_SCALE, 12, 3, (spacing, spacing, 0.0), True))
    if nodata is not None:
        extratags.append((GDAL_NODATA, 2, 0, repr(float(nodata)), True))
    options = dict(shape=(height, width), dtype=dtype, photometric="minisblack",
                   compression=None if compression == "none" else "zlib",
                   predictor=predictor if predictor > 1 else None, bigtiff=bigtiff,
                   byteorder=dtype.str[0] if dtype.str[0] in "<>" else "<",
                   extratags=extratags, metadata=None)
    with atomic_writer(path) as handle:
        if tile:
            tifffile.imwrite(handle, tiles(), tile=tuple(tile), **options)
        else:
            tifffile.imwrite(handle, band(0, height), rowsperstrip=rows_per_strip, **options)

"""A .vmtiles file built from a GeoTIFF DEM in bounded memory (a DEM larger than memory).

`build_tiles(source, out, budget_bytes=...)` writes the same file, byte for byte, as loading
the DEM (sources.load_file, --fit pad), saving it and `terrain tile` (paged.write_tiles) would,
without ever holding the raster or the grid. Five streaming steps:

1. the DEM's rows in bands (geotiff.TiffRaster: only the strips or tile rows of the band are
   decoded): the lowest and highest valid height (the uint16 quantisation's range) and which
   rows hold a valid sample;
2. the quantised grid, padded onto the next 2^n+1 square, into a scratch file beside the output
   (uint16 samples, and one byte of validity a sample when there are holes). No-data samples
   get sources' fill: the nearest valid sample along the row (heightmap.fill_holes's row pass,
   a band's own rows), a row without one the whole filled row nearest to it (its column pass);
3. per level and tile row, the tiles' statistics (E, hmin, hmax: raster.band_statistics, the
   exact tile_statistics restricted to a band of rows, with the template triangles' corners
   read from the level's corner rows), the seed's horizontal error from the validity rows at
   the level's half stride, then nesting as TilePyramid.build does;
4. per level and tile row, the tiles' records (samples and normals: the vertex rows and the
   rows beside them for the central differences);
5. the header, statistics and records into a temporary file renamed onto the output.

Memory: the statistics (48 bytes a tile while nesting; 24 are kept at run time anyway) plus
each step's band of rows (or group of records) sized from what is left of `budget_bytes`
(the *_BYTES constants); a budget below one tile row's band (minimum_budget) is refused.
tracemalloc's peak stays within the budget (tests/terrain/test_outofcore.py). Time: the
statistics scan every sample as often as the in-memory build does; every level rereads the
scratch once.
"""
from __future__ import annotations

import json
import os
import struct
import time
import zlib
from pathlib import Path

import numpy as np

from ..errors import WorldError
from ..files.atomic import atomic_writer, check_destination, temp_path
from .heightmap import MAX_LEVEL, fill_holes
from .heightmap import sample_heights as _heights
from .paged import MAGIC, pack_records, grid_normals
from .quadtree import level_offsets
from .raster import band_statistics
from .sources import MAX_HEIGHT
from .tiles import horizontal_from_grid, template

# Bytes a sample of each step's working arrays (measured with tracemalloc, with slack): the
# first scan (float64 rows and masks), the quantisation (fill_holes' temporaries), the
# statistics' bands (float64, float32 and uint16 rows) and a record's vertex (indices,
# normals and their temporaries).
SCAN_BYTES, QUANTISE_BYTES, BAND_BYTES, RECORD_BYTES = 40, 120, 32, 320


def grid_size(rows: int, cols: int) -> int:
    """The next 2^n+1 at or above the longer side (sources._to_grid's padding)."""
    longest = max(rows, cols)
    return (1 << int(np.ceil(np.log2(max(longest - 1, 2))))) + 1


def minimum_budget(size: int, patch: int = 16) -> int:
    """Bytes build_tiles needs at least for a size^2 grid: the statistics while nesting and a
    band of 3 (patch + 1) rows (a tile row's records with their normals' neighbours)."""
    return 48 * _tiles(size, patch) + 3 * (patch + 2) * size * BAND_BYTES + \
        (patch + 1) ** 2 * RECORD_BYTES


class _Scratch:
    """The quantised grid (and validity) in scratch files, read back by rows with pread."""

    def __init__(self, out: Path, size: int, holes: bool):
        self.size, self.holes = size, holes
        base = temp_path(out)
        self.paths = [base.with_name(base.name[:-4] + ".samples.tmp")]
        if holes:
            self.paths.append(base.with_name(base.name[:-4] + ".valid.tmp"))
        self.fds = [os.open(p, os.O_RDWR | os.O_CREAT | os.O_TRUNC, 0o600) for p in self.paths]

    def write(self, r0, samples, valid) -> None:
        os.pwrite(self.fds[0], samples.astype("<u2").tobytes(), 2 * r0 * self.size)
        if self.holes:
            os.pwrite(self.fds[1], valid.astype(np.uint8).tobytes(), r0 * self.size)

    def samples(self, rows) -> np.ndarray:
        """(len(rows), N) uint16 samples of the given grid rows."""
        rows = np.asarray(rows, np.int64)
        out = np.empty((len(rows), self.size), np.uint16)
        for k, r in enumerate(rows):
            out[k] = np.frombuffer(os.pread(self.fds[0], 2 * self.size, 2 * int(r) * self.size),
                                   "<u2")
        return out

    def span(self, r0, r1) -> np.ndarray:
        """(r1 - r0, N) uint16 samples of rows [r0, r1) in one read."""
        data = os.pread(self.fds[0], 2 * (r1 - r0) * self.size, 2 * r0 * self.size)
        return np.frombuffer(data, "<u2").reshape(r1 - r0, self.size)

    def valid(self, rows, cols=slice(None)) -> np.ndarray:
        rows = np.asarray(rows, np.int64)
        out = np.empty((len(rows), self.size), bool)
        for k, r in enumerate(rows):
            out[k] = np.frombuffer(os.pread(self.fds[1], self.size, int(r) * self.size),
                                   np.uint8) != 0
        return out[:, cols]

    def close(self) -> None:
        for fd in self.fds:
            os.close(fd)
        for p in self.paths:
            try:
                os.unlink(p)
            except OSError:
                pass
        self.fds = []


def build_tiles(source, out, nodata=None, spacing=None, vertical: float = 1.0,
                patch: int = 16, budget_bytes: int = 256 << 20, status=None) -> dict:
    """Write out (.vmtiles) from the GeoTIFF source in bounded memory (module doc).

    nodata, spacing: override the file's GDAL_NODATA and pixel scale tags (spacing 1 when
    neither). Returns {"size", "seconds", "band_rows"}. Raises WorldError naming the source on
    a malformed file, VisMobileError when the budget is too small.
    """
    from ..errors import VisMobileError
    from .geotiff import TiffRaster

    start = time.perf_counter()
    source, out = Path(source), check_destination(out)
    say = status or (lambda text: None)
    with TiffRaster(source, budget_bytes // 4) as raster:
        height, width = raster.shape
        size = grid_size(height, width)
        if size > (1 << MAX_LEVEL) + 1:
            raise WorldError(source, f"{height:,}x{width:,} samples: the longer side is beyond "
                                     f"the largest grid ({(1 << MAX_LEVEL) + 1:,})")
        if size - 1 < patch:
            raise WorldError(source, f"{height}x{width} samples: fewer than a {patch}-cell tile")
        need = minimum_budget(size, patch)
        if out.suffix.lower() == ".vmrpages":
            from .outofcore_pages import pages_minimum

            need = max(need, pages_minimum(size))
        if budget_bytes < need:
            raise VisMobileError(f"--memory {budget_bytes / (1 << 20):g} MB is below the "
                                 f"{need / (1 << 20):.1f} MB a {size}^2 grid needs")
        nodata = raster.nodata if nodata is None else nodata
        nodata = None if nodata is None or np.isnan(nodata) else float(nodata)
        spacing = float(raster.spacing if spacing is None and raster.spacing else spacing or 1.0)
        rest = budget_bytes - 48 * _tiles(size, patch)  # beside the statistics
        in_rows = max(1, rest // (SCAN_BYTES * width))

        def prepared(r0, r1):
            h = raster.rows(r0, r1)
            if nodata is not None:
                h[h == nodata] = np.nan
            with np.errstate(all="ignore"):
                h *= float(vertical)
            if np.isinf(h).any() or not (np.abs(h[~np.isnan(h)]) <= MAX_HEIGHT).all():
                raise WorldError(source, f"heights beyond +-{MAX_HEIGHT:g} world units or "
                                         "infinite (after --vertical)")
            return h

        say("scanning the heights")
        low, high, any_invalid = np.inf, -np.inf, False
        nonempty = np.zeros(size, bool)
        for r0 in range(0, height, in_rows):
            h = prepared(r0, min(height, r0 + in_rows))
            valid = ~np.isnan(h)
            if valid.any():
                low, high = min(low, float(h[valid].min())), max(high, float(h[valid].max()))
            nonempty[r0:r0 + len(h)] = valid.any(axis=1)
            any_invalid |= not valid.all()
        if not nonempty.any():
            raise WorldError(source, "heights hold no valid sample (all no-data)")
        holes = any_invalid or height < size or width < size
        scale = (high - low) / 65535.0 if high > low else 1.0
        scratch = _Scratch(out, size, holes)
        try:
            say("quantising into the scratch grid")
            smin, smax = _quantise(prepared, scratch, size, height, width, nonempty, low, scale,
                                   max(1, rest // (QUANTISE_BYTES * size)))
            band = max(3 * (patch + 2), rest // (size * BAND_BYTES))
            if out.suffix.lower() == ".vmrpages":  # Röttger's pages (terrain/outofcore_pages.py)
                from .outofcore_pages import write_pages_streamed

                band = max(17, rest // (72 * size))  # the coarse blocks' bands (72 B a sample)
                write_pages_streamed(scratch, out, {
                    "size": size, "spacing": spacing, "z_scale": scale, "z_offset": low,
                    "name": source.stem, "low": low + scale * float(smin),
                    "high": low + scale * float(smax), "holes": holes}, say, band_rows=band)
                return {"size": size, "seconds": time.perf_counter() - start,
                        "band_rows": int(band)}
            say("the tiles' statistics")
            stats = _statistics(scratch, size, patch, spacing, scale, low, band)
            levels = ((size - 1) // patch).bit_length() - 1
            header = {"size": size, "patch": patch, "levels": levels, "spacing": spacing,
                      "z_scale": scale, "z_offset": low, "name": source.stem,
                      "low": low + scale * float(smin), "high": low + scale * float(smax),
                      "stats_crc": zlib.crc32(stats)}
            if holes:
                header["holes"] = True
            head = json.dumps(header, sort_keys=True).encode()
            say("the tiles' records")
            with atomic_writer(out) as handle:
                handle.write(MAGIC + struct.pack("<II", len(head), zlib.crc32(head)) + head)
                handle.write(stats)
                del stats
                _records(scratch, handle, size, patch, levels, spacing, scale, low,
                         max(1, rest // ((patch + 1) ** 2 * RECORD_BYTES)))
        finally:
            scratch.close()
    return {"size": size, "seconds": time.perf_counter() - start, "band_rows": int(band)}


def _tiles(size, patch) -> int:
    return int(level_offsets(((size - 1) // patch).bit_length() - 1)[-1])


def _quantise(prepared, scratch, size, height, width, nonempty, low, scale, in_rows) -> tuple:
    """Step 2 (module doc); returns the smallest and largest sample."""
    index = np.arange(size)
    last = np.maximum.accumulate(np.where(nonempty, index, -1))
    after = np.minimum.accumulate(np.where(nonempty, index, size)[::-1])[::-1]
    use_last = (last >= 0) & ((after >= size) | (index - last <= after - index))
    source_row = np.where(use_last, last, after)  # a row without a valid sample copies this

    def filled(r0, r1):
        """(r1 - r0, N) filled float64 heights of nonempty grid rows [r0, r1) (< height)."""
        grid = np.full((r1 - r0, size), np.nan)
        grid[:, :width] = prepared(r0, r1)
        return fill_holes(grid, ~np.isnan(grid)), ~np.isnan(grid)

    smin, smax = 65535, 0
    for r0 in range(0, size, in_rows):
        r1 = min(size, r0 + in_rows)
        heights = np.empty((r1 - r0, size))
        valid = np.zeros((r1 - r0, size), bool)
        live = np.flatnonzero(nonempty[r0:r1])
        if len(live):
            top, bottom = r0 + live[0], r0 + live[-1] + 1
            h, v = filled(top, bottom)
            keep = nonempty[top:bottom]
            heights[live] = h[keep]
            valid[live] = v[keep]
        for k in np.flatnonzero(~nonempty[r0:r1]):
            src = int(source_row[r0 + k])
            if r0 <= src < r1:
                heights[k] = heights[src - r0]
            else:
                heights[k] = filled(src, src + 1)[0][0]
        samples = np.rint((heights - low) / scale).astype(np.uint16)
        smin, smax = min(smin, int(samples.min())), max(smax, int(samples.max()))
        scratch.write(r0, samples, valid)
    return smin, smax


def _statistics(scratch, size, patch, spacing, scale, low, band) -> bytes:
    """Step 3: the statistics section (E, hmin, hmax per tile, '<f8'), as write_tiles."""
    levels = ((size - 1) // patch).bit_length() - 1
    templates = [template(patch, s) for s in range(16)]
    union = np.unique(np.sort(np.concatenate(templates), axis=1), axis=0)
    local = np.stack(np.divmod(union, patch + 1), axis=-1).astype(np.int64)

    def rows_heights(r0, r1):
        return _heights(scratch.span(r0, r1), scale, low).astype(np.float64)

    error, hmin, hmax = [], [], []
    for level in range(levels + 1):
        s = 1 << (levels - level)
        span, m = patch * s, 1 << level
        e, lo, hi = np.zeros((m, m)), np.full((m, m), np.inf), np.full((m, m), -np.inf)
        if span + 1 <= band:  # whole tile rows per band, the corners inside it
            group = max(1, (band - 1) // span)
            for t0 in range(0, m, group):
                t1 = min(m, t0 + group)
                h = rows_heights(t0 * span, t1 * span + 1)
                band_statistics(h, t0 * span, np.ascontiguousarray(h[::s, ::s]), t0 * span, s,
                                patch, local, t0, t1 - 1, e, lo, hi)
        else:  # one tile row in bands of rows, its corner rows read apart
            for ti in range(m):
                r_org = ti * span
                corner_rows = r_org + s * np.arange(patch + 1)
                corners = _heights(scratch.samples(corner_rows), scale, low)
                corners = np.ascontiguousarray(corners[:, ::s].astype(np.float64))
                for b0 in range(r_org, r_org + span, band - 1):
                    b1 = min(b0 + band - 1, r_org + span)
                    band_statistics(rows_heights(b0, b1 + 1), b0, corners, r_org, s, patch,
                                    local, ti, ti, e, lo, hi)
        if scratch.holes and s >= 2:  # seed 002's horizontal error, E = length(E_h, E_v)
            half = s // 2
            horizontal = np.zeros((m, m))
            for ti in range(m):
                g = scratch.valid(ti * span + half * np.arange(2 * patch + 1), slice(None, None,
                                                                                    half))
                horizontal[ti] = horizontal_from_grid(g, patch, half * spacing)[0]
            e = np.hypot(e, horizontal)
        error.append(e)
        hmin.append(lo)
        hmax.append(hi)
    for level in range(levels - 1, -1, -1):  # nest: a parent bounds its children
        child = error[level + 1]
        k = child.shape[0] // 2
        error[level] = np.maximum(error[level], child.reshape(k, 2, k, 2).max(axis=(1, 3)))
    flat = [np.concatenate([a.ravel() for a in arrays]) for arrays in (error, hmin, hmax)]
    return np.stack(flat, 1).astype("<f8").tobytes()


def _records(scratch, handle, size, patch, levels, spacing, scale, low, group) -> None:
    """Step 4: every tile's record, level by level, tile row by tile row (write_tiles' order),
    group tiles at a time."""
    n = patch + 1
    a, b = np.divmod(np.arange(n * n), n)
    for level in range(levels + 1):
        s = 1 << (levels - level)
        span, m = patch * s, 1 << level
        for ti in range(m):
            vertex_rows = ti * span + s * np.arange(n)
            need = np.unique(np.concatenate([np.maximum(vertex_rows - 1, 0), vertex_rows,
                                             np.minimum(vertex_rows + 1, size - 1)]))
            samples = scratch.samples(need)
            heights = _heights(samples, scale, low)
            valid = scratch.valid(need) if scratch.holes else None

            def at(r, c):
                return heights[np.searchsorted(need, r), c]

            for t0 in range(0, m, group):
                tj = np.arange(t0, min(m, t0 + group))
                rows = np.broadcast_to(ti * span + a[None] * s, (len(tj), n * n))
                cols = (tj * span)[:, None] + b[None] * s
                normals = grid_normals(at, size, spacing, rows, cols)
                local = np.searchsorted(need, rows)
                handle.write(pack_records(samples[local, cols], normals,
                                          None if valid is None else valid[local, cols]
                                          ).tobytes())

"""Röttger's pages (.vmrpages) built out of core from the quantised scratch grid of
terrain/outofcore.py (`terrain tile dem.tif -o dem.vmrpages`): byte for byte the file that
loading the DEM, Roettger(heightmap) and paged_roettger.write_pages make, without the grid.

- Blocks finer than the page level (16 cells and less): one page row at a time, over a band of
  rows reaching 32 cells beyond it (roettger.roughness_level on the band: a block's d2 depends
  on the finer blocks around it, less than one block of its own size away, so the band's edge
  blocks, which see no neighbour, never reach the page row's). The page row's records go to a
  scratch file; the 16-cell blocks' values are kept for the level above.
- The page level and coarser blocks (32 cells and more): their exact fan errors in one pass of
  bands of rows over the scratch (raster-style scan restricted to a band, fan corners read from
  the grid of every 16th sample, which stays in memory), then roughness_level on whole small
  arrays, the horizontal error from the validity at every 16th sample.
- The file: header, coarse section, then the page records copied from the scratch file,
  through a temporary file renamed onto the output.

Memory: a band of 65 rows (heights, validity and roughness_level's arrays over it, whose window
minima copy their views: about 4.3 KB a column, measured with tracemalloc), the grid of every
16th sample and the 16-cell blocks' arrays (about 100 bytes a 16 x 16-cell block); the coarse
blocks' bands are sized from the budget. pages_minimum gives the least budget.
"""
from __future__ import annotations

import json
import os
import struct
import zlib

import numpy as np
from numba import njit

from ..errors import VisMobileError
from ..files.atomic import atomic_writer, temp_path
from .heightmap import sample_heights as _heights
from .paged import grid_normals, pack_records
from .paged_roettger import MAGIC, page_layout
from .quadtree import level_offsets
from .raster import _scan_band
from .roettger import block_horizontal, fan_errors, roughness_level

MARGIN = 16  # rows of the band beyond a page row (module doc: enough for the 16-cell blocks)
G = 16  # the coarse grid's stride: every vertex of a block of 32 cells or more


def pages_minimum(size: int) -> int:
    """Bytes the pages build needs at least for a size^2 grid (module doc)."""
    return 5 * 1024 * size + 100 * ((size - 1) // G) ** 2 + (1 << 20)


@njit(cache=True)
def fan_errors_band(band, b0, grid, g, s, out):
    """roettger.fan_errors of blocks of s >= 2 g cells over a band of rows [b0, b0 + len),
    accumulated into out (m, m) by maximum; the fans' corners read from grid (heights at every
    g-th row and column). Bands that together cover every row give fan_errors exactly."""
    n = band.shape[1]
    m = (n - 1) // s
    half = s // 2
    b1 = b0 + band.shape[0] - 1
    ring_r = np.empty(9, np.int64)
    ring_c = np.empty(9, np.int64)
    rr = np.empty(3, np.int64)
    cc = np.empty(3, np.int64)
    hh = np.empty(3)
    for bi in range(m):
        r0 = bi * s
        lo_row, hi_row = max(r0, b0), min(r0 + s, b1)
        if lo_row > hi_row:
            continue
        for bj in range(m):
            c0 = bj * s
            k = 0
            for dr, dc in ((0, 0), (half, 0), (s, 0), (s, half), (s, s), (half, s), (0, s),
                           (0, half), (0, 0)):
                ring_r[k], ring_c[k] = r0 + dr, c0 + dc
                k += 1
            worst = out[bi, bj]
            rr[0], cc[0] = r0 + half, c0 + half
            hh[0] = grid[rr[0] // g, cc[0] // g]
            for step in (1, 2):
                for t in range(0, 8, step):
                    rr[1], cc[1] = ring_r[t], ring_c[t]
                    rr[2], cc[2] = ring_r[t + step], ring_c[t + step]
                    hh[1] = grid[rr[1] // g, cc[1] // g]
                    hh[2] = grid[rr[2] // g, cc[2] // g]
                    worst = max(worst, _scan_band(band, b0, lo_row, hi_row, rr, cc, hh))
            out[bi, bj] = worst


def write_pages_streamed(scratch, out, meta, say, C: float = 8.0, band_rows: int = 256) -> None:
    """Write out (.vmrpages) from the scratch grid (module doc). meta: size, spacing, z_scale,
    z_offset, name, low, high, holes of the quantised grid."""
    size, spacing = meta["size"], meta["spacing"]
    scale, low = meta["z_scale"], meta["z_offset"]
    levels, lg, q, per_page = page_layout(size)
    cells = size - 1
    if q < 2 * G:
        raise VisMobileError(f"{meta['name']}: Röttger's pages need a grid of 33^2 samples or "
                             f"more, not {size}^2")
    side = 1 << lg
    offsets = level_offsets(levels)
    say("Röttger's finer blocks, page row by page row")
    top = None  # the 16-cell blocks' (nested E, d2, hmin, hmax) over the whole map
    pages_path = temp_path(out).with_name(temp_path(out).name[:-4] + ".pages.tmp")
    a = np.arange(q + 1)
    try:
        with open(pages_path, "wb") as pages:
            for pi in range(side):
                r0, r1 = max(0, pi * q - MARGIN), min(cells, pi * q + q + MARGIN)
                band_samples = scratch.span(r0, r1 + 1)
                band32 = _heights(band_samples, scale, low)
                band = band32.astype(np.float64)
                valid = scratch.valid(np.arange(r0, r1 + 1)) if scratch.holes else None
                state, by_level = None, {}
                for level in range(levels, lg, -1):
                    s = cells >> level
                    state = roughness_level(band, valid, spacing, C, s, fan_errors(band, s),
                                            state)
                    first = (pi * q - r0) // s
                    by_level[level] = [x[first:first + q // s] for x in state[:4]]
                    by_level[level].append(state[4][first:first + q // s])
                if top is None:
                    top = [np.zeros((2 * side, 2 * side)) for _ in range(4)]
                for k in range(4):
                    top[k][2 * pi:2 * pi + 2] = by_level[lg + 1][k]
                stats = np.zeros((5, side, per_page))
                at = 0
                for k in range(1, levels - lg + 1):
                    mk = 1 << k
                    nested, d2, lo, hi, centre = by_level[lg + k]
                    for slot, value in enumerate((d2, lo, hi, centre)):
                        # (mk, side * mk) -> (side, mk * mk) in li * mk + lj order
                        stats[slot, :, at:at + mk * mk] = value.reshape(mk, side, mk) \
                            .transpose(1, 0, 2).reshape(side, mk * mk)
                    if lg + k == levels:
                        stats[4, :, at:at + mk * mk] = stats[0, :, at:at + mk * mk] * \
                            (2 * spacing)
                    at += mk * mk
                rows = np.arange(pi * q, pi * q + q + 1)

                def at_band(r, c):
                    return band32[r - r0, c]

                for pj in range(side):
                    rr, cc = np.meshgrid(rows, pj * q + a, indexing="ij")
                    records = pack_records(band_samples[rr - r0, cc],
                                           grid_normals(at_band, size, spacing, rr, cc),
                                           None if valid is None else valid[rr - r0, cc])
                    body = stats[:, pj].astype("<f8").tobytes() + records.tobytes()
                    pages.write(body + struct.pack("<I", zlib.crc32(body)))
        say("Röttger's coarse blocks")
        section = _coarse_section(scratch, size, spacing, scale, low, C, levels, lg, top,
                                  offsets, band_rows)
        header = {"size": size, "C": float(C), "levels": levels, "page_level": lg,
                  "spacing": spacing, "z_scale": scale, "z_offset": low, "name": meta["name"],
                  "low": meta["low"], "high": meta["high"], "coarse_crc": zlib.crc32(section)}
        if meta["holes"]:
            header["holes"] = True
        head = json.dumps(header, sort_keys=True).encode()
        with atomic_writer(out) as handle, open(pages_path, "rb") as pages:
            handle.write(MAGIC + struct.pack("<II", len(head), zlib.crc32(head)) + head + section)
            while True:
                chunk = pages.read(1 << 18)
                if not chunk:
                    break
                handle.write(chunk)
    finally:
        try:
            os.unlink(pages_path)
        except OSError:
            pass


def _coarse_section(scratch, size, spacing, scale, low, C, levels, lg, top, offsets,
                    band_rows) -> bytes:
    """The coarse section: d2, hmin, hmax, centres of levels 0..lg, then the records of every
    G-th sample (write_pages' layout)."""
    cells = size - 1
    grid_rows = np.arange(0, size, G)
    g32 = _heights(scratch.samples(grid_rows), scale, low)[:, ::G]
    grid = g32.astype(np.float64)
    exact = {level: np.zeros((1 << level, 1 << level)) for level in range(lg + 1)}
    for b0 in range(0, cells, band_rows - 1):
        b1 = min(cells, b0 + band_rows - 1)
        band = _heights(scratch.span(b0, b1 + 1), scale, low).astype(np.float64)
        for level in range(lg + 1):
            fan_errors_band(band, b0, grid, G, cells >> level, exact[level])
    valid_grid = scratch.valid(grid_rows, slice(None, None, G)) if scratch.holes else None
    state = tuple(top)
    d2 = np.zeros(offsets[lg + 1])
    hmin, hmax, centres = np.zeros_like(d2), np.zeros_like(d2), np.zeros_like(d2)
    for level in range(lg, -1, -1):
        s = cells >> level
        e = exact[level]
        if valid_grid is not None:
            e = np.hypot(e, block_horizontal(valid_grid, s // G, spacing * G))
        nested, local, lo, hi, _ = roughness_level(None, None, spacing, C, s, e, state)
        centre = grid[(s // 2) // G::s // G, (s // 2) // G::s // G][:1 << level, :1 << level]
        state = (nested, local, lo, hi)
        sl = slice(offsets[level], offsets[level + 1])
        d2[sl], hmin[sl], hmax[sl], centres[sl] = local.ravel(), lo.ravel(), hi.ravel(), \
            centre.ravel()
    # the records of every G-th sample, with the rows beside each for the normals, 8 grid rows
    # at a time
    parts = [np.stack([d2, hmin, hmax, centres]).astype("<f8").tobytes()]
    for k in range(0, len(grid_rows), 8):
        rows = grid_rows[k:k + 8]
        need = np.unique(np.concatenate([np.maximum(rows - 1, 0), rows,
                                         np.minimum(rows + 1, cells)]))
        samples = scratch.samples(need)
        h32 = _heights(samples, scale, low)
        rr, cc = np.meshgrid(rows, grid_rows, indexing="ij")
        local_rows = np.searchsorted(need, rr)
        normals = grid_normals(lambda r, c: h32[np.searchsorted(need, r), c], size, spacing,
                               rr, cc)
        valid = scratch.valid(need)[local_rows, cc] if scratch.holes else None
        parts.append(pack_records(samples[local_rows, cc], normals, valid).tobytes())
    return b"".join(parts)

"""A terrain paged in by tiles under a memory budget (seed 002's loader thread and LRU).

`write_tiles(pyramid, path)` writes a `.vmtiles` file once (offline, from an in-memory
TilePyramid): a CRC'd JSON header, the pyramid's per-tile statistics (E, hmin, hmax: 24 bytes
a tile, all kept in memory at run time) and one fixed-size record per tile of every level, its
(P+1)^2 vertices at the level's stride as uint16 sample, int8 normal x, int8 normal z (4 bytes
a vertex; the normal from the full-resolution samples' central differences, as the renderer's).
A 4097^2 map is 116,500 tile records of 1,156 bytes (135 MB) beside 2.8 MB of statistics.
No-data samples (seed 002's holes) keep their fill as the sample and carry the normal bytes
(-128, -128), which no unit normal has (its bytes lie in -127..127); the header then says
"holes": true, the renderer draws them with alpha 0 through the alpha test, and the tiles'
errors in the statistics hold the horizontal error as in memory.

`PagedTiles(path, budget_bytes)` keeps only the statistics and the records of the tiles it
holds, at most budget_bytes of them (an LRU: the least recently used go first, never one used
in the current frame). Selection runs on the statistics alone (terrain/tiles.select_tiles on a
pyramid without samples), so it is the in-memory method's exactly; a selected tile not held is
read at once (a miss, counted), and a loader thread reads ahead the tiles the next frames are
likely to want: the children of every selected tile whose error is within a factor `ahead` of
tau (they refine as the eye approaches) and the selected tiles' parents (they return as it
leaves). Reads are os.pread of one record each; the file is never mapped whole.
"""
from __future__ import annotations

import json
import os
import queue
import struct
import threading
import zlib
from collections import OrderedDict
from pathlib import Path

import numpy as np

from ..errors import WorldError
from ..files.atomic import atomic_write_bytes

MAGIC = b"VMTT"
MAX_HEADER = 1 << 20
NO_DATA = 0x80  # both normal bytes of a no-data vertex: int8 -128, which no unit normal has


def sample_normals(heightmap, rows, cols) -> np.ndarray:
    """(..., 3) unit normals at samples from the full-resolution central differences
    (one-sided at the border), as render/terrain.terrain_vertices computes them."""
    h = heightmap.heights
    return grid_normals(lambda r, c: h[r, c], heightmap.size, heightmap.spacing, rows, cols)


def grid_normals(at, size: int, spacing: float, rows, cols) -> np.ndarray:
    """sample_normals with the float32 heights read through at(rows, cols) (a whole grid or
    some of its rows: terrain/outofcore.py)."""
    n = size - 1
    r, c = rows, cols
    dx = (at(r, np.minimum(c + 1, n)) - at(r, np.maximum(c - 1, 0))) / \
        ((np.minimum(c + 1, n) - np.maximum(c - 1, 0)) * spacing)
    dz = (at(np.minimum(r + 1, n), c) - at(np.maximum(r - 1, 0), c)) / \
        ((np.minimum(r + 1, n) - np.maximum(r - 1, 0)) * spacing)
    normal = np.stack([-dx, np.ones_like(dx), -dz], axis=-1)
    return normal / np.linalg.norm(normal, axis=-1, keepdims=True)


def pack_records(samples, normals, valid=None) -> np.ndarray:
    """(K, V, 4) uint8 records of samples (K, V) uint16, normals (K, V, 3) and validity
    (K, V) bool or None (no-data vertices get the normal bytes NO_DATA)."""
    out = np.zeros(samples.shape + (4,), np.uint8)
    out[..., :2] = samples.astype("<u2").view(np.uint8).reshape(samples.shape + (2,))
    out[..., 2] = np.clip(np.rint(normals[..., 0] * 127), -127, 127).astype(np.int8).view(np.uint8)
    out[..., 3] = np.clip(np.rint(normals[..., 2] * 127), -127, 127).astype(np.int8).view(np.uint8)
    if valid is not None:
        out[~valid, 2:] = NO_DATA
    return out


def tile_records(pyramid, level: int, ti, tj) -> np.ndarray:
    """(K, V, 4) uint8 records (uint16 sample, int8 nx, int8 nz) of tiles (level, ti, tj)."""
    from .tiles import TileSelection, selection_mesh

    ti, tj = np.atleast_1d(ti), np.atleast_1d(tj)
    level_arr = np.full(len(ti), level, np.int64)
    rows, cols, _ = selection_mesh(pyramid, TileSelection(level_arr, ti, tj, level_arr * 0,
                                                          0, 0, 0))
    hm = pyramid.heightmap
    return pack_records(hm.samples[rows, cols], sample_normals(hm, rows, cols),
                        None if hm.valid is None else hm.valid[rows, cols])


def write_tiles(pyramid, path) -> None:
    """Write the .vmtiles file of an in-memory pyramid (module doc), atomically."""
    hm = pyramid.heightmap
    stats = np.stack([pyramid.flat_error, pyramid.flat_hmin, pyramid.flat_hmax], 1)
    stats = stats.astype("<f8").tobytes()
    header = {"size": hm.size, "patch": pyramid.patch, "levels": pyramid.levels,
              "spacing": hm.spacing, "z_scale": hm.z_scale, "z_offset": hm.z_offset,
              "name": hm.name, "low": float(hm.bounds()[0, 1]),
              "high": float(hm.bounds()[1, 1]), "stats_crc": zlib.crc32(stats)}
    if hm.valid is not None:
        header["holes"] = True  # absent otherwise: a file without holes is as before
    head = json.dumps(header, sort_keys=True).encode()
    parts = [MAGIC, struct.pack("<II", len(head), zlib.crc32(head)), head, stats]
    for level in range(pyramid.levels + 1):
        m = 1 << level
        ti, tj = np.divmod(np.arange(m * m), m)
        for start in range(0, m * m, 4096):
            parts.append(tile_records(pyramid, level, ti[start:start + 4096],
                                      tj[start:start + 4096]).tobytes())
    atomic_write_bytes(path, b"".join(parts))


class _Stand:
    """What selection and the renderer read of a heightmap: size, spacing, bounds, name."""

    def __init__(self, header):
        self.size, self.spacing = int(header["size"]), float(header["spacing"])
        self.z_scale, self.z_offset = float(header["z_scale"]), float(header["z_offset"])
        self.name, self.valid = str(header.get("name", "terrain")), None
        self.low, self.high = float(header["low"]), float(header["high"])
        self.holes = header.get("holes", False) is True  # no-data vertices in the records

    @property
    def extent(self) -> float:
        return (self.size - 1) * self.spacing

    def bounds(self) -> np.ndarray:
        return np.array([[0.0, self.low, 0.0], [self.extent, self.high, self.extent]])


def read_header(fd, path, magic: bytes, limit: int, name: str, kind: str) -> bytes:
    """The JSON text of a paged file's header: magic (4 bytes), its length and CRC32 (<II),
    then the text at byte 12. WorldError naming path: 'not a vismobile {name} (bad magic)',
    '{kind} header is too long' (over limit bytes), '... is truncated or corrupt'."""
    head = os.pread(fd, 12, 0)
    if len(head) != 12 or head[:4] != magic:
        raise WorldError(path, f"not a vismobile {name} (bad magic)")
    length, crc = struct.unpack("<II", head[4:])
    if length > limit:
        raise WorldError(path, f"{kind} header is too long")
    text = os.pread(fd, length, 12)
    if len(text) != length or zlib.crc32(text) != crc:
        raise WorldError(path, f"{kind} header is truncated or corrupt")
    return text


def grid_cells(x, z, spacing: float, size: int) -> tuple:
    """(shape of x and z broadcast, i, j, fu, fv): the grid cell (row i, column j, (n,) int64)
    holding each world point (x, z), clamped to the size^2 grid, and its place in it."""
    x, z = np.broadcast_arrays(np.asarray(x, np.float64), np.asarray(z, np.float64))
    u = np.clip(x / spacing, 0, size - 1).ravel()
    v = np.clip(z / spacing, 0, size - 1).ravel()
    j = np.minimum(np.floor(u).astype(np.int64), size - 2)
    i = np.minimum(np.floor(v).astype(np.int64), size - 2)
    return x.shape, i, j, u - j, v - i


def grid_surface(corners, fu, fv) -> np.ndarray:
    """(n,) heights of the cells' two triangles (split on the diagonal, Heightmap.height_at)
    at (fu, fv), from their corners (n, 4): h00, h01, h10, h11."""
    h00, h01, h10, h11 = corners.T
    upper = fu >= fv
    side = np.where(upper, h01, h10)
    a, b = np.where(upper, fu, fv), np.where(upper, fv, fu)
    return h00 + (a - b) * (side - h00) + b * (h11 - h00)


class PagedFile:
    """close() and its call on collection, shared by the paged terrains (a loader thread fed
    by self.queue, a file descriptor self.fd)."""

    def close(self) -> None:
        if self.loader is not None:
            self.queue.put(None)
            self.loader.join(timeout=5)
            self.loader = None
        if getattr(self, "fd", -1) >= 0:
            os.close(self.fd)
            self.fd = -1

    def __del__(self):
        try:
            self.close()
        except Exception:
            pass


class PagedTiles(PagedFile):
    """A .vmtiles terrain's statistics in memory and its tiles' records in an LRU (module doc).

    pyramid : a TilePyramid over the statistics (select_tiles runs on it unchanged)
    misses, hits, prefetched : counters of the last frame (records read at once, found held,
              read by the loader thread since the previous frame)
    """

    def __init__(self, path, budget_bytes: int = 16 << 20, ahead: float = 2.0,
                 thread: bool = True):
        from .quadtree import level_offsets
        from .tiles import TilePyramid, template

        from ..files.limits import regular_file

        self.path = Path(path)
        self.fd = -1
        self.loader = None
        regular_file(self.path)  # no FIFO (os.open would block), device or directory
        try:
            self.fd = os.open(self.path, os.O_RDONLY)
        except OSError as error:
            raise WorldError(path, f"cannot read ({error.strerror or error})") from None
        try:
            text = read_header(self.fd, path, MAGIC, MAX_HEADER, "tiled terrain",
                               "tiled terrain")
            length = len(text)
            try:
                header = json.loads(text)
                size, patch, levels = int(header["size"]), int(header["patch"]), \
                    int(header["levels"])
            except (ValueError, KeyError, TypeError):
                raise WorldError(path, "tiled terrain header is malformed") from None
            if not (3 <= size <= 8193 and 2 <= patch <= size - 1 and
                    0 <= levels <= 13 and patch << levels == size - 1):
                raise WorldError(path, f"tiled terrain header: size {size}, patch {patch}, "
                                       f"levels {levels} do not agree")
            try:
                scale = [float(header[k]) for k in ("spacing", "z_scale", "z_offset", "low",
                                                    "high")]
            except (KeyError, TypeError, ValueError):
                scale = [np.nan]
            if not isinstance(header.get("holes", False), bool):
                raise WorldError(path, "tiled terrain header: holes must be true or false")
            if not (np.isfinite(scale).all() and scale[0] > 0 and scale[1] > 0
                    and max(abs(v) for v in scale) <= 1e12 and scale[3] <= scale[4]):
                raise WorldError(path, "tiled terrain header: spacing, z_scale, z_offset, "
                                       "low and high must be finite (spacing, z_scale > 0)")
            self.offsets = level_offsets(levels)
            tiles = int(self.offsets[-1])
            raw = os.pread(self.fd, 24 * tiles, 12 + length)
            if len(raw) != 24 * tiles or zlib.crc32(raw) != header.get("stats_crc"):
                raise WorldError(path, "tiled terrain statistics are truncated or corrupt")
            self.record = 4 * (patch + 1) ** 2
            self.base = 12 + length + 24 * tiles
            if os.fstat(self.fd).st_size != self.base + tiles * self.record:
                raise WorldError(path, "tiled terrain file has the wrong length")
        except BaseException:
            os.close(self.fd)
            raise
        stats = np.frombuffer(raw, "<f8").reshape(tiles, 3)
        self.heightmap = _Stand(header)
        self.heightmap.height_at = self.height_at
        split = [(stats[self.offsets[l]:self.offsets[l + 1], k].reshape(1 << l, 1 << l))
                 for k in range(3) for l in range(levels + 1)]
        n = levels + 1
        self.pyramid = TilePyramid(self.heightmap, patch, levels, split[:n], split[n:2 * n],
                                   split[2 * n:], [template(patch, s) for s in range(16)], 0.0)
        self.budget = int(budget_bytes)
        self.capacity = max(1, self.budget // self.record)
        self.ahead = float(ahead)
        self.cache = OrderedDict()  # tile -> (V, 4) uint8 record, least recently used first
        self.lock = threading.Lock()
        self.current = set()
        self.misses = self.hits = self.prefetched = 0
        self._prefetched = 0
        self.queue = queue.Queue()
        if thread:
            self.loader = threading.Thread(target=self._load_ahead, daemon=True,
                                           name=f"tiles {self.path.name}")
            self.loader.start()

    def height_at(self, x, z, alternating: bool = False) -> np.ndarray:
        """Heights of the full-resolution grid surface at world (x, z) (Heightmap.height_at,
        the grid's diagonal), read from the finest tiles (not kept: a path's few points)."""
        hm, p = self.heightmap, self.pyramid
        shape, i, j, fu, fv = grid_cells(x, z, hm.spacing, hm.size)
        n, m = p.patch + 1, 1 << p.levels
        corners = np.empty((len(i), 4))
        for k, (di, dj) in enumerate(((0, 0), (0, 1), (1, 0), (1, 1))):
            r, c = i + di, j + dj
            ti, tj = np.minimum(r // p.patch, m - 1), np.minimum(c // p.patch, m - 1)
            tile = p.offsets[p.levels] + ti * m + tj
            for t in np.unique(tile):
                sel = tile == t
                rec = self._read(int(t))[:, :2].copy().view("<u2")[:, 0]
                local = (r[sel] - (t - p.offsets[p.levels]) // m * p.patch) * n + \
                    (c[sel] - (t - p.offsets[p.levels]) % m * p.patch)
                corners[sel, k] = hm.z_offset + hm.z_scale * rec[local].astype(np.float64)
        return grid_surface(corners, fu, fv).reshape(shape)

    def coarse_heightmap(self):
        """A Heightmap of the level 0 tile's (P+1)^2 samples (read, not kept): the viewer's
        stand-in of the ground."""
        from .heightmap import Heightmap

        record = self._read(0)
        n, hm = self.pyramid.patch + 1, self.heightmap
        samples = record[:, :2].copy().view("<u2")[:, 0].reshape(n, n)
        valid = ~((record[:, 2] == NO_DATA) & (record[:, 3] == NO_DATA)).reshape(n, n)
        return Heightmap(samples, hm.extent / (n - 1), hm.z_scale, hm.z_offset, hm.name,
                         valid if valid.any() else None)

    def memory_bytes(self) -> int:
        """Bytes of tile records held (at most the budget) plus the statistics."""
        return len(self.cache) * self.record + 24 * int(self.offsets[-1])

    def _read(self, tile: int) -> np.ndarray:
        data = os.pread(self.fd, self.record, self.base + int(tile) * self.record)
        if len(data) != self.record:
            raise WorldError(self.path, f"tile {tile} is truncated")
        return np.frombuffer(data, np.uint8).reshape(-1, 4)

    def _insert(self, tile, record) -> None:
        """Hold a record, evicting the least recently used not in this frame (lock held)."""
        self.cache[tile] = record
        self.cache.move_to_end(tile)
        while len(self.cache) > self.capacity:
            for old in self.cache:
                if old not in self.current:
                    del self.cache[old]
                    break
            else:
                break  # everything held is in use this frame: over budget until it ends

    def _load_ahead(self):
        while True:
            tiles = self.queue.get()
            if tiles is None:
                return
            for tile in tiles:
                with self.lock:
                    if tile in self.cache:
                        continue
                record = self._read(tile)
                with self.lock:
                    if tile not in self.cache and len(self.cache) < self.capacity:
                        self._insert(tile, record)
                        self._prefetched += 1

    def records(self, tiles) -> list:
        """The records of this frame's tiles (flat ids), reading the ones not held."""
        out = []
        with self.lock:
            self.current = set(int(t) for t in tiles)
            self.prefetched, self._prefetched = self._prefetched, 0
            self.misses = self.hits = 0
            for tile in tiles:
                tile = int(tile)
                record = self.cache.get(tile)
                if record is None:
                    record = self._read(tile)
                    self.misses += 1
                    self._insert(tile, record)
                else:
                    self.hits += 1
                    self.cache.move_to_end(tile)
                out.append(record)
        return out

    def read_ahead(self, selection, camera, resolution, tau) -> None:
        """Queue the tiles the next frames are likely to want (module doc)."""
        if self.loader is None or not len(selection.level):
            return
        from .tiles import pixel_scale

        p = self.pyramid
        _, lam = pixel_scale(camera, resolution)
        flat = p.offsets[selection.level] + selection.ti * (1 << selection.level) + selection.tj
        size = p.patch * (1 << (p.levels - selection.level)) * p.heightmap.spacing
        low = np.stack([selection.tj * size, p.flat_hmin[flat], selection.ti * size], 1)
        high = np.stack([(selection.tj + 1) * size, p.flat_hmax[flat],
                         (selection.ti + 1) * size], 1)
        gap = np.maximum(np.maximum(low - camera.eye, camera.eye - high), 0.0)
        dist = np.sqrt((gap * gap).sum(1))
        near = (lam * p.flat_error[flat] * self.ahead > tau * dist) & \
            (selection.level < p.levels)
        wanted = []
        for level, ti, tj in zip(selection.level[near], selection.ti[near], selection.tj[near]):
            child = p.offsets[level + 1] + (2 * ti + np.array([0, 0, 1, 1])) * \
                (1 << (level + 1)) + 2 * tj + np.array([0, 1, 0, 1])
            wanted.extend(int(c) for c in child)
        up = selection.level > 0
        parents = p.offsets[selection.level[up] - 1] + (selection.ti[up] // 2) * \
            (1 << (selection.level[up] - 1)) + selection.tj[up] // 2
        wanted.extend(int(t) for t in np.unique(parents))
        self.queue.put(wanted)

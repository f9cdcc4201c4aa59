"""Röttger's CLOD paged in by pages under a memory budget (issue 30: paging beyond the tiles).

A page is the subtree of one block of the page level lg (32 cells a side; the whole map when
it has fewer than 4 levels): its finer blocks' statistics (d2, hmin, hmax, centre height and
skip error, float64, exactly the in-memory Roettger's) and its (33)^2 vertices (uint16 sample,
int8 normal x and z as in .vmtiles; no data: normal bytes NO_DATA). The blocks of levels 0..lg
and the vertices every coarser leaf can use (the samples at every 16th row and column) stay in
memory, a few bytes a sample of the coarse grid.

`write_pages(roettger, path)` writes a `.vmrpages` file: magic b"VMRP", uint32 header length,
uint32 header CRC32, the JSON header, the coarse section (4 float64 arrays over the coarse
blocks, then the coarse vertex grid's records, CRC'd in the header), then one fixed-size
record per page in row-major order: its statistics as 5 x per_page float64, its vertex
records, and a CRC32 of both.

`PagedRoettger(path, budget_bytes)` refines with terrain/quadtree.py's *_paged kernels: a page
level block whose page is not held is not subdivided and the page is wanted; wanted pages are
read at once (misses, counted) and the frame is refined again, until nothing is wanted, so
every frame's leaves are the in-memory method's exactly (tests/terrain/test_paged_roettger.py).
Pages live in slots, least recently used first out, never one used by the current frame; a
frame that needs more pages than the budget holds grows the slots (counted in `grown`). A
loader thread reads ahead the pages Röttger's criterion wants for the eye AHEAD frames on
(_queue_ahead).
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
from ..files.atomic import atomic_writer
from .paged import (PagedFile, grid_cells, grid_surface, pack_records, read_header,
                    sample_normals)
from .quadtree import (ROETTGER, balance_paged, leaves_paged, level_offsets, refine_paged,
                       unreduce_finest_paged)
from .quadtree_paged import BASE, PAGE_LEVEL, PER_PAGE, SLOTS, WANTED
from .tiles import pixel_scale

MAGIC = b"VMRP"
MAX_HEADER = 1 << 16
AHEAD = 2.0  # frames of motion ahead the loader thread reads for


def page_layout(size: int) -> tuple:
    """(levels, page level, page cells, nodes a page holds) of a size^2 map."""
    cells = size - 1
    levels = cells.bit_length() - 2
    lg = max(0, levels - 4)
    k = levels - lg
    return levels, lg, cells >> lg, ((1 << (2 * k + 2)) - 4) // 3


def _page_nodes(offsets, lg, k_levels, pi, pj) -> np.ndarray:
    """Flat in-memory indices of page (pi, pj)'s nodes, in quadtree_paged.node_index's local
    order."""
    out = []
    for k in range(1, k_levels + 1):
        mk, m = 1 << k, 1 << (lg + k)
        li, lj = np.divmod(np.arange(mk * mk), mk)
        out.append(offsets[lg + k] + (pi * mk + li) * m + pj * mk + lj)
    return np.concatenate(out)


def write_pages(roettger, path) -> None:
    """Write the .vmrpages file of an in-memory Roettger (module doc), atomically."""
    hm = roettger.heightmap
    levels, lg, q, per_page = page_layout(hm.size)
    offsets = roettger.offsets
    coarse = int(offsets[lg + 1])
    h = max(q // 2, 1)
    grid = np.arange(0, hm.size, h)
    rows, cols = np.meshgrid(grid, grid, indexing="ij")
    section = np.stack([roettger.d2[:coarse], roettger.hmin[:coarse], roettger.hmax[:coarse],
                        roettger.centres[:coarse]]).astype("<f8").tobytes() + \
        _vertex_records(hm, rows, cols).tobytes()
    header = {"size": hm.size, "C": roettger.C, "levels": levels, "page_level": lg,
              "spacing": hm.spacing, "z_scale": hm.z_scale, "z_offset": hm.z_offset,
              "name": hm.name, "low": float(hm.bounds()[0, 1]),
              "high": float(hm.bounds()[1, 1]), "coarse_crc": zlib.crc32(section)}
    if hm.valid is not None:
        header["holes"] = True
    head = json.dumps(header, sort_keys=True).encode()
    stats = np.stack([roettger.d2, roettger.hmin, roettger.hmax, roettger.centres,
                      roettger.skip_error])
    a = np.arange(q + 1)
    with atomic_writer(path) as handle:
        handle.write(MAGIC + struct.pack("<II", len(head), zlib.crc32(head)) + head + section)
        for page in range(1 << (2 * lg)):
            pi, pj = divmod(page, 1 << lg)
            nodes = _page_nodes(offsets, lg, levels - lg, pi, pj)
            rows, cols = np.meshgrid(pi * q + a, pj * q + a, indexing="ij")
            body = stats[:, nodes].astype("<f8").tobytes() + \
                _vertex_records(hm, rows, cols).tobytes()
            handle.write(body + struct.pack("<I", zlib.crc32(body)))


def _vertex_records(hm, rows, cols) -> np.ndarray:
    return pack_records(hm.samples[rows, cols], sample_normals(hm, rows, cols),
                        None if hm.valid is None else hm.valid[rows, cols])


class PagedRoettger(PagedFile):
    """A .vmrpages terrain's coarse blocks in memory and its pages in slots (module doc).

    heightmap : a stand-in (size, spacing, z_scale, z_offset, bounds, holes)
    misses, prefetched : pages read at once in the last frame / read ahead since the previous
    grown : frames that needed more slots than the budget holds
    evicted : pages dropped for others (least recently used), in all
    """

    def __init__(self, path, budget_bytes: int = 16 << 20, thread: bool = True):
        from .paged import _Stand

        self.path = Path(path)
        self.loader = None
        try:
            self.fd = os.open(self.path, os.O_RDONLY)
        except OSError as error:
            raise WorldError(path, f"cannot read ({error.strerror or error})") from None
        try:
            header, section = self._open()
        except BaseException:
            os.close(self.fd)
            raise
        self.heightmap = _Stand(header)
        self.heightmap.height_at = self.height_at
        self.C = float(header["C"])
        size = self.size = int(header["size"])
        self.levels, self.lg, self.q, self.per_page = page_layout(size)
        self.offsets = level_offsets(self.levels)
        coarse = self.coarse = int(self.offsets[self.lg + 1])
        stats = np.frombuffer(section[:32 * coarse], "<f8").reshape(4, coarse)
        h = self.h = max(self.q // 2, 1)
        g = (size - 1) // h + 1
        self.grid = np.frombuffer(section[32 * coarse:], np.uint8).reshape(g, g, 4)
        self.pages = 1 << (2 * self.lg)
        self.coarse_stats = stats
        self.vertex_bytes = 4 * (self.q + 1) ** 2
        self.slot_bytes = self.per_page * 56 + self.vertex_bytes  # 5 stats + stamp + list
        self.budget = int(budget_bytes)
        self.table = np.full(SLOTS + 2 * self.pages, -1, np.int64)
        self.table[PAGE_LEVEL], self.table[PER_PAGE], self.table[BASE] = \
            self.lg, self.per_page, coarse
        self.table[WANTED] = 0
        self.slots = 0
        fixed = self.coarse * 48 + self.grid.nbytes  # as memory_bytes counts them
        self._allocate(max(1, (self.budget - fixed) // self.slot_bytes))
        self.resident = OrderedDict()  # page -> slot, least recently used first
        self.frame = 0
        self.misses = self.prefetched = self.grown = self.evicted = 0
        self._prefetched = 0
        self.pinned = set()
        self.lock = threading.Lock()
        self.queue = queue.Queue()
        self.leaf_rows = np.zeros((1 << 12, 4), np.int64)
        self.leaf_count = 0
        self._out = np.zeros((1 << 12, 3), np.int64)  # triangles(): kept across frames
        self._side = np.empty((size, 0), np.float32)
        self._signature = np.zeros(1, np.uint64)
        if thread:
            self.loader = threading.Thread(target=self._load_ahead, daemon=True,
                                           name=f"pages {self.path.name}")
            self.loader.start()

    def _open(self) -> tuple:
        path = self.path
        text = read_header(self.fd, path, MAGIC, MAX_HEADER, "paged Röttger terrain",
                           "paged terrain")
        length = len(text)
        try:
            header = json.loads(text)
            size, levels, lg = int(header["size"]), int(header["levels"]), \
                int(header["page_level"])
            C = float(header["C"])
            scale = [float(header[k]) for k in ("spacing", "z_scale", "z_offset", "low", "high")]
        except (ValueError, KeyError, TypeError):
            raise WorldError(path, "paged terrain header is malformed") from None
        if not (5 <= size <= 8193 and (size - 1) & (size - 2) == 0
                and (levels, lg) == page_layout(size)[:2]):
            raise WorldError(path, f"paged terrain header: size {size}, levels {levels}, page "
                                   f"level {lg} do not agree")
        if not (np.isfinite(scale).all() and scale[0] > 0 and scale[1] > 0 and 1 < C < 1e6
                and max(abs(v) for v in scale) <= 1e12 and scale[3] <= scale[4]):
            raise WorldError(path, "paged terrain header: C, spacing, z_scale, z_offset, low "
                                   "and high must be finite (C > 1, spacing, z_scale > 0)")
        if not isinstance(header.get("holes", False), bool):
            raise WorldError(path, "paged terrain header: holes must be true or false")
        _, _, q, per_page = page_layout(size)
        g = (size - 1) // max(q // 2, 1) + 1
        length_section = 32 * int(level_offsets(levels)[lg + 1]) + 4 * g * g
        section = os.pread(self.fd, length_section, 12 + length)
        if len(section) != length_section or zlib.crc32(section) != header.get("coarse_crc"):
            raise WorldError(path, "paged terrain coarse section is truncated or corrupt")
        self.base = 12 + length + length_section
        self.record = 40 * per_page + 4 * (q + 1) ** 2 + 4
        if os.fstat(self.fd).st_size != self.base + (1 << (2 * lg)) * self.record:
            raise WorldError(path, "paged terrain file has the wrong length")
        return header, section

    def _allocate(self, slots: int) -> None:
        """(Re)size the per-node arrays for slots pages (the coarse part and held pages kept)."""
        old = self.slots
        total = self.coarse + slots * self.per_page
        arrays = {}
        for name in ("d2", "hmin", "hmax", "centres", "skip_error"):
            arrays[name] = np.zeros(total)
        arrays["stamp"] = np.zeros(total, np.int64)
        if old:
            keep = self.coarse + old * self.per_page
            for name in arrays:
                arrays[name][:keep] = getattr(self, name)[:keep]
            samples = np.zeros((slots, (self.q + 1) ** 2, 4), np.uint8)
            samples[:old] = self.samples
        else:
            for k, name in enumerate(("d2", "hmin", "hmax", "centres")):
                arrays[name][:self.coarse] = self.coarse_stats[k]
            samples = np.zeros((slots, (self.q + 1) ** 2, 4), np.uint8)
        for name, value in arrays.items():
            setattr(self, name, value)
        self.samples = samples
        caps = [1 << (2 * l) if l <= self.lg else slots << (2 * (l - self.lg))
                for l in range(self.levels + 1)]
        self.list_offsets = np.r_[0, np.cumsum(caps)].astype(np.int64)
        self.lists = np.zeros(int(self.list_offsets[-1]), np.int64)
        self.counts = np.zeros(self.levels + 1, np.int64)
        self.free = list(range(old, slots)) + list(getattr(self, "free", []))
        self.slots = slots

    def height_at(self, x, z, alternating: bool = False) -> np.ndarray:
        """Heights of the full-resolution grid surface at world (x, z) (Heightmap.height_at),
        the cells' corners read from their pages (not kept: a path's few points)."""
        hm, q, side = self.heightmap, self.q, 1 << self.lg
        shape, i, j, fu, fv = grid_cells(x, z, hm.spacing, self.size)
        page = np.minimum(i // q, side - 1) * side + np.minimum(j // q, side - 1)
        corners = np.empty((len(i), 4))
        for p in np.unique(page):
            sel = page == p
            vertices = self._read(int(p))[1][:, :2].copy().view("<u2")[:, 0]
            pi, pj = divmod(int(p), side)
            for k, (di, dj) in enumerate(((0, 0), (0, 1), (1, 0), (1, 1))):
                local = (i[sel] + di - pi * q) * (q + 1) + j[sel] + dj - pj * q
                corners[sel, k] = hm.z_offset + hm.z_scale * vertices[local].astype(np.float64)
        return grid_surface(corners, fu, fv).reshape(shape)

    def coarse_heightmap(self):
        """A Heightmap of every 16th sample (the coarse grid held in memory): the viewer's
        stand-in of the ground."""
        from .heightmap import Heightmap

        samples = self.grid[..., :2].copy().view("<u2")[..., 0]
        valid = ~((self.grid[..., 2] == 0x80) & (self.grid[..., 3] == 0x80))
        hm = self.heightmap
        return Heightmap(samples, hm.spacing * self.h, hm.z_scale, hm.z_offset, hm.name,
                         valid if valid.any() else None)

    def memory_bytes(self) -> int:
        """Bytes of the coarse part and of the slots (allocated, held or not)."""
        return self.coarse * 48 + self.grid.nbytes + self.slots * self.slot_bytes

    def _read(self, page: int) -> tuple:
        data = os.pread(self.fd, self.record, self.base + page * self.record)
        if len(data) != self.record or \
                zlib.crc32(data[:-4]) != struct.unpack("<I", data[-4:])[0]:
            raise WorldError(self.path, f"page {page} is truncated or corrupt")
        stats = np.frombuffer(data[:40 * self.per_page], "<f8").reshape(5, self.per_page)
        return stats, np.frombuffer(data[40 * self.per_page:-4], np.uint8).reshape(-1, 4)

    def _place(self, page, stats, vertices, grow: bool = True) -> bool:
        """Hold a page (lock held): a free slot, else the least recently used unpinned one,
        else more slots when grow (else nothing: False)."""
        if not self.free:
            victim = next((p for p in self.resident if p not in self.pinned), None)
            if victim is None:
                if not grow:
                    return False
                self.grown += 1
                self._allocate(2 * self.slots)
            else:
                self.free.append(self.resident.pop(victim))
                self.table[SLOTS + victim] = -1
                self.evicted += 1
        slot = self.free.pop()
        start = self.coarse + slot * self.per_page
        for k, name in enumerate(("d2", "hmin", "hmax", "centres", "skip_error")):
            getattr(self, name)[start:start + self.per_page] = stats[k]
        self.stamp[start:start + self.per_page] = 0
        self.samples[slot] = vertices
        self.resident[page] = slot
        self.table[SLOTS + page] = slot
        return True

    def select(self, camera, resolution, tau: float, cull: bool = True) -> tuple:
        """Refine for this camera, reading wanted pages, until nothing is wanted; the visible
        leaves go to leaf_rows (Roettger.select's rows). Returns (blocks tested, leaves)."""
        _, lam = pixel_scale(camera, resolution)
        c = lam / (tau * self.C)
        planes = camera.frustum_planes()
        cells, spacing = self.size - 1, self.heightmap.spacing
        self.prefetched, self._prefetched = self._prefetched, 0
        self.misses = 0
        with self.lock:
            self.pinned = set()
            for _ in range(4 * self.levels + 8):
                self.frame += 1
                self.table[WANTED] = 0
                tested = refine_paged(cells, spacing, self.centres, self.d2, self.hmin,
                                      self.hmax, self.offsets, self.levels, self.stamp,
                                      self.frame, camera.eye, planes, ROETTGER, self.C, c,
                                      cull, self.lists, self.counts, self.table,
                                      self.list_offsets)
                if self.levels > 0 and unreduce_finest_paged(
                        cells, spacing, self.levels, self.offsets, self.stamp, self.frame,
                        self.lists, self.counts, self.skip_error, self.hmin, self.hmax,
                        camera.eye, planes, lam, float(tau), cull, self.table,
                        self.list_offsets):
                    balance_paged(self.offsets, self.levels, self.stamp, self.frame,
                                  self.lists, self.counts, self.table, self.list_offsets)
                used = self._used()
                self.pinned |= set(used.tolist())
                for page in used:
                    self.resident.move_to_end(int(page))
                wanted = self.table[SLOTS + self.pages:SLOTS + self.pages
                                    + self.table[WANTED]]
                if not len(wanted):
                    break
                for page in np.unique(wanted):
                    if int(page) not in self.resident:
                        self.pinned.add(int(page))
                        self._place(int(page), *self._read(int(page)))
                        self.misses += 1
            else:
                raise RuntimeError("paged refinement did not settle")
            while True:
                count, _ = leaves_paged(cells, spacing, self.hmin, self.hmax, self.offsets,
                                        self.levels, self.stamp, self.frame, planes, cull,
                                        self.leaf_rows, self.table)
                if count >= 0:
                    break
                self.leaf_rows = np.zeros((2 * len(self.leaf_rows), 4), np.int64)
        self.leaf_count = count
        if self.loader is not None:
            eye = np.asarray(camera.eye, np.float64)
            last = getattr(self, "_last_eye", eye)
            self._last_eye = eye
            shift = AHEAD * (eye - last)
            ahead = planes.copy()
            ahead[:, 3] -= ahead[:, :3] @ shift  # the frustum moved with the eye
            self._queue_ahead(used, eye + shift, c, ahead)
        return tested, count

    def _used(self) -> np.ndarray:
        """Pages whose page level block is subdivided this frame (the level's list of the last
        refinement: as many as there are, not a scan of every page)."""
        start = self.list_offsets[self.lg]
        return np.sort(self.lists[start:start + self.counts[self.lg]])

    def _queue_ahead(self, used, eye, c, planes) -> None:
        """Queue the pages not held whose page level block Röttger's criterion subdivides
        for the eye and frustum where the motion is heading (AHEAD frames on), the nearest to
        subdividing first, as many as half the slots the frame leaves (more would evict each
        other, and the loader thread, holding the interpreter while it copies, would slow the
        frames)."""
        room = (self.slots - len(used)) // 2
        if room <= 0:
            return
        side, lg = 1 << self.lg, self.lg
        if not len(used):
            return
        # candidates: the pages around those in use (not every page: no per-frame work in
        # proportion to the map)
        ui, uj = np.divmod(used, side)
        rows = np.arange(max(0, ui.min() - 2), min(side, ui.max() + 3))
        cols = np.arange(max(0, uj.min() - 2), min(side, uj.max() + 3))
        bi, bj = (a.ravel() for a in np.meshgrid(rows, cols, indexing="ij"))
        pages = bi * side + bj
        first = self.offsets[lg] + pages
        d = (self.size - 1 >> lg) * self.heightmap.spacing
        centre = self.coarse_stats[3, first]
        l1 = np.abs(eye[0] - (bj + 0.5) * d) + np.abs(eye[1] - centre) + \
            np.abs(eye[2] - (bi + 0.5) * d)
        low = self.coarse_stats[1, first]
        high = self.coarse_stats[2, first]
        gap = np.stack([np.maximum(np.maximum(bj * d - eye[0], eye[0] - (bj + 1) * d), 0),
                        np.maximum(np.maximum(low - eye[1], eye[1] - high), 0),
                        np.maximum(np.maximum(bi * d - eye[2], eye[2] - (bi + 1) * d), 0)])
        dist = np.sqrt((gap * gap).sum(0))
        d2 = self.coarse_stats[0, first]
        ratio = np.minimum(l1 / (d * self.C), dist / np.maximum(d * self.C * c * d2, 1e-300))
        corner = [np.where(planes[:, k, None] >= 0, hi, lo) for k, (lo, hi) in
                  enumerate(((bj * d, (bj + 1) * d), (low, high), (bi * d, (bi + 1) * d)))]
        inside = ((planes[:, 0, None] * corner[0] + planes[:, 1, None] * corner[1]
                   + planes[:, 2, None] * corner[2] + planes[:, 3, None]) >= 0).all(0)
        wanted = np.flatnonzero((ratio < 1.0) & inside & (self.table[SLOTS + pages] < 0))
        if len(wanted):
            self.queue.put([int(p) for p in pages[wanted[np.argsort(ratio[wanted])[:room]]]])

    def _load_ahead(self):
        while True:
            pages = self.queue.get()
            while pages is not None and not self.queue.empty():
                pages = self.queue.get()  # only the latest frame's wishes
            if pages is None:
                return
            for page in pages:  # may evict held pages the last frame did not use
                with self.lock:
                    if page in self.resident:
                        continue
                try:
                    stats, vertices = self._read(page)
                except WorldError:
                    continue  # read again at once when wanted, which reports it
                with self.lock:
                    if page not in self.resident and self._place(page, stats, vertices,
                                                                 grow=False):
                        self._prefetched += 1

    def vertex_records(self, ids) -> np.ndarray:
        """(K, 4) uint8 records (sample, nx, nz) of sample ids (row * N + col): from the coarse
        grid at every h-th row and column, else from a held page holding the sample (every
        leaf's page is held by construction)."""
        r, c = np.divmod(np.asarray(ids, np.int64), self.size)
        out = np.empty((len(r), 4), np.uint8)
        on_grid = (r % self.h == 0) & (c % self.h == 0)
        out[on_grid] = self.grid[r[on_grid] // self.h, c[on_grid] // self.h]
        rest = np.flatnonzero(~on_grid)
        side, q = 1 << self.lg, self.q
        slot = np.full(len(rest), -1, np.int64)
        rr, cc = r[rest], c[rest]
        local = np.zeros(len(rest), np.int64)
        for di in (0, 1):
            for dj in (0, 1):
                pi = np.clip(rr // q - di, 0, side - 1)
                pj = np.clip(cc // q - dj, 0, side - 1)
                inside = (rr - pi * q <= q) & (cc - pj * q <= q) & (rr >= pi * q) & \
                    (cc >= pj * q)
                s = np.where(inside, self.table[SLOTS + pi * side + pj], -1)
                take = (slot < 0) & (s >= 0)
                slot[take] = s[take]
                local[take] = (rr[take] - pi[take] * q) * (q + 1) + cc[take] - pj[take] * q
        if (slot < 0).any():
            raise RuntimeError("a drawn vertex lies in no held page")
        out[rest] = self.samples[slot, local]
        return out

    def triangles(self) -> np.ndarray:
        """(T, 3) int64 sample ids of the last select's leaves' fans (Roettger's fans)."""
        from .roettger import _emit

        if len(self._out) < 8 * self.leaf_count:  # a fan has at most 8 triangles
            self._out = np.zeros((8 * self.leaf_count, 3), np.int64)
        # _emit reads only the map's side from its first argument; chunk level 0: one chunk
        count = _emit(self._side, self.leaf_rows, self.leaf_count, self.offsets, 0, self._out,
                      self._signature)
        return self._out[:count].copy()

    def leaf_errors(self) -> tuple:
        """(e, hmin, hmax) per drawn leaf: d * d2 (0 for a finest leaf with no skip) and its
        box heights, read through the page table (RoettgerLod.errors)."""
        rows = self.leaf_rows[:self.leaf_count]
        level, bi, bj, sides = rows.T
        index = np.empty(len(rows), np.int64)
        for k, (l, i, j) in enumerate(zip(level, bi, bj)):
            index[k] = _index(self.offsets, self.table, int(l), int(i), int(j))
        size = ((self.size - 1) >> level) * self.heightmap.spacing
        e = np.where((level == self.levels) & (sides == 0), 0.0, self.d2[index] * size)
        return e, self.hmin[index], self.hmax[index]


def _index(offsets, table, l, bi, bj) -> int:
    """quadtree_paged.node_index in Python."""
    lg = int(table[PAGE_LEVEL])
    if l <= lg:
        return int(offsets[l] + bi * (1 << l) + bj)
    k = l - lg
    slot = int(table[SLOTS + (bi >> k) * (1 << lg) + (bj >> k)])
    mk = 1 << k
    return int(table[BASE] + slot * table[PER_PAGE] + ((1 << (2 * k)) - 4) // 3
               + (bi & (mk - 1)) * mk + (bj & (mk - 1)))

"""Out-of-core octree build: a memory-mapped world partitioned in triangle chunks, references
sorted externally, the .vmp streamed to disk; chunks run in parallel worker processes.

Why chunks give the serial build's tree: every decision of `octree.subdivide` (which children a
triangle keeps, by its box and the exact SAT) depends on that triangle and the cell alone, and
a cell's box depends only on its octant path from the root. So each chunk of triangles is
subdivided on its own (`_chunk_task`), naming cells by their octant path (3 bits per level, the
first level highest). The tree is the union of the chunks' cells; all references sit in the
leaves of the last level, and the serial build orders them by leaf path, then triangle id,
which is leaf path, then chunk, then the chunk's own order. That is a distribution sort: each
chunk's references (spilled to disk, already in that order) go to offsets known from the
per-chunk leaf counts (`_scatter_task`), so no step holds all references in memory.

Memory: a chunk's subdivision (about 0.5 KB per triangle at the default chunk) per worker, the
tree's nodes, and the file pages being written. Time: the chunk and scatter tasks run on
`jobs` processes; what stays serial is the extent pass, merging the chunks' cell sets (small),
copying the world into the file and its checksums (streamed); the extent pass (per-chunk boxes)
runs on the workers too.
"""
from __future__ import annotations

import json
import os
import shutil
import time
import types
import zlib
from pathlib import Path

import numpy as np

from ..files.atomic import check_destination, make_dirs, sweep_stale, temp_path
from .layout import outward_f32
from .octree import DEFAULT_DEPTH, check_depth, child_boxes, subdivide
from .occluders import STORED, candidate_lists
from .store import ALIGN, MAGIC, PREFIX, VERSION

CHUNK = 1 << 19
# Bytes reserved for the JSON header at the front of a streamed file (padded with spaces).
HEADER_SPACE = 1 << 16
COPY_ROWS = 1 << 20


def _extent_task(world, start, size) -> np.ndarray:
    """(2, 3) float64 box of the corners of triangles [start, start + size)."""
    corners = np.asarray(world.vertices)[np.asarray(world.triangles[start:start + size]).ravel()]
    return np.stack([corners.min(axis=0), corners.max(axis=0)]).astype(np.float64)


def _chunk_task(world, start, size, extent, depth, spill) -> tuple:
    """Subdivide triangles [start, start + size) on their own; their references go to `spill`.

    returns : per level 1..depth the sorted cell paths (int64), the leaf paths (L,) int64 with
              their reference counts (L,) int64; spill holds the triangle ids (int32), ordered
              by leaf path, then id
    """
    tris = np.asarray(world.triangles[start:start + size])
    corners = np.asarray(world.vertices)[tris.ravel()].astype(np.float64).reshape(-1, 3, 3)
    # subdivide reads .bounds, .vertices and .triangles: a chunk-local world of its corners.
    local = types.SimpleNamespace(
        bounds=np.stack([corners.min(axis=1), corners.max(axis=1)], axis=1),
        vertices=corners.reshape(-1, 3),
        triangles=np.arange(3 * len(corners), dtype=np.int64).reshape(-1, 3))
    del tris
    ids = np.arange(len(corners), dtype=np.int64)
    try:
        levels, (leaf_node, leaf_tri) = subdivide(local, np.asarray(extent, np.float64)[None],
                                                  np.zeros_like(ids), ids, depth)
    except ValueError:  # over layout.MAX_REFERENCES: the caller splits the chunk
        if len(ids) == 1:
            raise
        return None
    paths, code = [], np.zeros(1, dtype=np.int64)
    for _, parent, octant in levels:
        code = code[parent] * 8 + octant
        paths.append(code)
    leaf_path = paths[-1][leaf_node] if len(leaf_node) else np.zeros(0, dtype=np.int64)
    np.save(spill, (leaf_tri + start).astype(np.int32))
    leaves, counts = np.unique(leaf_path, return_counts=True)
    return paths, leaves, counts.astype(np.int64)


def _scatter_task(spill, out_path, offset, total, positions) -> None:
    """Write a chunk's spilled references at `positions` (one start per run of a leaf) into the
    tri_refs section (int32, `total` values at byte `offset` of out_path)."""
    refs = np.load(spill)
    target = np.memmap(out_path, dtype="<i4", mode="r+", offset=offset, shape=(total,))
    starts, counts = positions
    at = np.repeat(starts - np.cumsum(counts) + counts, counts) + np.arange(len(refs))
    target[at] = refs
    target.flush()
    del target


class _Clock:
    """Wall and CPU seconds (of this process) per named phase: clock("name") closes the phase
    begun at the last call. With jobs=1 the CPU seconds are the whole work of each phase."""

    def __init__(self):
        self.seconds, self.cpu = {}, {}
        self.last, self.last_cpu = time.perf_counter(), time.process_time()

    def __call__(self, name):
        now, cpu = time.perf_counter(), time.process_time()
        self.seconds[name], self.cpu[name] = now - self.last, cpu - self.last_cpu
        self.last, self.last_cpu = now, cpu


class _Workers:
    """Runs (function, args) tasks on `jobs` spawned processes, or here when jobs is 1; one
    pool serves every phase of a build (spawning costs an import of numpy and vismobile)."""

    def __init__(self, jobs):
        self.jobs, self.pool = jobs, None

    def __enter__(self):
        if self.jobs > 1:
            import multiprocessing
            from concurrent.futures import ProcessPoolExecutor

            self.pool = ProcessPoolExecutor(self.jobs,
                                            mp_context=multiprocessing.get_context("spawn"))
        return self

    def __exit__(self, *exc):
        if self.pool is not None:
            self.pool.shutdown()

    def run(self, tasks) -> list:
        """Results in task order."""
        if self.pool is None:
            return [f(*a) for f, a in tasks]
        return [f.result() for f in [self.pool.submit(f, *a) for f, a in tasks]]


def tree_of(level_paths, leaves, counts, extent, depth) -> dict:
    """Breadth-first arrays (base.py layout) of the octree with these cells.

    level_paths : per level 1..depth the sorted unique cell paths present
    leaves, counts : last-level paths (sorted) and their reference counts
    returns dict node_bounds, child_count, ref_start, ref_end, level_start, octant
    """
    paths = [np.zeros(1, dtype=np.int64)] + list(level_paths)
    boxes, octants, parents = [np.asarray(extent, np.float64)[None]], [np.array([-1])], []
    for k in range(1, len(paths)):
        parent = np.searchsorted(paths[k - 1], paths[k] >> 3)
        octant = (paths[k] & 7).astype(np.int64)
        boxes.append(child_boxes(boxes[-1], parent, octant))
        octants.append(octant)
        parents.append(parent)
    sizes = np.array([len(p) for p in paths], dtype=np.int64)
    level_start = np.concatenate([[0], np.cumsum(sizes)]).astype(np.int64)
    child_count = np.concatenate([np.bincount(p, minlength=len(paths[k]))
                                  for k, p in enumerate(parents)] + [np.zeros(sizes[-1], np.int64)])
    cum = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
    ref_start, ref_end = [], []
    for k, level in enumerate(paths):
        shift = 3 * (depth - k)  # the leaves below a cell: paths [p << shift, (p + 1) << shift)
        ref_start.append(cum[np.searchsorted(leaves, level << shift)])
        ref_end.append(cum[np.searchsorted(leaves, (level + 1) << shift)])
    return {"node_bounds": outward_f32(np.concatenate(boxes)),
            "child_count": child_count.astype(np.int32),
            "ref_start": np.concatenate(ref_start), "ref_end": np.concatenate(ref_end),
            "level_start": level_start,
            "octant": np.concatenate(octants).astype(np.int8)}


class _Writer:
    """Sections appended to an open file after HEADER_SPACE, each CRC32'd as it is written."""

    def __init__(self, handle):
        self.handle, self.sections, self.fields, self.offset = handle, [], {}, 0

    def field(self, name, dtype, shape, stored, write):
        """Add field `name` (logical dtype and shape) stored raw as `stored` dtype; `write` is
        called with (self) and must call self.put(array) for consecutive pieces."""
        self.fields[name] = {"encoding": "raw", "dtype": np.dtype(dtype).str,
                             "shape": list(shape), "parts": [name]}
        self._section = {"name": name, "dtype": np.dtype(stored).str,
                         "count": int(np.prod(shape, dtype=np.int64)), "offset": self.offset,
                         "crc32": 0}
        self._dtype, self._nbytes = np.dtype(stored), 0
        self.handle.seek(HEADER_SPACE + self.offset)
        write(self)
        self._finish()

    def put(self, array):
        data = np.ascontiguousarray(array, dtype=self._dtype).tobytes()
        self.handle.write(data)
        self._section["crc32"] = zlib.crc32(data, self._section["crc32"])
        self._nbytes += len(data)

    def reserve(self, count):
        """Leave room for `count` values (filled later through a memory map); returns the
        section's absolute byte offset."""
        self._nbytes = count * self._dtype.itemsize
        self._section["pending"] = True
        return HEADER_SPACE + self.offset

    def _finish(self):
        self._section["nbytes"] = self._nbytes
        self.sections.append(self._section)
        self.offset += self._nbytes + (-self._nbytes % ALIGN)

    def checksum_pending(self):
        """CRC32 of reserved sections, read back in pieces once they are filled."""
        for sec in self.sections:
            if sec.pop("pending", False):
                self.handle.flush()
                self.handle.seek(HEADER_SPACE + sec["offset"])
                left, crc = sec["nbytes"], 0
                while left:
                    data = self.handle.read(min(left, 1 << 24))
                    crc, left = zlib.crc32(data, crc), left - len(data)
                sec["crc32"] = crc


def _copy_rows(array, dtype):
    """A writer callback that streams array (memory-mapped) in row blocks."""
    def write(writer):
        for start in range(0, len(array), COPY_ROWS):
            writer.put(np.asarray(array[start:start + COPY_ROWS], dtype=dtype))
    return write


def build_octree_file(world, out, depth=DEFAULT_DEPTH, chunk=CHUNK, jobs=1,
                      spill_dir=None) -> dict:
    """Partition a MappedWorld (mapped.py) into an octree .vmp at `out`, out of core.

    The file is the one `octree.build(world.load(), depth)` saves, with every section stored
    raw (vertices float32, references int32), so `store.map_partition` maps it without
    decoding; `load_partition` reads it too. Same bytes for any `jobs` and `chunk`.
    world : MappedWorld (with jobs > 1, opened from a directory so workers can map it)
    jobs  : worker processes for the chunk and scatter tasks
    returns {"nodes", "references", "chunks", "bytes", "seconds": {phase: wall seconds},
              "cpu_seconds": {phase: CPU seconds of this process}};
              the phases "extent", "chunks" and "scatter" run on `jobs` processes, the others here
    """
    depth = check_depth(depth)
    if world.triangle_count == 0:
        raise ValueError("cannot partition a world without triangles")
    out = check_destination(out)
    make_dirs(out.parent)
    sweep_stale(out.parent)
    clock = _Clock()
    starts = list(range(0, world.triangle_count, chunk))
    # Named like atomic.py's temporaries, so a crashed build's spill is swept by a later one.
    spill_root = temp_path(Path(spill_dir or out.parent) / f"{out.name}.spill")
    spill_root.mkdir()
    tmp = temp_path(out)
    workers = _Workers(jobs).__enter__()
    try:
        bounds = np.array(workers.run([(_extent_task, (world, s, chunk)) for s in starts]))
        extent = np.stack([bounds[:, 0].min(axis=0), bounds[:, 1].max(axis=0)])
        clock("extent")
        # (start, size) chunks; one whose level would exceed the reference limit comes back
        # as None and is split in two (chunk boundaries do not change the file).
        pending, done = [(s, min(chunk, world.triangle_count - s)) for s in starts], {}
        while pending:
            answers = workers.run([(_chunk_task, (world, s, n, extent, depth,
                                                  spill_root / f"{s}.npy")) for s, n in pending])
            retry = []
            for (s, n), answer in zip(pending, answers):
                if answer is None:
                    retry += [(s, n // 2), (s + n // 2, n - n // 2)]
                else:
                    done[s] = answer
            pending = retry
        starts = sorted(done)
        spills = [spill_root / f"{s}.npy" for s in starts]
        results = [done[s] for s in starts]
        clock("chunks")
        level_paths = [np.unique(np.concatenate([r[0][k] for r in results]))
                       for k in range(depth)]
        leaves = level_paths[-1]
        per_chunk = np.zeros((len(leaves), max(len(results), 1)), dtype=np.int64)
        for c, (_, chunk_leaves, counts) in enumerate(results):
            per_chunk[np.searchsorted(leaves, chunk_leaves), c] = counts
        # Offsets: leaf path first, then chunk (the serial build's order).
        flat = np.cumsum(per_chunk.ravel()) - per_chunk.ravel()
        offsets = flat.reshape(per_chunk.shape)
        total = int(per_chunk.sum())
        tree = tree_of(level_paths, leaves, per_chunk.sum(axis=1), extent, depth)
        clock("merge")
        with open(tmp, "wb+") as handle:
            writer = _Writer(handle)
            writer.field("world.vertices", "<f8", world.vertices.shape, "<f4",
                         _copy_rows(world.vertices, "<f4"))
            writer.field("world.triangles", "<i4", world.triangles.shape, "<i4",
                         _copy_rows(world.triangles, "<i4"))
            writer.field("world.object_ids", "<i4", world.object_ids.shape, "<i4",
                         _copy_rows(world.object_ids, "<i4"))
            for name in ("node_bounds", "child_count", "ref_start", "ref_end", "level_start"):
                value = tree[name]
                stored = "<f4" if value.dtype.kind == "f" else value.dtype.str
                writer.field(name, value.dtype, value.shape, stored,
                             lambda w, v=value: w.put(v))
            refs_at = []
            writer.field("tri_refs", "<i4", (total,), "<i4",
                         lambda w: refs_at.append(w.reserve(total)))
            writer.field("extras.octant", "<i1", tree["octant"].shape, "<i1",
                         lambda w: w.put(tree["octant"]))
            handle.truncate(HEADER_SPACE + writer.offset)
            handle.flush()
            clock("write")
            if total:
                tasks = []
                for c, (_, chunk_leaves, counts) in enumerate(results):
                    rows = np.searchsorted(leaves, chunk_leaves)
                    tasks.append((_scatter_task, (spills[c], tmp, refs_at[0], total,
                                                  (offsets[rows, c], counts))))
                workers.run(tasks)
            clock("scatter")
            # Each node's largest triangles (partition/occluders.py), from the references just
            # scattered (read back through a map) and the world's corners: occlusion's lists.
            handle.flush()
            refs = (np.memmap(tmp, dtype="<i4", mode="r", offset=refs_at[0], shape=(total,))
                    if total else np.zeros(0, np.int32))
            count = tree["child_count"].astype(np.int64)
            lists = candidate_lists(np.where(count > 0, 1 + np.cumsum(count) - count, -1), count,
                                    tree["ref_start"], tree["ref_end"], refs, world.vertices,
                                    world.triangles, STORED)
            del refs
            writer.field("extras.occluders", "<i4", lists.shape, "<i4",
                         lambda w: w.put(lists))
            clock("occluders")
            writer.checksum_pending()
            last = writer.sections[-1]
            handle.truncate(HEADER_SPACE + last["offset"] + last["nbytes"])
            header = {"format": "vismobile partition", "version": VERSION, "kind": "octree",
                      "params": {"depth": depth},
                      "world": {"digest": world.digest().hex(),
                                "triangles": world.triangle_count,
                                "vertices": len(world.vertices), "name": world.name,
                                "object_names": list(world.object_names)},
                      "fields": writer.fields, "sections": writer.sections}
            text = json.dumps(header, sort_keys=True, separators=(",", ":")).encode("utf-8")
            room = HEADER_SPACE - PREFIX.size
            if len(text) > room:
                raise ValueError(f"partition header of {len(text)} bytes exceeds {room}")
            text += b" " * (room - len(text))  # JSON allows trailing white space
            handle.seek(0)
            handle.write(PREFIX.pack(MAGIC, VERSION, len(text), zlib.crc32(text)) + text)
            handle.flush()
            os.fsync(handle.fileno())
        os.replace(tmp, out)
        clock("checksum")
        node_count = int(tree["level_start"][-1])
        return {"nodes": node_count, "references": total, "chunks": len(starts),
                "bytes": out.stat().st_size, "seconds": clock.seconds,
                "cpu_seconds": clock.cpu}
    finally:
        workers.__exit__()
        shutil.rmtree(spill_root, ignore_errors=True)
        if tmp.exists():
            tmp.unlink()

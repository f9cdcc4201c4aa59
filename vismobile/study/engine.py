"""The study's access to the pipeline: worlds, partitions, cullers and timed frames, cached.

One place that loads a thesis world (building and saving `worlds/<name>.obj` when missing),
builds or reloads a partition (`<cache>/partitions/*.vmp`), and times one frame (cull with
perf_counter, render with the renderer's glFinish timing). Per-process caches keep the last
few worlds and partitions, so a worker running several configurations of a world loads it once.
"""
from __future__ import annotations

import hashlib
import json
import time
from collections import OrderedDict
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..world.camera import Camera
from .matrix import base_structure, structure_params

_WORLDS = OrderedDict()
_PARTITIONS = OrderedDict()
_KEEP = 3


def _remember(cache: OrderedDict, key, value):
    cache[key] = value
    cache.move_to_end(key)
    while len(cache) > _KEEP:
        cache.popitem(last=False)
    return value


def ensure_world_file(name: str, worlds_dir) -> Path:
    """Path of a world argument: worlds_dir/<name>.obj for a thesis world, (re)built when
    missing or stale; any other name is the path of a mesh file, returned as it is."""
    from ..scenes.lookup import world_file

    return world_file(name, worlds_dir)


def load_world(name: str, worlds_dir, repair=None):
    """World of a thesis world name (or a mesh file path), cached per process. A world that
    moves (W7, an animated glTF: scenes.lookup.animated_world) is its rest pose, and
    animated_of(world) is its AnimatedWorld.

    repair : None / "none", or "tjunctions" (files/loader.repaired: the world's T-junctions
             split, `world.repair` set; compare --repair, tune --repair)"""
    from ..files.loader import load_world as load_file
    from ..scenes.lookup import animated_world

    path = ensure_world_file(name, worlds_dir)
    repair = None if repair in (None, "none") else repair
    key = (str(path.resolve()), repair)
    if key in _WORLDS:
        _WORLDS.move_to_end(key)
        return _WORLDS[key]
    world = load_file(path, repair)
    animated = animated_world(name, world, worlds_dir=worlds_dir)
    if animated is not None and repair is not None:  # as play: triangle ids would move
        from ..errors import VisMobileError

        raise VisMobileError(f"{name}: --repair applies to a static world, not to a moving "
                             "one")
    if animated is not None:
        world = animated.world
        _ANIMATED[id(world)] = animated
    return _remember(_WORLDS, key, world)


_ANIMATED = {}  # id(rest world) -> its AnimatedWorld (the rest world is kept by _WORLDS)


def animated_of(world):
    """The AnimatedWorld whose rest world this is, or None for a static world."""
    return _ANIMATED.get(id(world))


@dataclass(frozen=True)
class TimedCamera(Camera):
    """A camera at a time of an animated scene: culls and renders show the pose at `time`."""

    time: float = 0.0


def frame_cameras(world, trajectory, frames, aspect) -> list:
    """The trajectory's cameras at `frames`; for an animated world TimedCameras at
    t = frame / the motion's fps."""
    cameras = [trajectory.camera(f, aspect) for f in frames]
    animated = animated_of(world)
    if animated is None:
        return cameras
    fps = animated.motion.fps
    return [TimedCamera(c.position, c.yaw, c.pitch, c.fov, c.aspect, c.near, c.far,
                        time=float(f) / fps) for c, f in zip(cameras, frames)]


def file_digest(path) -> str:
    """sha256 hex of a file's bytes."""
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def load_structure(world, label: str, cache_dir=None, executor=None, progress=None):
    """Partition of `world` for a structure label ("octree:5", "portal:2+pvs", ...), cached in
    memory and on disk. A "+pvs" label is its base structure (loaded the same way) with the
    PVS baked on it (bake_pvs); the bake's statistics go beside the file (bake_stats).

    executor : optional Dask Client (or process pool) a conservative bake is spread over
    progress : optional callable(done, total) while a PVS bakes
    Returns (partition, build_seconds); build_seconds is 0.0 when it was loaded from the cache.
    """
    from ..partition import load_partition, partition, save_partition

    key = (world.digest().hex()[:16], label)
    if key in _PARTITIONS:
        _PARTITIONS.move_to_end(key)
        return _PARTITIONS[key], 0.0
    animated = animated_of(world)
    if animated is not None:  # its static triangles partitioned, in memory only
        params = structure_params(label)
        if params.get("pvs") is not None:
            raise ValueError(f"{label}: a baked PVS of a world whose objects move is not "
                             "studied (bake its static part with partition)")
        start = time.perf_counter()
        built = partition(animated, label.split(":")[0], **params)
        return _remember(_PARTITIONS, key, built), time.perf_counter() - start
    path = _structure_path(world, label, cache_dir)
    if path is not None and path.is_file():
        try:
            loaded = load_partition(path)
            # a conservative bake cached before the default budget (no budget in its
            # params) holds the exact sets: baked again below
            stale = loaded.params.get("pvs") == "conservative" and "budget" not in loaded.params
            if loaded.world.digest() == world.digest() and not stale:
                return _remember(_PARTITIONS, key, loaded), 0.0
        except Exception:  # unreadable or stale cache file: rebuild it below
            pass
    params = structure_params(label)
    mode = params.pop("pvs", None)
    start = time.perf_counter()
    if mode is None:
        built = partition(world, label.split(":")[0], **params)
    else:
        base, _ = load_structure(world, base_structure(label), cache_dir)
        built, stats = bake_pvs(base, mode, progress=progress,
                                executor=executor if mode == "conservative" else None)
        _BAKES[key] = stats
    seconds = time.perf_counter() - start
    if path is not None:
        path.parent.mkdir(parents=True, exist_ok=True)
        save_partition(built, path)
        if mode is not None:
            from ..files.atomic import atomic_write_bytes

            atomic_write_bytes(path.with_suffix(".bake.json"), json.dumps(stats).encode())
    return _remember(_PARTITIONS, key, built), seconds


_BAKES = {}  # (world digest, label) -> bake statistics, for bakes made in this process


def _structure_path(world, label, cache_dir):
    """<cache>/partitions/<world>-<digest>-<label>.vmp, or None without a cache."""
    if cache_dir is None:
        return None
    name = label.replace(":", "").replace("=", "-")
    return Path(cache_dir) / "partitions" / f"{world.name}-{world.digest().hex()[:16]}-{name}.vmp"


def bake_pvs(base, mode: str, progress=None, jobs: int = 1, executor=None) -> tuple:
    """(a copy of partition `base` with its PVS baked, bake statistics): mode "conservative"
    (partition/pvs.py, spread over `jobs` processes or a Dask `executor`) or "sampled:N"
    (render/pvs_sampled.py, item buffers in the desktop profile's arithmetic). The one bake
    path of the partition command and the study. Statistics: seconds, cells, bytes (the PVS's
    sections in a .vmp), mean_set (mean share of the world in a cell's set)."""
    import copy

    from ..partition.pvs import bake
    from ..partition.pvs_codec import DERIVED, cell_sizes, decode
    from ..partition.store import stored_bytes

    if mode == "conservative":
        extras, stats = bake(base, mode, progress=progress, jobs=jobs, executor=executor)
    elif str(mode).startswith("sampled:") and str(mode)[8:].isdigit():
        from ..device.profile import get_profile
        from ..render.pvs_sampled import bake_sampled

        extras, stats = bake_sampled(base, int(mode[8:]), get_profile("desktop"),
                                     progress=progress)
    else:
        raise ValueError(f"unknown pvs mode {mode!r}; valid: conservative, sampled:N")
    built = copy.copy(base)
    built.extras = {**base.extras, **extras}
    built.params = {**base.params, "pvs": mode}
    if mode == "conservative":  # the budget the bake used (pvs.stored_sets: default 0.25)
        from ..partition.pvs_coarsen import budget_param

        built.params["budget"] = budget_param(base.params.get("budget"))
    cells = len(extras["pvs_cells"])
    sizes = cell_sizes(*decode(extras, cells, base.world.triangle_count), cells)
    summary = {"mode": mode, "seconds": float(stats["seconds"]), "cells": int(len(sizes)),
               "bytes": int(sum(stored_bytes(v) for k, v in extras.items()
                                if k not in DERIVED)),
               "mean_set": float(np.mean(sizes) / max(base.world.triangle_count, 1))
               if len(sizes) else 0.0, "budget": stats.get("budget")}
    return built, summary


def bake_stats(world, label: str, cache_dir=None) -> dict | None:
    """The statistics of the PVS bake behind a "+pvs" structure label (bake_pvs), from this
    process or the cache; None for a label without a PVS or a bake no longer on record."""
    key = (world.digest().hex()[:16], label)
    if key in _BAKES:
        return _BAKES[key]
    path = _structure_path(world, label, cache_dir)
    if path is None or "+" not in label:
        return None
    try:
        return json.loads(path.with_suffix(".bake.json").read_text())
    except (OSError, ValueError):
        return None


def load_chains(world, cache_dir=None):
    """LOD chains of `world` (lod/simplify.build_chains), cached in memory and on disk
    (<cache>/lod/<name>-<digest>.npz, written atomically): a chain is built once per world."""
    import io

    from ..files.atomic import atomic_write_bytes
    from ..lod.chains import FIELDS, PREFIX, LodChains
    from ..lod.simplify import build_chains

    key = ("lod", world.digest().hex()[:16])
    if key in _PARTITIONS:
        return _PARTITIONS[key]
    path = None
    if cache_dir is not None:
        path = Path(cache_dir) / "lod" / f"{world.name}-{key[1]}.npz"
        if path.is_file():
            try:
                with np.load(path) as data:
                    chains = LodChains.from_extras({PREFIX + n: data[n] for n in FIELDS})
                chains.check(world)
                return _remember(_PARTITIONS, key, chains)
            except Exception:  # unreadable or stale cache file: rebuild it below
                pass
    chains = build_chains(world)
    if path is not None:
        buffer = io.BytesIO()
        np.savez(buffer, **{n: getattr(chains, n) for n in FIELDS})
        atomic_write_bytes(path, buffer.getvalue())
    return _remember(_PARTITIONS, key, chains)


def make_culler(partition, stages, profile=None):
    """Culler over partition; with a profile, its arithmetic mode and screen (device_options).
    vfc walks to the thesis's draw nodes (its `cover` off): the device model's per-call term
    was fitted to their count (costmodel.CALIBRATION_ROWS), and the same triangles are sent."""
    from ..culling import Culler, device_options

    options = device_options(profile) if profile else {}
    return Culler(partition, list(stages), vfc={"cover": False}, **options)


def timed_cull(culler, camera) -> tuple:
    """(result, cull_ms) of one cull (a TimedCamera's at its time); a cull that compiled numba
    code is timed again (timing.timed), so no figure holds a compile."""
    from ..timing import timed

    at = getattr(camera, "time", None)
    cull = culler.cull if at is None else (lambda c: culler.cull(c, time=at))
    result, ms, _ = timed(cull, camera)
    return result, ms


def renderer(world, profile):
    """A render.Renderer for the world (imported here: only render/ imports moderngl); for an
    animated world one that poses its moving objects at each TimedCamera's time."""
    from ..render import Renderer

    drawer = Renderer(world, profile)
    animated = animated_of(world)
    if animated is None:
        return drawer
    from ..render.posed import PosedRenderer

    return PosedRenderer(animated, drawer)


def item_buffer_fn(world, profile, cull_back: bool):
    """camera -> (H, W) uint32 item buffer of the whole world (at a TimedCamera's pose)."""
    from ..render import item_buffer_renderer

    ids = np.arange(world.triangle_count)
    item = item_buffer_renderer(world, profile)
    animated = animated_of(world)
    if animated is None:
        return lambda camera: item.render(ids, camera, cull_back)
    from ..render.posed import PosedRenderer

    posed = PosedRenderer(animated, item.renderer)

    def render(camera):
        posed.pose(getattr(camera, "time", None))
        return item.render(ids, camera, cull_back)

    return render


def sent_triangles(result) -> np.ndarray:
    """(S,) int64 sorted unique ids of a cull result."""
    return np.asarray(result.triangles, dtype=np.int64)

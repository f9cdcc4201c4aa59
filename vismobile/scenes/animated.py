"""A thesis world with moving instances of the shipped models (decimated, shared): the animated
worlds of the tests and of tools/bench_dynamic.py (W2 with 1,000 or 10,000 walkers)."""
from __future__ import annotations

import functools

import numpy as np

from ..world.animated import AnimatedWorld
from ..world.motion import Motion, Track
from ..world.world import World

MODELS = ("bunny", "dragon", "lamp", "goblet")
MAX_INSTANCE_TRIANGLES = 1000


@functools.lru_cache(maxsize=None)
def instance_model(kind: str) -> tuple:
    """(vertices (V, 3), triangles (T, 3) int32) of a Table 5.4 object (objects.load_object,
    unit height, base centre at the origin), decimated to at most MAX_INSTANCE_TRIANGLES."""
    from .objects import decimate_exact, load_object, outward

    vertices, triangles = (np.array(a) for a in load_object(kind))  # writable copies
    if len(triangles) > MAX_INSTANCE_TRIANGLES:
        vertices, triangles = decimate_exact(vertices, triangles, MAX_INSTANCE_TRIANGLES)
        triangles = outward(vertices, triangles)
    return np.asarray(vertices, dtype=np.float64), np.asarray(triangles, dtype=np.int32)


def animated_instances(world: World, count: int, seed: int = 0, models=MODELS, keys: int = 4,
                       period: float = 2.0, height: float | None = None,
                       stride: float | None = None) -> AnimatedWorld:
    """world plus `count` moving instances (objects named "<model>_moving_<i>"): each stands
    at a random place in the world's box and walks a looping path through `keys` places, each
    at most `stride` (default 3 heights) from the one before along each axis (one every
    `period` seconds, back to its start), turning about +y; its height `height` (default 1/40
    of the box's largest side). Deterministic in seed."""
    rng = np.random.default_rng(seed)
    low, high = world.extent
    size = float((high - low).max())
    height = size / 40.0 if height is None else float(height)
    step = 3.0 * height if stride is None else float(stride)
    inner_low, inner_high = low + 0.05 * (high - low), high - 0.05 * (high - low)
    parts, tracks = [world], []
    base = len(world.object_names)
    vertices, triangles, names, ids, offset = [], [], [], [], 0
    for i in range(count):
        kind = models[i % len(models)]
        v, t = instance_model(kind)
        start = rng.uniform(inner_low, inner_high)
        start[1] = rng.uniform(low[1], max(low[1], high[1] - height))
        vertices.append(v * height + start)
        triangles.append(t + offset)
        ids.append(np.full(len(t), i, dtype=np.int32))
        names.append(f"{kind}_moving_{i}")
        offset += len(v)
        steps = rng.uniform(-step, step, size=(keys, 3))
        steps[0] = 0.0
        places = np.clip(start + np.cumsum(steps, axis=0), inner_low,
                         np.maximum(inner_low, inner_high - [0, height, 0]))
        times = np.arange(keys + 1) * period
        moves = np.vstack([places, places[:1]]) - start
        yaw = np.concatenate([[0.0], rng.uniform(-np.pi, np.pi, keys - 1), [0.0]])
        quats = np.stack([np.zeros_like(yaw), np.sin(yaw / 2), np.zeros_like(yaw),
                          np.cos(yaw / 2)], axis=1)
        tracks.append(Track(base + i, translation=(times, moves), rotation=(times, quats),
                            loop=True, pivot=tuple(start)))
    if count:
        parts.append(World(np.concatenate(vertices), np.concatenate(triangles),
                           np.concatenate(ids), names, "instances"))
    whole = World.concatenate(parts, name=f"{world.name}+{count}moving")
    return AnimatedWorld(whole, Motion(tracks))

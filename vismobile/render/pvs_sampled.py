"""Sampled PVS, labelled aggressive: each view cell's set is what item buffers show from N
jittered points inside it (six 90-degree faces of a cube map per point), the way an
artist-facing bake does it. It can miss what no sample point sees (thin gaps, far corners of a
cell): its misses are measured along the paths, never assumed away (tools/bench_pvs.py).

Same storage as the conservative bake (partition/pvs.py: pvs_cells, pvs_shape, pvs_pack,
pvs_grow), so the `pvs` stage looks it up alike; the partition's params say pvs="sampled:N".
View cells: the portal structure's cells, the grid's cells, or else an automatic grid over the
world's box (AUTO_CELLS per horizontal axis, AUTO_LAYERS layers).
"""
from __future__ import annotations

import dataclasses
import time

import numpy as np

from ..partition.pvs_codec import encode
from ..world.camera import Camera
from .item_buffer import SENTINEL, item_buffer

FACES = ((0.0, 0.0), (90.0, 0.0), (180.0, 0.0), (270.0, 0.0), (0.0, 89.999), (0.0, -89.999))
AUTO_CELLS, AUTO_LAYERS = 8, 2
RESOLUTION = 128  # cube face pixels per side


def view_cells(partition) -> np.ndarray:
    """(V, 2, 3) float64 view-cell boxes (module docstring)."""
    x = partition.extras or {}
    if "cell_bounds" in x:
        return np.asarray(x["cell_bounds"], dtype=np.float64)
    if all(f"grid_{a}" in x for a in "xyz"):
        edges = [np.asarray(x[f"grid_{a}"], dtype=np.float64) for a in "xyz"]
    else:
        low, high = partition.world.extent
        counts = (AUTO_CELLS, AUTO_LAYERS, AUTO_CELLS)
        edges = [np.linspace(low[a], high[a], counts[a] + 1) for a in range(3)]
    lo = np.stack(np.meshgrid(edges[0][:-1], edges[1][:-1], edges[2][:-1], indexing="ij"), -1)
    hi = np.stack(np.meshgrid(edges[0][1:], edges[1][1:], edges[2][1:], indexing="ij"), -1)
    return np.stack([lo.reshape(-1, 3), hi.reshape(-1, 3)], axis=1)


def seen_from(world, points, cube) -> np.ndarray:
    """(T,) bool: the triangles the item buffers of the cube profile show from the points (P, 3),
    six 90-degree faces each, no back-face culling; what sampling sees, so it errs toward
    missing what no point shows."""
    seen = np.zeros(world.triangle_count, dtype=bool)
    for point in points:
        for yaw, pitch in FACES:
            cam = Camera(point, yaw=yaw, pitch=pitch, fov=90.0, aspect=1.0, near=0.01)
            ids = np.unique(item_buffer(world, None, cam, cube, cull_back=False))
            seen[ids[ids != SENTINEL].astype(np.int64)] = True
    return seen


def bake_sampled(partition, samples: int, profile, seed: int = 0, progress=None) -> tuple:
    """(extras, stats) of the sampled PVS with `samples` jittered points per view cell.

    profile : the device profile whose arithmetic the item buffers use (its resolution is
              replaced by RESOLUTION x RESOLUTION, square faces)
    """
    if int(samples) < 1:
        raise ValueError(f"pvs=sampled:N needs N >= 1 sample points per cell, got {samples}")
    began = time.perf_counter()
    world = partition.world
    cube = dataclasses.replace(profile, resolution=(RESOLUTION, RESOLUTION))
    cells = view_cells(partition)
    rng = np.random.default_rng(seed)
    masks = []
    for c, (lo, hi) in enumerate(cells):
        # stratified along the cell's longest axis, jittered in all three
        points = lo + rng.uniform(0.0, 1.0, (int(samples), 3)) * (hi - lo)
        longest = int(np.argmax(hi - lo))
        points[:, longest] = lo[longest] + (np.arange(samples) + rng.uniform(0, 1, samples)) \
            / samples * (hi[longest] - lo[longest])
        masks.append(seen_from(world, points, cube))
        if progress is not None:
            progress(c + 1, len(cells))
    extras = {"pvs_cells": cells.copy(), **encode(cells, masks),
              "pvs_grow": np.array([0.0])}  # no growth: the stage knows it is sampled
    return extras, {"seconds": time.perf_counter() - began, "cells": len(cells),
                    "renders": len(cells) * int(samples) * len(FACES)}

"""Triangle meshes of a heightmap: the regular grid at a stride, and the terrain as a World."""
from __future__ import annotations

import numpy as np

from .heightmap import Heightmap


def grid_triangles(cells: int) -> np.ndarray:
    """(2 * cells^2, 3) int32 triangles of a (cells+1)^2 vertex grid (row-major vertex ids).

    Uses the heightmap's diagonal (i, j)-(i+1, j+1); counter-clockwise seen from +y.
    """
    n = cells + 1
    i, j = np.meshgrid(np.arange(cells), np.arange(cells), indexing="ij")
    v00 = (i * n + j).ravel()
    v01, v10, v11 = v00 + 1, v00 + n, v00 + n + 1
    upper = np.stack([v00, v11, v01], axis=1)
    lower = np.stack([v00, v10, v11], axis=1)
    return np.stack([upper, lower], axis=1).reshape(-1, 3).astype(np.int32)


def grid_mesh(heightmap: Heightmap, stride: int = 1) -> tuple:
    """(vertices (V, 3) float64, triangles (T, 3) int32) of the heightmap sampled every stride.

    stride must divide N - 1 (a power of two up to N - 1); stride 1 is the full mesh of
    2 * (N - 1)^2 triangles.
    """
    cells = (heightmap.size - 1) // stride
    if stride < 1 or cells * stride != heightmap.size - 1:
        raise ValueError(f"stride {stride} does not divide {heightmap.size - 1}")
    index = np.arange(0, heightmap.size, stride)
    i, j = np.meshgrid(index, index, indexing="ij")
    h = heightmap.heights[i, j].astype(np.float64)
    vertices = np.stack([j * heightmap.spacing, h, i * heightmap.spacing], axis=-1).reshape(-1, 3)
    return vertices, grid_triangles(cells)


def terrain_world(heightmap: Heightmap, placement=None, stride: int = 1):
    """World of the ground mesh (object "terrain") plus every placed object.

    Any command that takes a World can then cull and draw a terrain. At stride 1 a 1025^2 map is
    2.1 M triangles; pass a larger stride for a lighter stand-in.
    """
    from ..world.world import World

    vertices, triangles = grid_mesh(heightmap, stride)
    parts = [World(vertices, triangles, np.zeros(len(triangles), np.int32), ["terrain"],
                   heightmap.name)]
    if placement is not None:
        for index, (v, t) in enumerate(placement.meshes()):
            parts.append(World(v, t, np.zeros(len(t), np.int32),
                               [f"{placement.kinds[index]}{index}"], heightmap.name))
    world = World.concatenate(parts, heightmap.name) if len(parts) > 1 else parts[0]
    return world


MAX_WORLD_TRIANGLES = 1 << 19  # ground triangles of a terrain loaded as a World


def terrain_world_file(path, max_triangles: int = MAX_WORLD_TRIANGLES):
    """World of a .vmt terrain for the triangle-world commands: the ground at the finest
    stride that stays within max_triangles (a 1025^2 map at stride 2: 524,288), plus its
    objects. WorldError names the file when it cannot be read."""
    from . import store

    heightmap, placement = store.load(path)
    stride = 1
    while 2 * ((heightmap.size - 1) // stride) ** 2 > max_triangles and stride < heightmap.size - 1:
        stride *= 2
    world = terrain_world(heightmap, placement if len(placement) else None, stride)
    world.name = str(path).rsplit("/", 1)[-1].rsplit(".", 1)[0]
    return world

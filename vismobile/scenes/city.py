"""World 5: a city of 3 x 3 blocks of 4 x 4 buildings on a ground plane (thesis §5.2, CityGen-like).

Buildings are closed boxes (no bottom) wound outward, each turned by its own yaw inside its
lot and given its own height, so none are aligned. The ground faces up. Units are metres.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .surfaces import MeshCollector, fan_split, quad, tiled_rect

BLOCKS = 3  # per side
LOTS = 4  # buildings per block side
LOT = 15.0  # lot pitch
STREET = 20.0  # street width between blocks
MARGIN = 40.0  # ground beyond the outer streets' edge
GROUND_TILES = 23  # per side
SEED = 20080502


@dataclass(frozen=True)
class Building:
    centre: tuple  # (x, z) of the footprint centre
    size: tuple  # (width, depth)
    yaw: float  # degrees about +y
    height: float

    def corners(self) -> np.ndarray:
        """(4, 2) float64 footprint corners (x, z), counter-clockwise seen from above."""
        a = np.radians(self.yaw)
        u = np.array([np.cos(a), -np.sin(a)]) * self.size[0] / 2
        v = np.array([np.sin(a), np.cos(a)]) * self.size[1] / 2
        c = np.asarray(self.centre)
        return np.array([c - u - v, c + u - v, c + u + v, c - u + v])


def block_origin(i: int) -> float:
    """Lower x (or z) edge of block i."""
    return i * (LOTS * LOT + STREET)


def city_extent() -> tuple:
    """(low, high) of the ground square along x and z."""
    return -MARGIN, block_origin(BLOCKS - 1) + LOTS * LOT + MARGIN


def make_buildings(seed: int = SEED) -> list:
    """The 144 buildings, deterministic for a seed."""
    rng = np.random.default_rng(seed)
    buildings = []
    for bx in range(BLOCKS):
        for bz in range(BLOCKS):
            for i in range(LOTS):
                for j in range(LOTS):
                    size = rng.uniform(6.0, 10.0, 2)
                    slack = (LOT - np.hypot(*size)) / 2  # turning keeps it inside the lot
                    centre = (block_origin(bx) + LOT * (i + 0.5) + rng.uniform(-slack, slack),
                              block_origin(bz) + LOT * (j + 0.5) + rng.uniform(-slack, slack))
                    buildings.append(Building(tuple(centre), tuple(size),
                                              float(rng.uniform(0.0, 90.0)),
                                              float(rng.uniform(8.0, 45.0))))
    return buildings


def building_mesh(building: Building) -> tuple:
    """(vertices, triangles) of one building: 4 walls and a roof, 10 triangles, wound outward."""
    corners = building.corners()
    parts = []
    centre = np.array([building.centre[0], 0.0, building.centre[1]])
    for k in range(4):
        (x0, z0), (x1, z1) = corners[k], corners[(k + 1) % 4]
        wall = [(x0, 0.0, z0), (x1, 0.0, z1), (x1, building.height, z1), (x0, building.height, z0)]
        middle = np.mean(wall, axis=0)
        parts.append(quad(wall, middle - [centre[0], middle[1], centre[2]]))
    parts.append(quad([(x, building.height, z) for x, z in corners], (0.0, 1.0, 0.0)))
    offsets = np.cumsum([0] + [len(p[0]) for p in parts[:-1]])
    return (np.concatenate([p[0] for p in parts]),
            np.concatenate([p[1] + o for p, o in zip(parts, offsets)]))


def build_city(target: int | None = 2548, seed: int = SEED):
    """World 5 as (World, buildings); ground quads are fan-split to reach `target` exactly.

    Raises ValueError when the target is odd, below the base count or beyond the ground's reach.
    """
    buildings = make_buildings(seed)
    mesh = MeshCollector()
    for index, building in enumerate(buildings):
        mesh.add(f"building_{index:03d}", *building_mesh(building))
    low, high = city_extent()
    ground = tiled_rect((low, 0.0, low), (high - low, 0.0, 0.0), (0.0, 0.0, high - low),
                        GROUND_TILES, GROUND_TILES, (0.0, 1.0, 0.0))
    extra = 0 if target is None else target - mesh.triangle_count - len(ground[1])
    if extra < 0 or extra % 2 or extra // 2 > len(ground[1]) // 2:
        raise ValueError(f"city base {mesh.triangle_count + len(ground[1])} cannot reach {target}")
    # Spread the split quads over the ground with a fixed stride so density stays even.
    order = np.argsort((np.arange(len(ground[1]) // 2) * 7919) % (len(ground[1]) // 2), kind="stable")
    half = len(ground[1]) // 2
    pairs = np.concatenate([order, order + half])
    reordered = ground[1][np.concatenate([pairs[:half], pairs[half:]])]
    mesh.add("ground", *fan_split(ground[0], reordered, extra // 2))
    return mesh.world("w5"), buildings

"""Objects standing on a terrain: which shared model, where, how big, turned how far."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import WorldError

MAX_OBJECTS = 200  # up to 5,288 triangles each (flower): 1,000 flowers took 4 GB and 97 s in info
FOOTPRINT_SAMPLES = 5  # per side: the base sits at the lowest ground point under its footprint


@dataclass(frozen=True)
class Placement:
    """K placed objects.

    kinds     : tuple of K model kinds (keys of scenes.objects.OBJECTS)
    positions : (K, 3) float64 base centres (y = ground under the footprint)
    yaws      : (K,) float64 degrees about +y
    heights   : (K,) float64 world units
    """

    kinds: tuple
    positions: np.ndarray
    yaws: np.ndarray
    heights: np.ndarray

    @classmethod
    def empty(cls) -> "Placement":
        return cls((), np.zeros((0, 3)), np.zeros(0), np.zeros(0))

    def __len__(self) -> int:
        return len(self.kinds)

    def boxes(self) -> np.ndarray:
        """(K, 2, 3) float64 exact bounding boxes of the placed meshes."""
        if not len(self):
            return np.zeros((0, 2, 3))
        return np.stack([np.stack([v.min(axis=0), v.max(axis=0)]) for v, _ in self.meshes()])

    def to_json(self) -> list:
        return [{"kind": k, "position": [float(c) for c in p], "yaw": float(y), "height": float(h)}
                for k, p, y, h in zip(self.kinds, self.positions, self.yaws, self.heights)]

    @classmethod
    def from_json(cls, records, path="<json>") -> "Placement":
        from ..scenes.objects import OBJECTS

        if not records:
            return cls.empty()
        try:
            kinds = tuple(str(r["kind"]) for r in records)
            positions = np.array([r["position"] for r in records], dtype=np.float64).reshape(-1, 3)
            yaws = np.array([r["yaw"] for r in records], dtype=np.float64)
            heights = np.array([r["height"] for r in records], dtype=np.float64)
        except (KeyError, TypeError, ValueError) as error:
            raise WorldError(path, f"bad object record ({error})") from None
        unknown = sorted(set(kinds) - set(OBJECTS))
        if unknown:
            raise WorldError(path, f"unknown object kind(s) {', '.join(unknown)}")
        return cls(kinds, positions, yaws, heights)

    def meshes(self) -> list:
        """[(vertices (V,3) float64, triangles (T,3) int32)] per object, scaled and placed."""
        from ..scenes.objects import placed

        return [placed(k, h, p, y) for k, p, y, h in
                zip(self.kinds, self.positions, self.yaws, self.heights)]


def place_objects(heightmap, count: int, seed: int = 0, height: float | None = None,
                  kinds=None) -> Placement:
    """count objects at seeded random spots, each standing on the lowest ground under it.

    height : object height in world units (default 8 sample spacings)
    kinds  : model kinds to cycle through (default: every Table 5.4 object)
    """
    from ..scenes.objects import OBJECTS

    if not 0 <= count <= MAX_OBJECTS:
        raise ValueError(f"object count must be from 0 to {MAX_OBJECTS}, got {count}")
    kinds = tuple(kinds or OBJECTS)
    height = float(height if height is not None else 8 * heightmap.spacing)
    rng = np.random.default_rng(seed)
    margin = height
    xz = rng.uniform(margin, heightmap.extent - margin, (count, 2))
    offsets = np.linspace(-0.5 * height, 0.5 * height, FOOTPRINT_SAMPLES)
    ox, oz = np.meshgrid(offsets, offsets)
    ground = heightmap.height_at(xz[:, 0, None] + ox.ravel(), xz[:, 1, None] + oz.ravel()).min(axis=1)
    positions = np.c_[xz[:, 0], ground, xz[:, 1]]
    chosen = tuple(kinds[i % len(kinds)] for i in range(count))
    yaws = rng.uniform(0.0, 360.0, count)
    return Placement(chosen, positions, yaws, np.full(count, height))

"""Generate a world larger than memory: W2 tiled on a grid plus instanced dragons, streamed into
a world directory (mapped.py) one tile at a time. Not committed: it is regenerated on demand.

Usage: .venv/bin/python tools/make_big_world.py [--triangles 20000000] [--out out/big20m]
       [--dragons 4]
Each tile is W2 (102,547 triangles, 40 x 6 x 32 m) moved by a 44 x 36 m pitch; each tile also
gets --dragons instances of the 1,500-triangle dragon, 0.7 m tall, at seeded spots on the
ground floor. Tiles fill the grid row by row until the triangle count is reached. The W2
indoor trajectory, moved to the centre tile, walks it (tools/bench_outofcore.py).
"""
from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from vismobile.world.mapped import write_world_dir  # noqa: E402
from vismobile.scenes import build_world  # noqa: E402
from vismobile.scenes.objects import placed  # noqa: E402

PITCH = (44.0, 36.0)  # tile spacing on x and z: W2's 40.2 x 32.2 m plus a street
SEED = 16


def layout(triangles: int, per_tile: int) -> tuple:
    """(tile count, columns) for at least `triangles` triangles, on a near-square grid."""
    tiles = max(1, math.ceil(triangles / per_tile))
    return tiles, math.ceil(math.sqrt(tiles))


def tile_offset(index: int, columns: int) -> np.ndarray:
    """(3,) offset of tile `index` (row-major)."""
    return np.array([index % columns * PITCH[0], 0.0, index // columns * PITCH[1]])


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--triangles", type=int, default=20_000_000)
    parser.add_argument("--out", type=Path, default=ROOT / "out" / "big20m")
    parser.add_argument("--dragons", type=int, default=4, help="instanced dragons per tile")
    args = parser.parse_args(argv)
    base = build_world("w2")
    dragon_v, dragon_t = placed("dragon", 0.7, (0.0, 0.0, 0.0))
    per_tile = base.triangle_count + args.dragons * len(dragon_t)
    tiles, columns = layout(args.triangles, per_tile)
    names = list(base.object_names) + ["dragon"]
    low, high = base.extent
    rng = np.random.default_rng(SEED)
    spots = rng.uniform([low[0] + 1, 0, low[2] + 1], [high[0] - 1, 0, high[2] - 1],
                        (tiles, args.dragons, 3))
    turns = np.radians(rng.uniform(0, 360, (tiles, args.dragons)))

    def parts():
        for k in range(tiles):
            offset = tile_offset(k, columns)
            yield (base.vertices + offset).astype(np.float32), base.triangles, base.object_ids
            for spot, turn in zip(spots[k], turns[k]):
                c, s = math.cos(turn), math.sin(turn)
                rotation = np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])
                yield ((dragon_v @ rotation.T + spot + offset).astype(np.float32), dragon_t,
                       np.full(len(dragon_t), len(names) - 1, dtype=np.int32))

    start = time.perf_counter()
    nv, nt = write_world_dir(args.out, parts, f"big{tiles}", names)
    print(f"{args.out}: {nt:,} triangles, {nv:,} vertices, {tiles} tiles of W2 ({columns} "
          f"columns) + {tiles * args.dragons} dragons, {time.perf_counter() - start:.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())

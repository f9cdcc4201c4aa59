"""Tiled W2 worlds for the scaling benchmarks (issue 10): W2 repeated on an n x n grid, generated
on demand and never committed (3 x 3 = 922,923 triangles, 7 x 7 = 5,024,803).

    .venv/bin/python tools/tile_world.py 3 [--out out/w2x3]   # also writes a world directory

Tiles use tools/make_big_world.py's pitch (44 x 36 m: W2's 40.2 x 32.2 m plus a street), without
its dragons; the W2 indoor trajectory moved to the centre tile (`centre_offset`) gives the same
views as on W2, with the other tiles around them (tools/bench_cull.py --tiled 3,7).
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tools"))

from make_big_world import tile_offset  # noqa: E402
from vismobile.scenes import build_world  # noqa: E402
from vismobile.world.world import World  # noqa: E402


def tiled_w2(n: int, base: World | None = None) -> World:
    """W2 on an n x n grid (row-major tiles, make_big_world's pitch), one in-memory World."""
    if n < 1:
        raise ValueError(f"tile count per side must be >= 1, got {n}")
    base = build_world("w2") if base is None else base
    count = n * n
    offsets = np.stack([tile_offset(k, n) for k in range(count)])
    vertices = (base.vertices[None] + offsets[:, None]).reshape(-1, 3)
    triangles = (base.triangles[None] + (np.arange(count) * len(base.vertices))[:, None, None])
    ids = (base.object_ids[None] + (np.arange(count) * len(base.object_names))[:, None])
    names = [f"t{k}_{name}" for k in range(count) for name in base.object_names]
    return World(vertices, triangles.reshape(-1, 3), ids.ravel(), names, f"w2x{n}")


def centre_offset(n: int) -> np.ndarray:
    """(3,) offset of the centre tile of an n x n grid (where the W2 trajectory is moved to)."""
    return tile_offset((n // 2) * n + n // 2, n)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("n", type=int, help="tiles per side (3: 923k triangles, 7: 5.0M)")
    parser.add_argument("--out", type=Path, default=None, help="write a world directory here")
    args = parser.parse_args(argv)
    if args.n < 1:
        print(f"tile_world: tiles per side must be >= 1, got {args.n}", file=sys.stderr)
        return 2
    start = time.perf_counter()
    world = tiled_w2(args.n)
    print(f"{world.name}: {world.triangle_count:,} triangles, {len(world.vertices):,} vertices, "
          f"{time.perf_counter() - start:.1f} s; centre tile offset {centre_offset(args.n)}")
    if args.out is not None:
        from vismobile.world.mapped import write_world_dir

        def parts():
            yield (world.vertices.astype(np.float32), world.triangles, world.object_ids)

        write_world_dir(args.out, parts, world.name, list(world.object_names))
        print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

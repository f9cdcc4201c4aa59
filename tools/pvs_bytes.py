"""The PVS's bytes per world (issue 29's storage target: at most 0.25x the OBJ), measured on
saved bakes, so the codec can be compared without baking again.

    .venv/bin/python tools/pvs_bytes.py [--worlds w5,w6,w1,w2] [--repair tjunctions]
                                        [--cache DIR] [--jobs 2]

Per world: the portal structure (depth 2) with pvs=conservative, baked once and saved as
DIR/NAME[-repaired].vmp (bakes take 1-9 minutes on the shared machine; the file is reused).
Printed: view cells, triangles, patterns; the PVS's bytes in the .vmp (the file with its PVS
minus the file without), per cell and against the OBJ; what the same sets took in the older
layouts, computed here: layout 1 (pattern bitsets and ids under zlib level 9, the boxes as
the .vmp stores a float array) and those bitsets and ids under lzma instead; the encode and
decode seconds (after a warm-up); and a check that the decoded sets and boxes are the baked
ones exactly (so what `pvs` sends and drops is unchanged).
"""
from __future__ import annotations

import argparse
import copy
import lzma
import os
import sys
import time
import zlib
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from vismobile.partition import load_partition, partition, save_partition  # noqa: E402
from vismobile.partition import pvs_codec  # noqa: E402
from vismobile.partition.store import stored_bytes, to_bytes  # noqa: E402
from vismobile.scenes import build_world  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]


def baked(name, repair, cache, jobs):
    """The world and its portal:2 partition with a conservative PVS of the exact sets
    (budget=none: the codec and pvs_budget.py's coarsening start from them), from cache or
    baked."""
    world = build_world(name)
    if repair == "tjunctions":
        from vismobile.world.tjunctions import repair_tjunctions

        world, _ = repair_tjunctions(world)
    path = Path(cache) / f"{name}{'-repaired' if repair == 'tjunctions' else ''}.vmp"
    if path.exists():
        try:
            part = load_partition(path, world)
            if part.params.get("budget") == "none":  # older files: their sets may be coarsened
                return world, part
            print(f"{path}: not an exact bake (budget=none); baking again", flush=True)
        except Exception as error:  # an older layout: bake again
            print(f"{path}: {error}; baking again", flush=True)
    from vismobile.partition.pvs import bake

    part = partition(world, "portal", depth=2)
    part.params["budget"] = "none"  # the exact sets, as partition(..., budget="none") bakes
    began = time.perf_counter()
    extras, _ = bake(part, jobs=jobs)
    print(f"{name}: baked in {time.perf_counter() - began:.1f} s", flush=True)
    part.extras.update(extras)
    part.params["pvs"] = "conservative"
    path.parent.mkdir(parents=True, exist_ok=True)
    save_partition(part, path)
    return world, part


def layout1_bytes(boxes, patterns, ids, compress) -> int:
    """Bytes of the same sets in layout 1 (float boxes as the store keeps them, pattern
    bitsets plus narrowest ids, compressed), section padding aside."""
    rows = np.ascontiguousarray(patterns).view(np.dtype((np.void, patterns.shape[1]))).ravel()
    order = np.argsort(rows, kind="stable")  # layout 1 numbered them in np.unique's order
    rank = np.empty(len(order), dtype=np.int64)
    rank[order] = np.arange(len(order))
    size = next(b for b in (1, 2, 4) if len(patterns) <= 1 << (8 * b))
    data = patterns[order].tobytes() + rank[ids].astype(f"<u{size}").tobytes()
    return stored_bytes(boxes) + len(compress(data)) + 24


def run(name, repair, cache, jobs):
    world, part = baked(name, repair, cache, jobs)
    triangles = world.triangle_count
    pvs_codec._CACHE.clear()
    boxes, patterns, ids = pvs_codec.decode_all(part.extras, triangles)
    cells = len(boxes)
    masks = np.unpackbits(patterns, axis=1, count=cells)[ids].T.astype(bool)
    plain = copy.copy(part)
    plain.extras = {k: v for k, v in part.extras.items() if not k.startswith("pvs_")}
    pvs_bytes = len(to_bytes(part)) - len(to_bytes(plain))
    obj = os.path.getsize(ROOT / "worlds" / f"{name}.obj")
    encode_s, decode_s = [], []
    for _ in range(2):  # the first of each compiles numba's kernels (cache=True)
        began = time.perf_counter()
        again = pvs_codec.encode(boxes, masks)
        encode_s.append(time.perf_counter() - began)
        pvs_codec._CACHE.clear()
        began = time.perf_counter()
        got = pvs_codec.decode_all(again, triangles)
        decode_s.append(time.perf_counter() - began)
    same = all(np.array_equal(part.extras[k], again[k]) for k in again) \
        and np.array_equal(got[0], boxes) and np.array_equal(got[1], patterns) \
        and np.array_equal(got[2], ids)
    zlibbed = layout1_bytes(boxes, patterns, ids, lambda b: zlib.compress(b, 9))
    lzmad = layout1_bytes(boxes, patterns, ids,
                          lambda b: lzma.compress(b, preset=9 | lzma.PRESET_EXTREME))
    side = int(part.extras["pvs_shape"][-1])
    label = name + (" (repaired)" if repair == "tjunctions" else "")
    print(f"{label}: {cells} cells, {triangles} triangles, {len(patterns)} patterns; PVS "
          f"{pvs_bytes / 1e3:.1f} KB in the .vmp = {pvs_bytes / obj:.3f}x the OBJ "
          f"({obj / 1e3:.1f} KB), {pvs_bytes / cells:.1f} B per cell (side stream "
          f"{side / 1e3:.1f} KB, pattern bits {(len(part.extras['pvs_pack']) - side) / 1e3:.1f}"
          f" KB) | layout 1 (zlib) {zlibbed / 1e3:.1f} KB = {zlibbed / obj:.3f}x, its bitsets "
          f"under lzma {lzmad / 1e3:.1f} KB = {lzmad / obj:.3f}x | encode {encode_s[-1]:.2f} s,"
          f" decode {decode_s[-1]:.3f} s | round trip exact: {same}", flush=True)
    return same


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--worlds", default="w5,w6,w1,w2")
    parser.add_argument("--repair", default="none", choices=("none", "tjunctions"))
    parser.add_argument("--cache", default=os.path.join(os.environ.get("TMPDIR", "/tmp"),
                                                        "vismobile-pvs-bytes"))
    parser.add_argument("--jobs", type=int, default=2)
    args = parser.parse_args(argv)
    ok = [run(w, args.repair, args.cache, args.jobs) for w in args.worlds.split(",")]
    return 0 if all(ok) else 1


if __name__ == "__main__":
    sys.exit(main())

"""Benchmark: level of detail on a thesis world's path, against the full-detail frames.

Usage: .venv/bin/python tools/bench_lod.py [--world w2] [--trajectory trajectories/indoor.csv]
       [--structure octree:5] [--cull vfc+occlusion+tbfc] [--tau 1] [--stride 1]
       [--profile ipaq-hx2490b] [--vmp runs/w2-lod.vmp]

Per frame, in one process: cull (timed), select the levels (timed), draw the full-detail frame
of the culled triangles and the level-of-detail frame, compare them (PSNR, largest difference,
fraction changed), and at tau = 0 check the frame is bit-identical. Prints triangles sent with
and without LOD (sum and ratio), PSNR min / mean, median selection and cull ms and their ratio,
and the chains' build time, levels and bytes. --vmp keeps the partition with its chains
(built on the first run, loaded after).

Targets (issue 27): W2 indoor at tau = 1 px, vfc+occlusion+tbfc: LOD sends <= 0.5x, PSNR >=
40 dB on every frame; selection <= 0.1x the cull time; tau = 0 bit-exact.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from vismobile.lod import LodChains, image_error  # noqa: E402
from vismobile.lod.simplify import build_chains  # noqa: E402
from vismobile.partition import load_partition, save_partition  # noqa: E402
from vismobile.app.playback import Scene, load_scene, make_culler, parse_stages  # noqa: E402
from vismobile.device.profile import get_profile  # noqa: E402
from vismobile.render.lod_view import LodView  # noqa: E402
from vismobile.world.trajectory import Trajectory  # noqa: E402


def scene_with_chains(args):
    if args.vmp and Path(args.vmp).exists():
        tree = load_partition(args.vmp)
        return Scene(tree.world, tree, args.structure), None
    scene = load_scene(args.world, args.structure)
    start = time.perf_counter()
    chains = build_chains(scene.world)
    built = time.perf_counter() - start
    scene.partition.extras.update(chains.to_extras())
    if args.vmp:
        Path(args.vmp).parent.mkdir(parents=True, exist_ok=True)
        save_partition(scene.partition, args.vmp)
    return scene, built


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--world", default="w2")
    parser.add_argument("--trajectory", default=str(ROOT / "trajectories" / "indoor.csv"))
    parser.add_argument("--structure", default="octree:5")
    parser.add_argument("--cull", default="vfc+occlusion+tbfc")
    parser.add_argument("--tau", type=float, default=1.0)
    parser.add_argument("--stride", type=int, default=1)
    parser.add_argument("--profile", default="ipaq-hx2490b")
    parser.add_argument("--vmp", default=None)
    args = parser.parse_args()

    profile = get_profile(args.profile)
    scene, built = scene_with_chains(args)
    chains = LodChains.from_extras(scene.partition.extras)
    world = scene.world
    print(f"{world.name}: {world.triangle_count:,} triangles, chains: {chains.level_count} levels "
          f"of {len(set(chains.level_object.tolist()))} objects, {chains.triangle_count:,} level "
          f"triangles, {chains.nbytes / 1e6:.2f} MB"
          + (f", built in {built:.1f} s" if built is not None else " (loaded)"))
    memory = profile.estimate_memory(world, scene.partition)
    print(f"heap: total {memory['total'] / 2**20:.2f} MiB of {profile.heap_bytes / 2**20:.0f} MiB "
          f"(partition with chains {memory['partition'] / 2**20:.2f} MiB, level buffers "
          f"{memory['lod_buffers'] / 2**20:.2f} MiB)")
    culler = make_culler(scene, parse_stages(args.cull), profile)
    view = LodView(world, chains, profile, args.tau)
    exact = LodView(world, chains, profile, 0.0)
    trajectory = Trajectory.load(args.trajectory)
    frames = range(0, len(trajectory), max(args.stride, 1))
    for f in list(frames)[:3]:  # warm-up: numba compiles, first uploads
        camera = trajectory.camera(f, profile.aspect)
        view.draw(culler.cull(camera).triangles, camera)
    culler = make_culler(scene, parse_stages(args.cull), profile)
    full, sent, psnr, cull_ms, lod_ms, worst, changed = 0, 0, [], [], [], 0, []
    bit_exact = True
    for f in frames:
        camera = trajectory.camera(f, profile.aspect)
        start = time.perf_counter()
        culled = culler.cull(camera)
        cull_ms.append((time.perf_counter() - start) * 1000.0)
        frame = view.draw(culled.triangles, camera, bool(culled.cull_back))
        lod_ms.append(frame.lod_ms)
        full += frame.full_triangles
        sent += frame.drawn.triangles
        psnr.append(frame.error["psnr_db"])
        worst = max(worst, frame.error["max_diff"])
        changed.append(frame.error["changed"])
        zero = exact.draw(culled.triangles, camera, bool(culled.cull_back))
        bit_exact &= zero.error["max_diff"] == 0 and zero.drawn.triangles == len(culled.triangles)
    psnr = np.asarray(psnr)
    finite = psnr[np.isfinite(psnr)]
    mse = np.where(np.isfinite(psnr), 255.0 ** 2 / 10 ** (psnr / 10), 0.0).mean()
    print(f"{len(psnr)} frames of {args.trajectory} (stride {args.stride}), {args.structure}, "
          f"{args.cull}, tau {args.tau:g} px")
    print(f"triangles sent: full {full:,}, lod {sent:,}, ratio {sent / max(full, 1):.3f}")
    print(f"PSNR: min {finite.min() if len(finite) else float('inf'):.2f} dB, mean (of the "
          f"mean MSE) {10 * np.log10(255 ** 2 / mse) if mse > 0 else float('inf'):.2f} dB, "
          f"frames identical {int(np.isinf(psnr).sum())}, largest difference {worst}, "
          f"pixels changed mean {np.mean(changed):.4f}")
    ratio = np.median(lod_ms) / np.median(cull_ms)
    print(f"selection median {np.median(lod_ms):.3f} ms, cull median {np.median(cull_ms):.3f} "
          f"ms, ratio {ratio:.3f} (per frame: median of selection/cull "
          f"{np.median(np.asarray(lod_ms) / np.asarray(cull_ms)):.3f})")
    print(f"tau = 0 bit-exact on every frame: {bool(bit_exact)}")


if __name__ == "__main__":
    main()

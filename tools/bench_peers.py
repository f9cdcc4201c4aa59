"""Peers. Terrain (default): the engine's terrain methods against the PyPI peers pymartini and
pydelatin (issue 15): triangles vs largest error vs PSNR along the fast lemniscate, each peer at
equal triangles and at equal (world) error to each method and knob value. Occlusion (--moc):
`vfc,occlusion,tbfc` with the profile's screen against Intel's Masked Occlusion Culling driven
hierarchically (tools/moc_peer.py), same cameras, same process, interleaved frame by frame
(issue 32): time, sent / visible, frames and triangles dropped against the item buffer.

    .venv/bin/python tools/bench_peers.py [--size 1025] [--frames 3] [--taus 0.5,1,4]
        [--methods tiles,roettger,roam] [--out runs/bench_peers.md]
    .venv/bin/python tools/bench_peers.py --moc [--worlds w2,w2x3,w2x7] [--frames 150]
        [--start 300] [--out runs/bench_peers_moc.md]

Terrain needs the optional extra: pip install 'vismobile[peers]' (the peers that are missing
are named and skipped). --moc needs ../shared/peers/moc and g++ (else its rows are skipped with
the reason); w2xN are W2 tiled N x N (tools/tile_world.py; 7 x 7 builds for minutes).
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tools"))

from bench_moc import moc_main  # noqa: E402
from bench_terrain import build_methods, heightmap  # noqa: E402
from vismobile.device.profile import get_profile  # noqa: E402
from vismobile.study.peers import PEERS, compare, missing  # noqa: E402
from vismobile.terrain.paths import path_cameras  # noqa: E402


def table(rows) -> list:
    lines = ["| method | tau px | matched on | max error (world) | triangles | sample error max px "
             "| PSNR min | PSNR median | pixels differing |",
             "|---|---:|---|---:|---:|---:|---:|---:|---:|"]
    for r in rows:
        lines.append(f"| {r['method']} | {r['tau']:g} | {r['match'] or '-'} | "
                     f"{r['max_error']:.3g} | {r['triangles']:,.0f} | {r['sample_error_px']:.2f} | "
                     f"{r['psnr_min']:.1f} | {r['psnr_median']:.1f} | "
                     f"{100 * r['differing_median']:.2f}% |")
    return lines


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--size", type=int, default=1025)
    parser.add_argument("--frames", type=int, default=None, help="3 (terrain), 150 (--moc)")
    parser.add_argument("--taus", default="0.5,1,4")
    parser.add_argument("--methods", default="tiles,roettger,roam")
    parser.add_argument("--patch", type=int, default=16)
    parser.add_argument("--C", type=float, default=8.0)
    parser.add_argument("--out", type=Path, default=None)
    parser.add_argument("--moc", action="store_true",
                        help="occlusion against Intel MOC instead of the terrain peers")
    parser.add_argument("--worlds", default="w2,w2x3",
                        help="--moc: w2 and tiled w2xN worlds, comma-separated")
    parser.add_argument("--start", type=int, default=300, help="--moc: first trajectory frame")
    args = parser.parse_args(argv)
    if args.moc:
        return moc_main(args.worlds, args.start, args.frames or 150,
                        args.out or ROOT / "runs" / "bench_peers_moc.md")
    args.out = args.out or ROOT / "runs" / "bench_peers.md"
    args.frames = args.frames or 3
    for name in PEERS:
        reason = missing(name)
        if reason:
            print(f"skipping {name}: {reason}", file=sys.stderr)
    hm = heightmap(args.size)
    cameras = path_cameras(hm, "lemniscate", "fast", frames=args.frames,
                           every=900 // max(args.frames, 1))
    methods, _ = build_methods(hm, args.methods.split(","), args.patch, args.C)
    rows = compare(methods, hm, cameras, [float(t) for t in args.taus.split(",")],
                   get_profile("ipaq-hx2490b"))
    lines = [f"## Peers, {args.size}^2, {args.frames} frames of the fast lemniscate, 240x320", ""]
    lines += table(rows)
    print("\n".join(lines))
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text("\n".join(lines) + "\n")
    args.out.with_suffix(".json").write_text(json.dumps(rows, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())

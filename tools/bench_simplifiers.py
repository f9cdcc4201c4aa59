"""Benchmark: the three simplifiers issue 27 names, on W2's models, at the same targets.

Usage: .venv/bin/python tools/bench_simplifiers.py [--world w2] [--objects bunny_01,...]
       [--ratios 0.5,0.125,0.03]

For each object and target (a fraction of its triangles): wall time (median of 3), triangles
reached, the error the library reports (meshoptimizer only), and the measured two-sided
distance between the surfaces (largest of: original vertices and triangle centroids to the
simplified surface, simplified vertices and centroids to the original; exact point-to-triangle
distances, lod/nearest.py), as a fraction of the object's box diagonal. Whether the result
keeps the original vertices (an index buffer only) is printed too.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from vismobile.lod.nearest import nearest_triangle  # noqa: E402
from vismobile.lod.simplify import simplify_object  # noqa: E402
from vismobile.files.loader import open_world  # noqa: E402


def meshopt(points, faces, target):
    tris, error = simplify_object(points, faces, target)
    return points, tris, error


def fast(points, faces, target):
    import fast_simplification

    p, f = fast_simplification.simplify(points.astype(np.float32), faces.astype(np.int64),
                                        target_count=int(target))
    return p.astype(np.float64), f, None


def quadric(points, faces, target):
    from vismobile.open3d_import import decimate

    p, f = decimate(points, faces, target)
    return p, f, None


LIBRARIES = {"meshoptimizer": meshopt, "fast-simplification": fast, "open3d-quadric": quadric}


def distance(points_a, faces_a, points_b, faces_b):
    """Largest distance from a's vertices and centroids to b's surface."""
    corners_a = points_a[faces_a]
    queries = np.concatenate([points_a[np.unique(faces_a)], corners_a.mean(axis=1)])
    return float(nearest_triangle(points_b[faces_b], queries)[1].max())


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--world", default="w2")
    parser.add_argument("--objects", default="bunny_01,cow_01,dragon_01,flower_01,teapot_01")
    parser.add_argument("--ratios", default="0.5,0.125,0.03")
    args = parser.parse_args()
    world = open_world(args.world)
    for name in args.objects.split(","):
        obj = world.object_names.index(name)
        ids = np.flatnonzero(world.object_ids == obj)
        used, local = np.unique(world.triangles[ids], return_inverse=True)
        points, faces = world.vertices[used], local.reshape(-1, 3)
        diagonal = float(np.linalg.norm(np.ptp(points, axis=0)))
        for ratio in (float(r) for r in args.ratios.split(",")):
            target = max(int(len(faces) * ratio), 4)
            for label, run in LIBRARIES.items():
                times = []
                for _ in range(3):
                    start = time.perf_counter()
                    p, f, reported = run(points, faces, target)
                    times.append((time.perf_counter() - start) * 1000.0)
                measured = max(distance(points, faces, p, f), distance(p, f, points, faces))
                same = p.shape == points.shape and np.array_equal(p, points)
                print(f"{name:<10} {len(faces):>5} -> target {target:>5}  {label:<20} "
                      f"{np.median(times):7.2f} ms  {len(f):>5} tris  reported "
                      f"{'-' if reported is None else f'{reported / diagonal:.5f}'}  measured "
                      f"{measured / diagonal:.5f} (x diagonal)  original vertices "
                      f"{'kept' if same else 'moved'}")


if __name__ == "__main__":
    main()

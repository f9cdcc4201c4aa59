"""Building the level-of-detail chains offline with meshoptimizer's simplifier.

Why meshoptimizer (tools/bench_simplifiers.py, docs/lod.md): it returns an index buffer over
the mesh's own vertices (a level costs only its indices, and the renderer's vertex data is
shared), it reports the error of the result (absolute, in world units, with
SIMPLIFY_ERROR_ABSOLUTE), and it meets a triangle target exactly and fast.
fast-simplification and open3d's quadric decimation move vertices and report no error.

Levels shrink the triangle count by RATIO from the original each time (each level simplified
from the original, so its error is against the original), until a level would hold fewer
than MIN_LEVEL_TRIANGLES or saves less than 10% over the previous one. Objects under
MIN_OBJECT_TRIANGLES keep only level 0: their levels would save little and cost lookups.
"""
from __future__ import annotations

import time

import numpy as np

from ..errors import VisMobileError
from .chains import LodChains, object_bounds
from .nearest import nearest_triangle, triangle_samples

RATIO = 0.6
MIN_OBJECT_TRIANGLES = 16
MIN_LEVEL_TRIANGLES = 2
MAX_LEVELS = 12
MAX_SAMPLES = 64  # points spread over one level triangle to find the originals under it
SPREAD = 2
MIN_SPREAD = 512


def simplify_object(vertices, triangles, target: int):
    """(level triangles (k, 3) int64 into vertices, absolute error float) of one object.

    vertices  : (V, 3) float64, triangles (n, 3) int: the object's mesh
    target    : triangles wanted (the result may hold fewer, or more when the simplifier
                cannot reach it without breaking the topology it keeps)
    """
    import meshoptimizer

    indices = np.ascontiguousarray(triangles, dtype=np.uint32).ravel()
    positions = np.ascontiguousarray(vertices, dtype=np.float32)
    out = np.zeros(len(indices), dtype=np.uint32)
    error = np.zeros(1, dtype=np.float32)
    count = meshoptimizer.simplify(out, indices, positions, target_index_count=3 * int(target),
                                   target_error=np.float32(np.inf),
                                   options=meshoptimizer.SIMPLIFY_ERROR_ABSOLUTE,
                                   result_error=error)
    return out[:count].reshape(-1, 3).astype(np.int64), float(error[0])


def build_chains(world, min_object_triangles=MIN_OBJECT_TRIANGLES, ratio=RATIO,
                 max_levels=MAX_LEVELS, progress=None) -> LodChains:
    """LodChains of every object of world with at least min_object_triangles triangles.

    Raises VisMobileError when meshoptimizer is not installed.
    """
    try:
        import meshoptimizer  # noqa: F401
    except ImportError as error:
        raise VisMobileError(f"level of detail needs meshoptimizer ({error}); "
                             "pip install meshoptimizer") from None
    order = np.argsort(world.object_ids, kind="stable")  # each object's ids, ascending
    sizes = np.bincount(world.object_ids, minlength=len(world.object_names))
    firsts = np.r_[0, np.cumsum(sizes)]
    tris, objs, starts, errors, owners, extra_slots, extra_tris = [], [], [0], [], [], [], []
    owner_starts = [0]
    total = 0
    started = time.perf_counter()
    for obj in np.flatnonzero(sizes >= max(int(min_object_triangles), 1)):
        ids = order[firsts[obj]:firsts[obj + 1]]
        mesh = world.triangles[ids]
        used, local = np.unique(mesh, return_inverse=True)
        local = local.reshape(-1, 3)
        points = world.vertices[used]
        centroids = world.centroids[ids]
        previous, last_error = len(ids), 0.0
        for _ in range(int(max_levels)):
            target = int(previous * ratio)
            if target < MIN_LEVEL_TRIANGLES:
                break
            level, error = simplify_object(points, local, target)
            if len(level) < MIN_LEVEL_TRIANGLES or len(level) > 0.9 * previous:
                break
            entry = len(objs)
            level_corners = points[level]
            # Ties: each original to the level triangle nearest to its centroid (owner) and
            # to those nearest to points halfway to its corners; each level triangle to the
            # originals nearest to points spread over it (one per original it covers, about).
            # A level triangle is drawn when culling kept an original tied to it.
            owner, far = nearest_triangle(level_corners, centroids)
            half = 0.5 * (world.corners[ids] + centroids[:, None])  # (n, 3, 3)
            more, far_half = nearest_triangle(level_corners, half.reshape(-1, 3))
            areas = 0.5 * np.linalg.norm(np.cross(level_corners[:, 1] - level_corners[:, 0],
                                                  level_corners[:, 2] - level_corners[:, 0]),
                                         axis=1)
            # Samples spread by area: about SPREAD per original in all, at least MIN_SPREAD
            # (small objects, whose few big triangles a level overlaps unevenly).
            budget = max(SPREAD * len(ids), MIN_SPREAD)
            wanted = np.minimum(budget * areas / max(float(areas.sum()), 1e-300), MAX_SAMPLES)
            spread, of = triangle_samples(level_corners, wanted)
            under, far_level = nearest_triangle(world.corners[ids], spread)
            pairs = np.unique(np.concatenate([
                np.stack([np.repeat(ids, 3), more], axis=1),
                np.stack([ids[under], of], axis=1)]), axis=0)
            pairs = pairs[pairs[:, 1] != owner[np.searchsorted(ids, pairs[:, 0])]]
            pairs[:, 1] += total
            owner = owner + total
            # Slot of an original in the owner table: owner_start[entry] + its rank.
            extra_slots.append(owner_starts[-1] + np.searchsorted(ids, pairs[:, 0]))
            extra_tris.append(pairs[:, 1])
            # The level's error: the simplifier's, or when larger the largest distance from
            # the original's vertices and sample points to the level's surface and from the
            # level's sample points to the original's.
            _, far_vertex = nearest_triangle(level_corners, points)
            error = max(error, float(max(far.max(), far_half.max(), far_level.max(),
                                         far_vertex.max())))
            last_error = max(last_error, error)  # a coarser level never claims less error
            tris.append(used[level])
            objs.append(obj)
            errors.append(last_error)
            owners.append(owner)
            total += len(level)
            starts.append(total)
            owner_starts.append(owner_starts[-1] + len(ids))
            previous = len(level)
        if progress is not None:
            progress(int(obj) + 1, len(sizes))
    slots = np.concatenate(extra_slots) if extra_slots else np.zeros(0, np.int64)
    extra = np.concatenate(extra_tris) if extra_tris else np.zeros(0, np.int64)
    sort = np.argsort(slots, kind="stable")
    chains = LodChains(
        triangles=(np.concatenate(tris) if tris else np.zeros((0, 3))).astype(np.int32),
        level_object=np.asarray(objs, dtype=np.int32),
        level_start=np.asarray(starts, dtype=np.int64),
        level_error=np.asarray(errors, dtype=np.float64),
        owner=(np.concatenate(owners) if owners else np.zeros(0)).astype(np.int32),
        owner_start=np.asarray(owner_starts, dtype=np.int64),
        extra_start=np.searchsorted(slots[sort], np.arange(owner_starts[-1] + 1)).astype(np.int32),
        extra_tri=extra[sort].astype(np.int32),
        object_bounds=object_bounds(world))
    chains.build_seconds = time.perf_counter() - started
    return chains

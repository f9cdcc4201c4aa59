"""Moving objects as occluders of the `occlusion` stage (issue 25): each frame the moving
objects in the frustum that look largest from the eye offer their triangles **posed at this
frame's time** (the matrices the frame's cull computed: never last frame's pose); the best by
estimated solid angle that certainly face the eye, also as the device rounds them, are
rasterised into the depth buffer after the static occluders, so they hide static nodes and
triangles and other moving objects.

Why it is conservative: the ground truth is the item buffer of the world posed at t, in which
every front-facing triangle of the posed world is opaque; the triangles rasterised here are
exactly those posed vertices (animated.transform_rows, the arithmetic of AnimatedWorld.posed),
taken only when they certainly face the eye (hiz.facing_occluders, errs toward False by the
device's rounding delta) and only from objects whose box lies within the coordinate scale the
stage's device margins were computed for (a larger coordinate would move by more on the
device). The rasteriser's own rules apply unchanged (pixels wholly inside, clip beyond the near
plane, T-junctions never closed). Which objects and triangles are chosen only affects how much
is hidden, never safety.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from ..world.animated import transform_rows
from .hiz import facing_occluders
from .hiz.frame import top_scored
from .occluder_choice import GRAZING
from .occluder_rows import occluder_mesh_of, score_corners, triangle_rows
from .triangle_backface import DEVICE_ABSOLUTE, DEVICE_RELATIVE, GAMMA_8

# At most this many moving objects offer occluders a frame (the largest from the eye) ...
OBJECTS = 8
# ... each seen under at least this angle (box half-diagonal over distance, radians): smaller
# ones cover too few buffer pixels to hide anything.
SMALLEST = 0.02


@njit(cache=True, nogil=True)
def largest_objects(boxes, objects, eye, scale, smallest, count):
    """(<= count,) int64 of objects (rows of boxes (M, 2, 3)) whose box lies within |coordinate|
    <= scale, largest angular size (half-diagonal over the distance from the eye to the box's
    centre) first, those seen under less than `smallest` left out. Only ranks: never safety."""
    size = np.zeros(len(objects))
    for i in range(len(objects)):
        k = objects[i]
        inside, d2, r2 = True, 0.0, 0.0
        for j in range(3):
            lo, hi = boxes[k, 0, j], boxes[k, 1, j]
            inside = inside and max(abs(lo), abs(hi)) <= scale
            c, h = 0.5 * (lo + hi), 0.5 * (hi - lo)
            d2 += (c - eye[j]) ** 2
            r2 += h * h
        if inside:
            size[i] = np.sqrt(r2 / max(d2, 1e-300))
    keep = np.flatnonzero(size >= smallest)
    order = keep[np.argsort(-size[keep], kind="mergesort")][:count]
    return objects[order]


def moving_occluders(animated, matrices, posed, objects, boxes, eye, planes, scale, budget):
    """The rasteriser's tables (occlusion.mesh's form, local ids 0..K-1) of this frame's moving
    occluders, or None: up to `budget` triangles of the OBJECTS largest of `objects` (K,) int64
    (in the frustum, boxes (M, 2, 3) exact at t, matrices (M, 4, 4) at t), posed into `posed`
    (rest_vertices' shape; their rows written), best by solid angle, certainly facing the eye
    (module docstring). scale: the stage's coordinate scale (its device margins hold up to it)."""
    eye = np.asarray(eye, dtype=np.float64)
    chosen_objects = largest_objects(boxes, np.ascontiguousarray(objects, dtype=np.int64), eye,
                                     float(scale), SMALLEST, OBJECTS)
    if not len(chosen_objects):
        return None
    transform_rows(animated.rest_vertices, animated.vertex_start, matrices, chosen_objects,
                   posed)
    start = animated.tri_start
    local = np.concatenate([np.arange(start[k], start[k + 1], dtype=np.int64)
                            for k in chosen_objects])
    triangles = animated.local_triangles
    score = score_corners(local, posed, triangles, np.ascontiguousarray(planes, np.float64), eye,
                          GRAZING)
    chosen = top_scored(local, score, int(budget))
    if not len(chosen):
        return None
    delta = DEVICE_RELATIVE * max(float(scale), *map(abs, eye)) + DEVICE_ABSOLUTE
    normals, v0, centroids, _, _ = triangle_rows(chosen, posed, triangles)
    rows = np.arange(len(chosen), dtype=np.int64)
    chosen = chosen[facing_occluders(chosen, posed, triangles, rows, normals, v0, centroids, eye,
                                     delta, GAMMA_8, GRAZING)]
    if not len(chosen):
        return None
    (points, tri_points, normals, offsets, groups, piece_start, piece_end, piece_a, piece_b,
     partner, partner_any) = occluder_mesh_of(chosen, posed, triangles)
    order = np.argsort(groups, kind="stable").astype(np.int64)
    return (order, groups, tri_points, points, normals, offsets, piece_start, piece_end, piece_a,
            piece_b, partner, partner_any, np.full(len(chosen), -1, np.int64))

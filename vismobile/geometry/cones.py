"""Normal cones of triangle clusters and the apex back-face test (meshoptimizer's
`meshopt_computeClusterBounds`, zeux/meshoptimizer src/clusterizer.cpp).

A cluster's cone is (apex, axis, cutoff). Every triangle normal lies within acos(mindp) of the
axis, cutoff = sqrt(1 - mindp^2), and the apex lies on the back side of every triangle plane.
Then dot(normalize(apex - eye), axis) >= cutoff implies every triangle is back-facing (or
edge-on) seen from eye.
"""
from __future__ import annotations

import numpy as np

# Clusters whose normals spread wider than acos(MIN_SPREAD_DOT) get no cone (never culled).
MIN_SPREAD_DOT = 0.1
NEVER = 2.0  # cutoff that no dot product of unit vectors reaches


def _reduceat_nonempty(ufunc, values, starts, ends):
    """ufunc-reduction of each non-empty segment values[starts[i]:ends[i]] (along axis 0)."""
    bounds = np.empty(2 * len(starts), dtype=np.int64)
    bounds[0::2], bounds[1::2] = starts, ends
    # One padding row keeps an end equal to len(values) a valid reduceat index.
    padded = np.concatenate([values, values[:1]])
    return ufunc.reduceat(padded, bounds, axis=0)[0::2]


def cluster_cones(normals, corners, starts, ends, scale: float = 1.0) -> tuple:
    """Normal cones of clusters of triangles given as contiguous segments of a triangle list.

    normals : (R, 3) float64 unit triangle normals, in cluster order (zero rows = degenerate)
    corners : (R, 3, 3) float64 triangle corners, same order
    starts, ends : (G,) int64 segment bounds of each cluster
    scale   : coordinate scale of the world, for the apex's safety margin
    returns (apex (G, 3), axis (G, 3), cutoff (G,)) float64; cutoff = NEVER for clusters that
    are empty, contain degenerate triangles or spread too wide.
    Errs toward keeping: the cone is widened and the apex pushed back by 1e-9 relative.
    """
    starts = np.asarray(starts, dtype=np.int64)
    ends = np.asarray(ends, dtype=np.int64)
    g = len(starts)
    apex = np.zeros((g, 3))
    axis = np.zeros((g, 3))
    cutoff = np.full(g, NEVER)
    nonempty = ends > starts
    if not nonempty.any():
        return apex, axis, cutoff
    s, e = starts[nonempty], ends[nonempty]
    sums = _reduceat_nonempty(np.add, normals, s, e)  # (G', 3)
    length = np.linalg.norm(sums, axis=1)
    ok = length > 1e-12
    ax = np.where(ok[:, None], sums / np.where(ok, length, 1.0)[:, None], 0.0)
    seg = np.repeat(np.arange(len(s)), e - s)
    dots = np.einsum("ij,ij->i", normals, ax[seg])
    unit = np.abs(np.linalg.norm(normals, axis=1) - 1.0) < 1e-6
    dots = np.where(unit, dots, -1.0)  # a degenerate triangle disables its cluster's cone
    mindp = _reduceat_nonempty(np.minimum, dots, s, e) - 1e-9
    # Box centre of the cluster's corners, then the apex behind every triangle plane.
    lo = _reduceat_nonempty(np.minimum, corners.min(axis=1), s, e)
    hi = _reduceat_nonempty(np.maximum, corners.max(axis=1), s, e)
    center = 0.5 * (lo + hi)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.einsum("ij,ij->i", center[seg] - corners[:, 0], normals) / dots
    t = np.where(dots > 0, t, 0.0)
    maxt = np.maximum(_reduceat_nonempty(np.maximum, t, s, e), 0.0) + 1e-9 * scale
    good = ok & (mindp > MIN_SPREAD_DOT)
    apex[nonempty] = center - ax * maxt[:, None]
    axis[nonempty] = ax
    cutoff[nonempty] = np.where(good, np.sqrt(np.clip(1.0 - mindp * mindp, 0.0, 1.0)), NEVER)
    return apex, axis, cutoff


def cones_backfacing(apex, axis, cutoff, eye) -> np.ndarray:
    """(G,) bool: every triangle of the cluster is back-facing or edge-on seen from eye
    (exact given the cone; errs toward False by 1e-12 in the dot product).

    apex, axis : (G, 3) float64;  cutoff : (G,) float64;  eye : (3,) float64
    """
    v = np.asarray(apex) - np.asarray(eye, dtype=np.float64)
    dist = np.linalg.norm(v, axis=1)
    return np.einsum("ij,ij->i", v, axis) >= (cutoff + 1e-12) * dist

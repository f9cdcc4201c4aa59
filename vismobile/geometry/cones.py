"""Normal cones of triangle clusters and the apex back-face test (meshoptimizer's
`meshopt_computeClusterBounds`, zeux/meshoptimizer src/clusterizer.cpp).

A cluster's cone is (apex, axis, cutoff). Every triangle normal lies within acos(mindp) of the
axis, cutoff = sqrt(1 - mindp^2), and the apex lies on the back side of every triangle plane.
Then dot(normalize(apex - eye), axis) >= cutoff implies every triangle is back-facing (or
edge-on) seen from eye.

Device rounding (cone_rounding, cones_backfacing's `move`): the device draws triangles whose
corners, and the eye, moved by at most m (Euclidean). A triangle's unit normal then turns by
theta (sin theta <= k1 m + k2 m^2 = r, geometry/tilt.py) and |n' - n| <= 2 r, and its plane
passes within m of the old corner q, so n'.(apex - q') <= n.(apex - q) + 2 r |apex - q| + m =: B.
With alpha = the cone's half angle (asin cutoff), theta, beta = asin(B / |apex - eye'|) and
gamma = asin(m / |apex - eye|) (the eye's move), angle(apex - eye, axis) + alpha + theta + beta
+ gamma <= 90 degrees gives n'.(apex - eye') >= B >= n'.(apex - q'), i.e. n'.(eye' - q') <= 0:
every rounded triangle faces away from the rounded eye.
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


def cone_rounding(normals, corners, apex, starts, ends) -> np.ndarray:
    """(G, 5) float64 per cluster, the terms of the device-rounding bound (module docstring):
    k1, k2 (largest tilt coefficients), behind (largest n.(apex - q) <= 0), reach1, reach2
    (largest k1 |apex - q|, k2 |apex - q|), so that B <= behind + 2 (reach1 m + reach2 m^2) + m.
    Empty clusters get zeros (their cutoff is NEVER anyway); degenerate triangles inf.

    normals : (R, 3), corners : (R, 3, 3) float64 in cluster order;  apex : (G, 3) float64
    starts, ends : (G,) int64 segment bounds
    """
    from .tilt import tilt_coefficients  # noqa: PLC0415  (sibling module, kept light)
    starts, ends = np.asarray(starts, dtype=np.int64), np.asarray(ends, dtype=np.int64)
    out = np.zeros((len(starts), 5))
    nonempty = ends > starts
    if not nonempty.any():
        return out
    s, e = starts[nonempty], ends[nonempty]
    seg = np.repeat(np.arange(len(starts))[nonempty], e - s)
    k1, k2 = tilt_coefficients(corners)
    rel = apex[seg] - corners[:, 0]
    dist = np.linalg.norm(rel, axis=1)
    with np.errstate(invalid="ignore"):
        terms = np.column_stack([k1, k2, np.einsum("ij,ij->i", normals, rel), k1 * dist,
                                 k2 * dist])
    terms = np.where(np.isnan(terms), np.inf, terms)
    out[nonempty] = _reduceat_nonempty(np.maximum, terms, s, e)
    return out


def cones_backfacing(apex, axis, cutoff, eye, rounding=None, move: float = 0.0) -> np.ndarray:
    """(G,) bool: every triangle of the cluster is back-facing or edge-on seen from eye, also
    after the device moves corners and eye by <= move (Euclidean) when `rounding` is given.

    Exact given the cone (and the bound in the module docstring); errs toward False by 1e-12.
    apex, axis : (G, 3) float64;  cutoff : (G,) float64;  eye : (3,) float64
    rounding : (G, 5) float64 from cone_rounding, or None (no device margin);  move : >= 0
    """
    v = np.asarray(apex) - np.asarray(eye, dtype=np.float64)
    dist = np.linalg.norm(v, axis=1)
    dots = np.einsum("ij,ij->i", v, axis)
    if rounding is None:
        return dots >= (cutoff + 1e-12) * dist
    m = float(move)
    k1, k2, behind, reach1, reach2 = np.asarray(rounding, dtype=np.float64).T
    with np.errstate(invalid="ignore", divide="ignore"):
        bound = np.maximum(behind + 2.0 * (reach1 * m + reach2 * m * m) + m, 0.0)
        near = np.maximum(dist - m, 0.0)  # the rounded eye is at least this far from the apex
        ratios = np.stack([np.minimum(cutoff, 2.0), k1 * m + k2 * m * m,
                           np.where(near > 0, bound / near, np.inf),
                           np.where(dist > 0, m / dist, np.inf)])
        ratios = np.where(np.isnan(ratios), np.inf, ratios)
        angle = np.arcsin(np.minimum(ratios, 1.0)).sum(axis=0)
    # The sum must stay below 90 degrees; any ratio >= 1 (an angle of 90) already blocks it.
    ok = (ratios < 1.0).all(axis=0) & (angle < np.pi / 2)
    need = np.sin(np.minimum(angle, np.pi / 2))
    return ok & (dots >= (need + 1e-12) * dist)

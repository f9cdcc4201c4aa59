"""How far moving the corners of a triangle can turn its plane: the rounding bound that back-face
and occlusion decisions need when the device draws rounded vertices (culling/precision.py).

A triangle (p0, p1, p2) has the normal direction c = (p1 - p0) x (p2 - p0), taken from the corner
between its two shortest edges a, b. Moving every corner by at most m (Euclidean) moves a and b
by at most 2 m each, so the new cross product c' satisfies
    |c' - c| <= 2 m (|a| + |b|) + 4 m^2,
and the angle between c and c' has sin <= |c' - c| / |c| (when below 1), while the unit normals
differ by |n' - n| <= 2 |c' - c| / |c|. tilt_coefficients returns k1, k2 with
|c' - c| / |c| <= k1 m + k2 m^2.
"""
from __future__ import annotations

import numpy as np

# The coefficients' own float64 evaluation: a few roundings, far below this relative slack.
_SLACK = 1.0 + 2.0 ** -40


def tilt_coefficients(corners) -> tuple:
    """(k1, k2), each (T,) float64 >= 0: moving each corner by <= m (Euclidean) changes the
    triangle's cross product by at most (k1 m + k2 m^2) |c|; inf for zero-area triangles.

    Errs large by 2^-40 relative. corners : (T, 3, 3) float64 (any winding)
    """
    corners = np.asarray(corners, dtype=np.float64).reshape(-1, 3, 3)
    edges = np.roll(corners, -1, axis=1) - corners
    lengths = np.sort(np.linalg.norm(edges, axis=2), axis=1)
    cross = np.linalg.norm(np.cross(edges[:, 0], -edges[:, 2]), axis=1)
    with np.errstate(divide="ignore"):
        inv = np.where(cross > 0, 1.0 / cross, np.inf)
    # inf * 0 cannot happen: a positive cross product needs two non-zero edges.
    return (2.0 * (lengths[:, 0] + lengths[:, 1]) * inv * _SLACK, 4.0 * inv * _SLACK)


def tilt_sine(k1, k2, move) -> np.ndarray:
    """Bound |c' - c| / |c| for corners moved by <= move (Euclidean); also bounds the sine of
    the normal's turn (when < 1) and half of |n' - n|. k1, k2 : arrays from tilt_coefficients."""
    move = float(move)
    with np.errstate(invalid="ignore"):
        out = np.asarray(k1) * move + np.asarray(k2) * (move * move)
    return np.where(np.isnan(out), np.inf, out)  # inf * 0 for zero-area triangles, move 0

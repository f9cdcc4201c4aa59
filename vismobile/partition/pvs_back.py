"""The PVS's from-region back-face test: a triangle whose plane has a whole view cell (grown by
the eye's reach) behind it faces away from every eye there, so the GPU culls it
(GL_CULL_FACE) and the back-face-culled item buffer never shows it.

Contract: `region_backfacing` errs toward front-facing. It keeps a triangle unless, at each of
the 8 corners e of the grown box, det = ((v1 - v0) x (v2 - v0)) . (e - v0) is below minus twice
culling/triangle_backface.py's bound on how far the device's rounding (each corner and the eye
moved by up to `delta` per coordinate) and float64 move det. det is linear in e and the bound
convex (it grows with |e - v0|), so det + bound is convex and below 0 at the 8 corners means
below 0 over the whole box. The bound is written here again because the partition package may
not import culling (tests/test_layers.py).
"""
from __future__ import annotations

import numpy as np

GAMMA_8 = 8 * 2.0 ** -53 / (1 - 8 * 2.0 ** -53)


def triangle_terms(corners) -> tuple:
    """Per triangle, once per world: (v0, cross c, c_abs (the cross product of absolute values),
    |v1 - v0|, |v2 - v0|) for region_backfacing. corners : (T, 3, 3) float64."""
    corners = np.asarray(corners, dtype=np.float64).reshape(-1, 3, 3)
    v0 = corners[:, 0]
    a = corners[:, 1] - v0
    b = corners[:, 2] - v0
    c = np.cross(a, b)
    c_abs = np.abs(a[:, [1, 2, 0]] * b[:, [2, 0, 1]]) + np.abs(a[:, [2, 0, 1]] * b[:, [1, 2, 0]])
    return v0, c, c_abs, np.linalg.norm(a, axis=1), np.linalg.norm(b, axis=1)


def region_backfacing(corners, lo, hi, delta, terms=None, ids=None) -> np.ndarray:
    """(T,) bool: triangles certainly back-facing from every eye in the box [lo, hi].

    corners : (T, 3, 3) float64 triangle corners (unused when terms are given)
    lo, hi  : (3,) the box (already grown by the eyes' reach)
    delta   : per-coordinate device move of corners and eyes
    terms   : optional triangle_terms of every triangle, with ids (S,) the ones to test
              (returns (S,) bool)
    """
    v0, c, c_abs, la, lb = triangle_terms(corners) if terms is None else terms
    if ids is not None:
        v0, c, c_abs, la, lb = v0[ids], c[ids], c_abs[ids], la[ids], lb[ids]
    back = np.ones(len(v0), dtype=bool)
    root3 = np.sqrt(3.0)
    fixed = 2 * la * lb
    for k in range(8):
        e = np.where([k & 1, k & 2, k & 4], hi, lo).astype(np.float64)
        w = v0 - e
        lw = np.sqrt(np.einsum("ij,ij->i", w, w))
        det = -np.einsum("ij,ij->i", c, w)  # c . (e - v0)
        bound = (root3 * delta * (2 * lw * (la + lb) + fixed)
                 + 36 * delta ** 2 * (lw + la + lb) + 48 * delta ** 3
                 + GAMMA_8 * np.einsum("ij,ij->i", c_abs, np.abs(w)))
        back &= det < -2.0 * bound
    return back

"""`tbfc`: exact per-triangle back-face culling on the CPU, for the triangles that survive the
node stages (the test GL_CULL_FACE makes, done before sending instead of after).

A triangle (v0, v1, v2), wound counter-clockwise seen from its front (OpenGL's default front
face), faces the eye e when det = ((v1 - v0) x (v2 - v0)) . (e - v0) > 0; the sign is the
orientation of its projection, so the driver culls it exactly when det < 0 (and edge-on ones,
det = 0, cover no pixel). Nothing is precomputed per triangle: each frame reads its candidates'
corners from the world's vertices (in memory, or a memory-mapped file) and forms the cross
product c = (v1 - v0) x (v2 - v0) and det (culling/facing.py), so memory does not grow with the
world and a frame costs what it gathers.

Why the tolerance. The device does not see these float64 vertices: it rounds them to float32 (or
fixed16.16) and transforms them in float32. We keep every triangle that would face the eye after
any move of its corners and of the eye by up to `delta` per coordinate (delta covers the
device's rounding), and on top of that the float64 rounding of det itself. With w = v0 - e,
a = v1 - v0, b = v2 - v0, det is a determinant of (w, w + a, w + b); moving each of its four
points by at most sqrt(3) delta changes it by at most
    sqrt(3) delta (2 |w| (|a| + |b|) + 2 |a| |b|) + 36 delta^2 (|w| + |a| + |b|) + 48 delta^3
(first order: the gradients with respect to v0, v1, v2, e are w x b + a x w + a x b, b x w,
w x a and -(a x b); higher orders: det is trilinear in v_i - e, each moved by <= 2 sqrt(3)
delta), and float64
evaluates det with an error below gamma_8 (|c_abs| . |w|), c_abs the cross product of
absolute values (8 roundings per term, Higham's gamma_n = n u / (1 - n u)).
"""
from __future__ import annotations

import numpy as np

# Device rounding covered (precision.py): each coordinate moves by up to DEVICE_RELATIVE x the
# largest coordinate magnitude (16 float32 ulps) plus, in fixed16.16, DEVICE_ABSOLUTE (2x the
# grid's step): precision.device_move in the Culler's arithmetic mode.
from .precision import DEVICE_ABSOLUTE, DEVICE_RELATIVE, device_move  # noqa: F401 (re-exported)
from .facing import not_backfacing
from .precision import world_scale
from .state import CullState
from .tree import Tree

_U = 2.0 ** -53
GAMMA_8 = 8 * _U / (1 - 8 * _U)


def triangle_cross(corners) -> tuple:
    """Per triangle: (cross (T, 3) float64 = (v1 - v0) x (v2 - v0), abs_cross (T, 3) float64 the
    same products with absolute values (for rounding bounds), edge_a (T,), edge_b (T,) float64
    lengths |v1 - v0|, |v2 - v0|). corners : (T, 3, 3) float64."""
    corners = np.asarray(corners, dtype=np.float64).reshape(-1, 3, 3)
    a = corners[:, 1] - corners[:, 0]
    b = corners[:, 2] - corners[:, 0]
    cross = np.cross(a, b)
    aa, ab = np.abs(a), np.abs(b)
    abs_cross = np.stack([aa[:, 1] * ab[:, 2] + aa[:, 2] * ab[:, 1],
                          aa[:, 2] * ab[:, 0] + aa[:, 0] * ab[:, 2],
                          aa[:, 0] * ab[:, 1] + aa[:, 1] * ab[:, 0]], axis=1)
    return cross, abs_cross, np.linalg.norm(a, axis=1), np.linalg.norm(b, axis=1)


def certainly_backfacing(cross, abs_cross, edge_a, edge_b, v0, eye, delta: float) -> np.ndarray:
    """(T,) bool: the triangle faces away from the eye, also after any move of its corners and the
    eye by up to `delta` per coordinate, and despite float64 rounding.

    Errs toward False (keeping) by the bound in the module docstring; edge-on is never True.
    cross, abs_cross : (T, 3) float64 from triangle_cross;  edge_a, edge_b : (T,) float64
    v0 : (T, 3) float64 first corners;  eye : (3,) float64;  delta : float >= 0
    """
    w = np.asarray(eye, dtype=np.float64) - v0  # e - v0: det = c . w
    det = np.einsum("ij,ij->i", cross, w)
    out = det < 0
    k = np.flatnonzero(out)  # the bound only matters where det is negative
    w, det, ea, eb = w[k], det[k], edge_a[k], edge_b[k]
    lw = np.sqrt(np.einsum("ij,ij->i", w, w))
    s3 = np.sqrt(3.0) * delta
    moved = (s3 * (2.0 * lw * (ea + eb) + 2.0 * ea * eb)
             + 36.0 * delta * delta * (lw + ea + eb) + 48.0 * delta ** 3)
    rounding = GAMMA_8 * np.einsum("ij,ij->i", abs_cross[k], np.abs(w))
    # The bound's own evaluation rounds too: 2^-50 relative is far above its few roundings.
    out[k] = det < -(moved + rounding) * (1.0 + 2.0 ** -50)
    return out

class TriangleBackface:
    """`tbfc`: drops each gathered triangle that is certainly back-facing from the eye.

    A backface stage: it drops only what the driver's GL_CULL_FACE would discard, so its ground
    truth is the back-face-culled item buffer (as for cbfc and cone).
    Contract: errs toward keeping by tol = the device-rounding move bound plus float64 rounding
    (module docstring): drops a triangle only when det < -tol. The move follows the Culler's
    arithmetic mode (precision.device_move: the fixed16.16 step only in fixed16.16) unless
    `absolute` is given.
    Per frame, per distinct candidate: its corners read from the world (in memory or mapped),
    a cross and a dot product, the bound only for those with a negative product.
    """

    name = "tbfc"
    cost = 85
    arithmetic = "float64"  # the Culler sets its mode: the device-rounding margin follows it

    def __init__(self, relative: float = DEVICE_RELATIVE, absolute: float | None = None):
        self.relative = float(relative)
        self.absolute = None if absolute is None else float(absolute)
        if self.relative < 0 or (self.absolute is not None and self.absolute < 0):
            raise ValueError("tbfc needs relative >= 0 and absolute >= 0")

    def prepare(self, tree: Tree) -> None:
        # Nothing per triangle: each frame reads its candidates' corners (facing.not_backfacing),
        # so a memory-mapped world needs no (T, 11) table (1.76 GB at 20 M triangles).
        world = tree.world
        self.vertices, self.triangles = np.asarray(world.vertices), np.asarray(world.triangles)
        self.magnitude = world_scale(self.vertices)
        self._tested_key = f"{self.name}.triangles_tested"
        self._culled_key = f"{self.name}.triangles_culled"

    def delta(self, eye) -> float:
        """Per-coordinate move allowed for device rounding, at this world's and eye's scale:
        relative x scale plus `absolute`, or the mode's own absolute term (device_move)."""
        scale = max(self.magnitude, float(np.abs(eye).max()))
        absolute = device_move(self.arithmetic, 0.0) if self.absolute is None else self.absolute
        return self.relative * scale + absolute

    def apply(self, state: CullState) -> None:
        eye = np.asarray(state.camera.eye, dtype=np.float64)
        delta = self.delta(eye)

        def keep_of(ids):  # ids are distinct (CullState.finish); returns the kept ids
            kept = np.empty(len(ids), dtype=np.int64)
            count = not_backfacing(np.ascontiguousarray(ids, dtype=np.int64), self.vertices,
                                   self.triangles, eye, delta, GAMMA_8, kept)
            state.count("triangles_tested", len(ids))
            state.count(self._tested_key, len(ids))
            state.count(self._culled_key, len(ids) - count)
            return kept[:count]

        state.filters.append(keep_of)

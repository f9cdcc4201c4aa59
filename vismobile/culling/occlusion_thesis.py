"""`occlusion_thesis`: the thesis's occlusion culling (4.3.2, Algorithm 2), kept for comparison.

Occluders are the triangles sent in the previous frame (temporal coherence), ranked by the
thesis's estimated solid angle -A (N.V) / |D|^2 (V the view direction, D eye to centre); the
best k are used. Each occluder spans a shadow volume bounded by the planes through the eye and
each of its edges. The thesis hides an object when no such plane cuts it and its centre is
inside. Two corrections keep it conservative, and are the only differences:
- the volume is closed by the occluder's own plane: an object between the eye and the occluder
  is not hidden (the thesis's text omits this plane and would hide it);
- an occluder must face the eye (N.(eye - p) > 0): with GL_CULL_FACE a back-facing polygon is
  not drawn and hides nothing; the thesis's -A(N.V) ranks by view direction, not by eye position;
- an occluder is first clipped by the near plane (pushed out by the device's error in placing
  it): the GPU does not draw the part nearer than `near`, so that part hides nothing (issue 17:
  an eye 0.0957 above a slab, near 0.1, sees the slab's bottom through its clipped top).
Device rounding: relative to the eye every point moves by at most m = 2 device_move per
coordinate (mu = sqrt(3) m). A plane through the eye and corners p, q then turns with
|n' - n| <= 2 (mu (|p - e| + |q - e|) + mu^2) / |(p - e) x (q - e)|, the occluder's own plane
with |n' - n| <= 2 tilt_sine(mu) (geometry/tilt.py) and moves by mu; so a node is hidden only
when its box, grown by m, is inside every plane by tol + A + B R (R: the grown box's farthest
distance from the eye; B = |n' - n|, A = 0 for eye planes, |n' - n| |e - q| + mu for the face).
Occluders are single triangles (no fusion), which is why the thesis found little gain.
"""
from __future__ import annotations

import numpy as np

from ..geometry.planes import box_plane_distances
from ..geometry.tilt import tilt_coefficients, tilt_sine
from .occlusion import NEAR_RELATIVE
from .precision import device_move
from .state import CullState, CullResult
from .tree import Tree

GRAZING = 1e-6  # |cos| of the view angle below which an occluder is skipped


def clip_near(corners, eye, forward, depth: float) -> tuple:
    """Triangles clipped to the half-space (p - eye).forward >= depth (Sutherland-Hodgman).

    corners : (K, 3, 3) float64;  eye, forward : (3,) float64 (forward unit);  depth : float
    returns (polygons (K, 4, 3) float64 convex, in the triangle's winding, counts (K,) int64):
    counts[k] corners are valid (0 when nothing is left, else 3 or 4); unused slots repeat
    corner 0. Exact up to float64 rounding of the cut points (callers add their own slack).
    """
    corners = np.asarray(corners, dtype=np.float64).reshape(-1, 3, 3)
    z = (corners - eye) @ forward - depth  # (K, 3) >= 0 inside
    inside = z >= 0
    nxt_z, nxt_in = np.roll(z, -1, axis=1), np.roll(inside, -1, axis=1)
    nxt = np.roll(corners, -1, axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(inside != nxt_in, z / (z - nxt_z), 0.0)
    cut = corners + t[..., None] * (nxt - corners)
    # Per edge i: corner i if inside, then the cut point if the edge crosses the plane.
    points = np.stack([corners, cut], axis=2).reshape(-1, 6, 3)
    valid = np.stack([inside, inside != nxt_in], axis=2).reshape(-1, 6)
    counts = valid.sum(axis=1)
    order = np.argsort(~valid, axis=1, kind="stable")[:, :4]
    polygons = np.take_along_axis(points, order[..., None], axis=1)
    polygons = np.where((np.arange(4) < counts[:, None])[..., None], polygons,
                        polygons[:, :1])
    return polygons, counts


def shadow_planes(polygons, eye, face_normals, face_points, move: float = 0.0,
                  face_tilt=None) -> tuple:
    """Shadow volumes of convex polygons: (planes (K, C + 1, 4) float64 inward planes, C through
    the eye and an edge (a repeated corner's empty edge repeats edge 0's plane), then the
    occluder's plane facing away from the eye (exact); slack (K, C + 1, 2) float64 (A, B): after
    the device moves every point by <= move (Euclidean, relative to the eye) a point x is still
    inside a plane when its distance exceeds A + B |x - e| (module docstring)).

    polygons     : (K, C, 3) float64 convex polygons, e.g. from clip_near (C = 3 or 4)
    face_normals : (K, 3) float64 normals of the occluders' planes (either side)
    face_points  : (K, 3) float64 a point of each occluder's plane
    face_tilt    : (K,) float64 bound on |c' - c| / |c| of each occluder (tilt_sine) or None (0)
    """
    rel = np.asarray(polygons, dtype=np.float64) - eye
    normals = np.cross(rel, np.roll(rel, -1, axis=1))  # (K, C, 3): through eye, corner i, i+1
    length = np.linalg.norm(normals, axis=2)
    empty = length <= 1e-300
    reach = np.linalg.norm(rel, axis=2)
    mu = float(move)
    with np.errstate(divide="ignore", invalid="ignore"):
        turn = 2.0 * (mu * (reach + np.roll(reach, -1, axis=1)) + mu * mu) / length
    turn = np.where(np.isnan(turn), np.inf, np.minimum(turn, 2.0))
    normals = np.where(empty[..., None], normals[:, :1], normals)
    length = np.where(empty, length[:, :1], length)
    turn = np.where(empty, turn[:, :1], turn)
    # The corners' mean is inside a convex polygon: it sets each plane's inner side.
    inner = rel.mean(axis=1)  # repeated corners weigh more, still inside
    sign = np.sign(np.einsum("kij,kj->ki", normals, inner))
    normals = normals * (sign / np.maximum(length, 1e-300))[..., None]
    face = np.asarray(face_normals, dtype=np.float64)
    face = face * np.sign(np.einsum("ij,ij->i", face, face_points - eye))[:, None]
    face = face / np.maximum(np.linalg.norm(face, axis=1, keepdims=True), 1e-300)
    all_normals = np.concatenate([normals, face[:, None]], axis=1)
    offsets = -np.einsum("kij,j->ki", all_normals, eye)
    offsets[:, -1] = -np.einsum("ij,ij->i", face, face_points)
    planes = np.concatenate([all_normals, offsets[..., None]], axis=2)
    tilt = np.zeros(len(rel)) if face_tilt is None else np.asarray(face_tilt, dtype=np.float64)
    face_turn = np.minimum(2.0 * tilt, 2.0)
    slack = np.zeros(planes.shape[:2] + (2,))
    slack[:, :-1, 1] = turn
    slack[:, -1, 0] = face_turn * np.linalg.norm(face_points - eye, axis=1) + mu
    slack[:, -1, 1] = face_turn
    return planes, slack


class ThesisOcclusion:
    """`occlusion_thesis`: shadow volumes of the best k of last frame's triangles.

    occluders : k, the number of occluders per frame
    """

    name = "occlusion_thesis"
    cost = 40
    arithmetic = "float64"  # the Culler sets its mode: the device-rounding margin follows it

    def __init__(self, occluders: int = 16):
        self.occluders = int(occluders)
        if self.occluders < 1:
            raise ValueError("occlusion_thesis needs occluders >= 1")
        self.previous = np.zeros(0, dtype=np.int64)

    def prepare(self, tree: Tree) -> None:
        self.tree = tree
        self.previous = np.zeros(0, dtype=np.int64)
        world = tree.world
        self.magnitude = float(np.abs(world.vertices).max()) if world.vertices.size else 0.0
        self.k1, self.k2 = tilt_coefficients(world.corners)

    def observe(self, result: CullResult) -> None:
        """Remember the triangles sent this frame: next frame's occluder candidates."""
        self.previous = result.triangles

    def select(self, camera) -> np.ndarray:
        """(K,) int64 triangle ids of this frame's occluders, best first."""
        world, ids = self.tree.world, self.previous
        if not len(ids):
            return ids
        eye = camera.eye
        d = world.centroids[ids] - eye
        score = -world.areas[ids] * (world.normals[ids] @ camera.forward) / np.maximum(
            np.einsum("ij,ij->i", d, d), 1e-300)
        # An eye (almost) in the occluder's plane degenerates its shadow planes: skip the
        # occluder unless the eye is off the plane by more than GRAZING of its distance.
        corner = world.vertices[world.triangles[ids, 0]]
        facing = (np.einsum("ij,ij->i", world.normals[ids], eye - corner)
                  > GRAZING * np.sqrt(np.einsum("ij,ij->i", d, d)))
        good = np.flatnonzero((score > 0) & facing)
        k = min(self.occluders, len(good))
        if k == 0:
            return ids[:0]
        best = good[np.argsort(-score[good], kind="stable")[:k]]
        return ids[best]

    def move(self, camera) -> float:
        """m: per-coordinate move of any point relative to the eye on the device (its own
        rounding and the eye's), at this world's and eye's scale."""
        scale = max(self.magnitude, float(np.abs(camera.eye).max()))
        return 2.0 * device_move(self.arithmetic, scale)

    def near_clip(self, camera) -> float:
        """Depth occluders are clipped at: beyond `near` by more than the device's error in
        placing a point (2 sqrt(3) m), so only parts the GPU certainly draws occlude."""
        return camera.near * (1.0 + NEAR_RELATIVE) + 2.0 * np.sqrt(3.0) * self.move(camera)

    def apply(self, state: CullState) -> None:
        tree, camera = self.tree, state.camera
        chosen = self.select(camera)
        state.count(f"{self.name}.occluders", len(chosen))
        if not len(chosen):
            return
        world = tree.world
        polygons, counts = clip_near(world.corners[chosen], camera.eye, camera.forward,
                                     self.near_clip(camera))
        left = counts > 0
        state.count(f"{self.name}.occluders_clipped", int(np.count_nonzero(counts != 3)))
        if not left.any():
            return
        chosen = chosen[left]
        sides = 4 if (counts == 4).any() else 3  # no quads: no repeated fourth plane to test
        m = self.move(camera)
        mu = np.sqrt(3.0) * m
        planes, slack = shadow_planes(polygons[left, :sides], camera.eye, world.normals[chosen],
                                      world.corners[chosen, 0], mu,
                                      tilt_sine(self.k1[chosen], self.k2[chosen], mu))
        per = planes.shape[1]
        planes, slack = planes.reshape(-1, 4), slack.reshape(-1, 2)
        need_a, need_b = slack[:, 0] + tree.tol, slack[:, 1]
        active = state.nodes
        kept, visited, hidden_count = [], 0, 0
        while len(active):
            boxes = tree.node_bounds[active] + np.array([-m, m])[None, :, None]
            _, n_dist = box_plane_distances(boxes, planes)
            far = np.linalg.norm(np.maximum(np.abs(boxes[:, 0] - camera.eye),
                                            np.abs(boxes[:, 1] - camera.eye)), axis=1)
            inside = (n_dist >= need_a + far[:, None] * need_b).reshape(
                len(active), -1, per).all(axis=2)
            hidden = inside.any(axis=1)
            visited += len(active)
            hidden_count += int(hidden.sum())
            grow = ~hidden & (tree.child_count[active] > 0)
            kept.append(active[~hidden & ~grow])
            kids, _ = tree.children(active[grow])
            active = kids[tree.nonempty[kids]]
        state.nodes = np.concatenate(kept) if kept else np.zeros(0, dtype=np.int64)
        state.count("nodes_visited", visited)
        state.count("plane_tests", visited * len(planes))
        state.count(f"{self.name}.nodes_culled", hidden_count)

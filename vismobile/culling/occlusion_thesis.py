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
Occluders are single triangles (no fusion), which is why the thesis found little gain.
"""
from __future__ import annotations

import numpy as np

from ..geometry.planes import box_plane_distances
from .occlusion import NEAR_RELATIVE
from .state import CullState, CullResult
from .tree import Tree
from .triangle_backface import DEVICE_ABSOLUTE, DEVICE_RELATIVE

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


def shadow_planes(polygons, eye, face_normals, face_points) -> np.ndarray:
    """(K, C + 1, 4) float64 inward planes of each convex polygon's shadow volume: C through the
    eye and an edge (a repeated corner's empty edge repeats edge 0's plane), then the
    occluder's plane facing away from the eye (exact, no slack).

    polygons     : (K, C, 3) float64 convex polygons, e.g. from clip_near (C = 3 or 4)
    face_normals : (K, 3) float64 normals of the occluders' planes (either side)
    face_points  : (K, 3) float64 a point of each occluder's plane
    """
    rel = np.asarray(polygons, dtype=np.float64) - eye
    normals = np.cross(rel, np.roll(rel, -1, axis=1))  # (K, 4, 3): through eye, corner i, i+1
    length = np.linalg.norm(normals, axis=2)
    empty = length <= 1e-300
    normals = np.where(empty[..., None], normals[:, :1], normals)
    length = np.where(empty, length[:, :1], length)
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
    return np.concatenate([all_normals, offsets[..., None]], axis=2)


class ThesisOcclusion:
    """`occlusion_thesis`: shadow volumes of the best k of last frame's triangles.

    occluders : k, the number of occluders per frame
    """

    name = "occlusion_thesis"
    cost = 40

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

    def near_clip(self, camera) -> float:
        """Depth occluders are clipped at: beyond `near` by more than the device's error in
        placing it (as the `occlusion` stage), so only parts the GPU certainly draws occlude."""
        scale = max(self.magnitude, float(np.abs(camera.eye).max()))
        return camera.near * (1.0 + NEAR_RELATIVE) + DEVICE_RELATIVE * scale + DEVICE_ABSOLUTE

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
        planes = shadow_planes(polygons[left, :sides], camera.eye, world.normals[chosen],
                               world.corners[chosen, 0])
        per = planes.shape[1]
        planes = planes.reshape(-1, 4)
        active = state.nodes
        kept, visited, hidden_count = [], 0, 0
        while len(active):
            _, n_dist = box_plane_distances(tree.node_bounds[active], planes)
            inside = (n_dist >= tree.tol).reshape(len(active), -1, per).all(axis=2)
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

"""`occlusion_thesis`: the thesis's occlusion culling (4.3.2, Algorithm 2), kept for comparison.

Occluders are the triangles sent in the previous frame (temporal coherence), ranked by the
thesis's estimated solid angle -A (N.V) / |D|^2 (V the view direction, D eye to centre); the
best k are used. Each occluder spans a shadow volume bounded by the planes through the eye and
each of its edges. The thesis hides an object when no such plane cuts it and its centre is
inside. Two corrections keep it conservative, and are the only differences:
- the volume is closed by the occluder's own plane: an object between the eye and the occluder
  is not hidden (the thesis's text omits this plane and would hide it);
- an occluder must face the eye (N.(eye - p) > 0): with GL_CULL_FACE a back-facing polygon is
  not drawn and hides nothing; the thesis's -A(N.V) ranks by view direction, not by eye position.
Occluders are single triangles (no fusion), which is why the thesis found little gain.
"""
from __future__ import annotations

import numpy as np

from ..geometry.planes import box_plane_distances
from .state import CullState, CullResult
from .tree import Tree

GRAZING = 1e-6  # |cos| of the view angle below which an occluder is skipped


def shadow_planes(corners, eye) -> np.ndarray:
    """(K, 4, 4) float64 inward planes of each triangle's shadow volume: three through the eye
    and an edge, then the triangle's plane facing away from the eye (exact, no slack).

    corners : (K, 3, 3) float64 triangles that face the eye
    """
    rel = np.asarray(corners, dtype=np.float64) - eye
    nxt = np.roll(rel, -1, axis=1)
    normals = np.cross(rel, nxt)  # (K, 3, 3): plane through eye, corner i, corner i+1
    opposite = np.roll(rel, -2, axis=1)  # the third corner is inside
    sign = np.sign(np.einsum("kij,kij->ki", normals, opposite))
    normals = normals * sign[..., None]
    face = np.cross(rel[:, 1] - rel[:, 0], rel[:, 2] - rel[:, 0])
    face = face * np.sign(np.einsum("ij,ij->i", face, rel[:, 0]))[:, None]  # away from the eye
    all_normals = np.concatenate([normals, face[:, None]], axis=1)
    all_normals /= np.maximum(np.linalg.norm(all_normals, axis=2, keepdims=True), 1e-300)
    offsets = -np.einsum("kij,j->ki", all_normals, eye)
    offsets[:, 3] = -np.einsum("ij,ij->i", all_normals[:, 3], corners[:, 0])
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

    def apply(self, state: CullState) -> None:
        tree, camera = self.tree, state.camera
        chosen = self.select(camera)
        state.count(f"{self.name}.occluders", len(chosen))
        if not len(chosen):
            return
        planes = shadow_planes(tree.world.corners[chosen], camera.eye).reshape(-1, 4)
        active = state.nodes
        kept, visited, hidden_count = [], 0, 0
        while len(active):
            _, n_dist = box_plane_distances(tree.node_bounds[active], planes)
            inside = (n_dist >= tree.tol).reshape(len(active), -1, 4).all(axis=2)
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

"""`occlusion`: a CPU software depth buffer at low resolution, in the style of Masked Occlusion
Culling (Hasselgren, Andersson, Akenine-Moller 2016) and the hierarchical Z-buffer (Greene 1993).

OpenGL ES 1.1 has no occlusion queries and no depth readback, so all of this runs on the CPU.
Each frame:
1. Occluders: the largest triangles of the world (precomputed candidates) that face the eye,
   grouped by plane; groups ranked by their best member's estimated solid angle
   A |n.d| / |d|^3 (d from the eye to the centroid), taken whole within a triangle budget.
   Any front-facing world triangle is opaque in the final image (with or without
   GL_CULL_FACE), so this needs no frame history.
2. They are clipped to the near plane and each coplanar group is rasterised shrunk as one
   union (a pixel only when wholly inside; shared edges leave no cracks), writing the farthest
   depth over the pixel (geometry/raster.py), then a max pyramid.
3. Node boxes are tested: hidden when the box is in front of no part of the occluders, i.e. its
   nearest depth is beyond the pyramid's max over a superset of its screen rectangle.
   Visible inner nodes whose rectangle touches covered pixels are expanded and retested.
4. The boxes of the triangles gathered from the surviving nodes get the same test.
Contract: never drops a triangle that the full world's item buffer shows (any resolution).
"""
from __future__ import annotations

import numpy as np

from ..geometry.raster import (box_rects, clip_near, fused_occluder_depth, pyramid, rect_query,
                               to_camera)
from .state import CullState
from .tree import Tree


class DepthBufferOcclusion:
    """`occlusion`: software depth buffer occlusion culling; refines state.nodes.

    width, height : depth buffer size in pixels (default 60 x 80, a quarter of 240 x 320)
    occluders     : budget of triangles rasterised per frame (whole coplanar groups)
    candidates    : size of the precomputed pool of largest triangles they are chosen from
    triangles     : also test each surviving triangle's box (a filter after the node pass)
    """

    name = "occlusion"
    cost = 50

    def __init__(self, width: int = 60, height: int = 80, occluders: int = 256,
                 candidates: int = 16384, triangles: bool = True):
        self.width, self.height = int(width), int(height)
        self.occluders, self.candidates = int(occluders), int(candidates)
        self.triangles = bool(triangles)
        if min(self.width, self.height, self.occluders, self.candidates) < 1:
            raise ValueError("occlusion needs positive width, height, occluders and candidates")
        self.last_buffer = None

    def prepare(self, tree: Tree) -> None:
        self.tree = tree
        world = tree.world
        count = min(self.candidates, world.triangle_count)
        pool = np.argsort(-world.areas, kind="stable")[:count]
        self.pool = pool
        self.pool_corners = world.corners[pool]
        self.pool_normals = world.normals[pool]
        self.pool_areas = world.areas[pool]
        self.pool_centroids = world.centroids[pool]
        # Coplanar groups (same rounded plane) are rasterised as one union, without cracks.
        offset = np.einsum("ij,ij->i", self.pool_normals, self.pool_corners[:, 0])
        key = np.column_stack([np.round(self.pool_normals, 6),
                               np.round(offset / max(tree.scale, 1e-300), 9)])
        _, self.pool_group = np.unique(key, axis=0, return_inverse=True)
        self.pool_group = self.pool_group.ravel()

    def select(self, camera) -> np.ndarray:
        """(K,) int64 positions in the pool of this frame's occluders: whole coplanar groups,
        best group (largest member solid angle) first, until `occluders` triangles."""
        eye = camera.eye
        d = self.pool_centroids - eye
        dist2 = np.einsum("ij,ij->i", d, d)
        facing = -np.einsum("ij,ij->i", self.pool_normals, self.pool_corners[:, 0] - eye)
        planes = camera.frustum_planes()
        dist = self.pool_corners @ planes[:, :3].T + planes[:, 3]  # (K, 3, 6)
        in_frustum = ~(dist < 0).all(axis=1).any(axis=1)
        usable = (facing > 0) & in_frustum
        score = np.where(usable, self.pool_areas * facing / np.maximum(dist2, 1e-300) ** 1.5, 0.0)
        groups = self.pool_group
        best = np.zeros(groups.max() + 1 if len(groups) else 0)
        np.maximum.at(best, groups, score)
        sizes = np.bincount(groups[usable], minlength=len(best))
        order = np.argsort(-best, kind="stable")
        order = order[best[order] > 0]
        take = order[(np.cumsum(sizes[order]) <= self.occluders)
                     | (np.arange(len(order)) < 4)]  # the 4 best groups in any case
        chosen = np.zeros(len(best), dtype=bool)
        chosen[take] = True
        return np.flatnonzero(chosen[groups] & usable)

    def depth_buffer(self, camera) -> tuple:
        """(H, W) occluder depth buffer for the camera, and the number of occluders drawn."""
        right, up, forward = camera.basis()
        rotation = np.stack([right, up, forward])
        chosen = self.select(camera)
        tris, source = clip_near(to_camera(self.pool_corners[chosen], camera.eye, rotation),
                                 camera.near, with_source=True)
        ty = np.tan(np.radians(camera.fov) / 2.0)
        buffer = fused_occluder_depth(tris, self.pool_group[chosen][source], self.width,
                                      self.height, ty * camera.aspect, ty)
        return buffer, len(chosen)

    def apply(self, state: CullState) -> None:
        tree, camera = self.tree, state.camera
        buffer, drawn = self.depth_buffer(camera)
        self.last_buffer = buffer
        covered = np.isfinite(buffer)
        state.count(f"{self.name}.occluders", drawn)
        state.count(f"{self.name}.pixels_covered", covered.sum())
        if not covered.any():
            return
        far_pyr, near_pyr = pyramid(buffer, np.maximum), pyramid(buffer, np.minimum)
        right, up, forward = camera.basis()
        rotation = np.stack([right, up, forward])
        ty = np.tan(np.radians(camera.fov) / 2.0)
        tx = ty * camera.aspect
        active = state.nodes
        kept, visited, hidden_count = [], 0, 0
        while len(active):
            x0, x1, y0, y1, zmin, testable = box_rects(
                tree.node_bounds[active], camera.eye, rotation, camera.near, tx, ty,
                self.width, self.height)
            far = rect_query(far_pyr, x0, x1, y0, y1, np.max)
            hidden = testable & (zmin > far)
            touches = ~testable | (rect_query(near_pyr, x0, x1, y0, y1, np.min) < np.inf)
            visited += len(active)
            hidden_count += int(hidden.sum())
            grow = ~hidden & touches & (tree.child_count[active] > 0)
            kept.append(active[~hidden & ~grow])
            kids, _ = tree.children(active[grow])
            active = kids[tree.nonempty[kids]]
        state.nodes = np.concatenate(kept) if kept else np.zeros(0, dtype=np.int64)
        state.count("nodes_visited", visited)
        state.count(f"{self.name}.nodes_tested", visited)
        state.count(f"{self.name}.nodes_culled", hidden_count)
        if self.triangles:
            state.filters.append(self._triangle_filter(state, far_pyr, rotation, tx, ty))

    def _triangle_filter(self, state, far_pyr, rotation, tx, ty):
        """Per-reference test of each surviving triangle's box against the same buffer."""
        world, camera = self.tree.world, state.camera

        def keep_of(ids):
            x0, x1, y0, y1, zmin, testable = box_rects(
                world.bounds[ids], camera.eye, rotation, camera.near, tx, ty,
                self.width, self.height)
            hidden = testable & (zmin > rect_query(far_pyr, x0, x1, y0, y1, np.max))
            state.count("triangles_tested", len(ids))
            state.count(f"{self.name}.refs_culled", hidden.sum())
            return ~hidden

        return keep_of

"""`occlusion`: a CPU software depth buffer at low resolution, in the style of Masked Occlusion
Culling (Hasselgren, Andersson, Akenine-Moller 2016) and the hierarchical Z-buffer (Greene 1993).

OpenGL ES 1.1 has no occlusion queries and no depth readback, so all of this runs on the CPU.
Each frame:
1. Occluders: the world's largest triangles (precomputed pool) that face the eye and reach the
   frustum, ranked by estimated solid angle A |n.d| / |d|^3 (d eye to centroid), best
   `occluders` taken. Any front-facing world triangle is opaque in the final image (with or
   without GL_CULL_FACE), so this needs no frame history.
2. They are clipped to the near plane and rasterised as one UNION (geometry/raster.py): a pixel
   is covered only when wholly inside it; edges are split at T-junctions beforehand, so shared
   edges, creases and T-junctions leave no cracks. Each covered pixel holds a depth bound >=
   the nearest occluder's depth everywhere over it. A sparse table answers exact
   "max depth over a pixel rectangle" queries.
3. Node boxes are tested: hidden when the box's nearest depth is beyond that maximum over its
   screen rectangle (plus the 24-bit depth buffer's resolution there), or the rectangle is off
   screen with the box in front. Visible inner nodes touching covered pixels are expanded.
4. Each triangle gathered from the surviving nodes gets the same test with its own vertices.
Contract: never drops a triangle that the full world's item buffer shows (any resolution).
"""
from __future__ import annotations

import numpy as np

from ..geometry.raster import (box_rects, max_table, point_rects, rect_max, split_edges,
                               to_camera, union_depth)
from ..partition.base import gather_ranges
from .state import CullState
from .tree import Tree

# Depth margin in units of z^2 / near: the GPU's 24-bit depth buffer resolves z^2 / near * 2^-24
# (window depth 1 - near / z); 64x that keeps z-fighting pairs visible.
ZBUFFER_MARGIN = 2.0 ** -18
# Occluders seen more edge-on than this (|cos| of the view angle) are skipped: their projected
# winding would be unreliable.
GRAZING = 1e-6


class DepthBufferOcclusion:
    """`occlusion`: software depth buffer occlusion culling; refines state.nodes.

    width, height : depth buffer size in pixels (default 60 x 80, a quarter of 240 x 320)
    occluders     : triangles rasterised per frame (the best by estimated solid angle)
    candidates    : size of the precomputed pool of largest triangles they are chosen from
    triangles     : also test each surviving triangle (a filter after the node pass)
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
        pool = pool[world.areas[pool] > 0]
        self.pool = pool
        self.pool_normals = world.normals[pool]
        self.pool_areas = world.areas[pool]
        self.pool_centroids = world.centroids[pool]
        corners = world.corners[pool]
        self.pool_corners = corners
        self.pool_radius = np.linalg.norm(corners - self.pool_centroids[:, None], axis=2).max(1)
        # Each point once, so shared corners project to bit-identical values.
        self.points, index = np.unique(corners.reshape(-1, 3), axis=0, return_inverse=True)
        self.pool_tri = index.reshape(-1, 3)
        tri, a, b = split_edges(self.points, self.pool_tri)
        self.piece_a, self.piece_b, self.piece_tri = a, b, tri
        self.piece_start = np.searchsorted(tri, np.arange(len(pool)), "left")
        self.piece_end = np.searchsorted(tri, np.arange(len(pool)), "right")
        # Planes by exact value: a group's members share one plane equation bit for bit.
        self.pool_offset = np.einsum("ij,ij->i", self.pool_normals, corners[:, 0])
        key = np.column_stack([self.pool_normals, self.pool_offset])
        _, group = np.unique(key, axis=0, return_inverse=True)
        self.pool_group = group.ravel()

    def select(self, camera) -> np.ndarray:
        """(K,) int64 positions in the pool of this frame's occluders, best first."""
        eye = camera.eye
        d = self.pool_centroids - eye
        dist2 = np.einsum("ij,ij->i", d, d)
        facing = -np.einsum("ij,ij->i", self.pool_normals, self.pool_corners[:, 0] - eye)
        planes = camera.frustum_planes()
        # Bounding spheres (centroid, farthest corner): loose is fine, only picks candidates.
        in_frustum = ((self.pool_centroids @ planes[:, :3].T + planes[:, 3])
                      >= -self.pool_radius[:, None]).all(axis=1)
        usable = (facing > GRAZING * np.sqrt(dist2)) & in_frustum
        score = np.where(usable, self.pool_areas * facing / np.maximum(dist2 ** 1.5, 1e-300),
                         0.0)
        good = np.flatnonzero(usable)
        if len(good) > self.occluders:
            good = good[np.argpartition(-score[good], self.occluders - 1)[:self.occluders]]
        return good[np.argsort(-score[good], kind="stable")]

    def depth_buffer(self, camera) -> tuple:
        """(H, W) occluder depth buffer for the camera, and the number of occluders drawn."""
        right, up, forward = camera.basis()
        rotation = np.stack([right, up, forward])
        chosen = self.select(camera)
        if not len(chosen):
            return np.full((self.height, self.width), np.inf), 0
        pieces = gather_ranges(np.arange(len(self.piece_tri)), self.piece_start[chosen],
                               self.piece_end[chosen])
        local = np.full(len(self.pool), -1, dtype=np.int64)
        local[chosen] = np.arange(len(chosen))
        # Split points may be other triangles' corners: project them too.
        used = np.unique(np.concatenate([self.pool_tri[chosen].ravel(), self.piece_a[pieces],
                                         self.piece_b[pieces]]))
        where = np.full(len(self.points), -1, dtype=np.int64)
        where[used] = np.arange(len(used))
        points = to_camera(self.points[used], camera.eye, rotation)
        # Camera-space planes n.x = d, d > 0 (n away from the eye), from the exact world planes.
        n = -self.pool_normals[chosen] @ rotation.T
        d = self.pool_normals[chosen] @ camera.eye - self.pool_offset[chosen]
        ty = np.tan(np.radians(camera.fov) / 2.0)
        buffer = union_depth(points, where[self.pool_tri[chosen]],
                             (local[self.piece_tri[pieces]], where[self.piece_a[pieces]],
                              where[self.piece_b[pieces]]),
                             self.pool_group[chosen], np.column_stack([n, d]), camera.near,
                             ty * camera.aspect, ty, self.width, self.height)
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
        table = max_table(buffer)
        area = np.zeros((self.height + 1, self.width + 1), dtype=np.int64)
        area[1:, 1:] = covered.cumsum(axis=0).cumsum(axis=1)
        right, up, forward = camera.basis()
        rotation = np.stack([right, up, forward])
        ty = np.tan(np.radians(camera.fov) / 2.0)
        tx = ty * camera.aspect
        margin = ZBUFFER_MARGIN / camera.near
        active = state.nodes
        kept, visited, hidden_count = [], 0, 0
        while len(active):
            x0, x1, y0, y1, zmin, testable = box_rects(
                tree.node_bounds[active], camera.eye, rotation, camera.near, tx, ty,
                self.width, self.height)
            far = rect_max(table, x0, x1, y0, y1)
            hidden = testable & (zmin > far + margin * far * far)
            touches = ~testable | (area[y1 + 1, x1 + 1] - area[y0, x1 + 1] - area[y1 + 1, x0]
                                   + area[y0, x0] > 0)
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
            state.filters.append(self._triangle_filter(state, table, rotation, tx, ty, margin))

    def _triangle_filter(self, state, table, rotation, tx, ty, margin):
        """Per-reference test of each surviving triangle against the same buffer: hidden when in
        front of the near plane and either off screen or behind the buffer over its rectangle."""
        world, camera = self.tree.world, state.camera

        def keep_of(ids):
            ids, back = np.unique(ids, return_inverse=True)
            cam = to_camera(world.vertices[world.triangles[ids]], camera.eye, rotation)
            x0, x1, y0, y1, zmin, testable, onscreen = point_rects(
                cam, camera.near, tx, ty, self.width, self.height)
            far = rect_max(table, x0, x1, y0, y1)
            hidden = testable & (~onscreen | (zmin > far + margin * far * far))
            state.count("triangles_tested", len(ids))
            state.count(f"{self.name}.triangles_culled", hidden.sum())
            return ~hidden[back.ravel()]

        return keep_of

"""`occlusion`: a CPU software depth buffer at low resolution, in the style of Masked Occlusion
Culling (Hasselgren, Andersson, Akenine-Moller 2016) and the hierarchical Z-buffer (Greene 1993).

OpenGL ES 1.1 has no occlusion queries and no depth readback, so all of this runs on the CPU.
Each frame:
1. Occluders: the world's largest triangles (precomputed pool) that face the eye and reach the
   frustum, ranked by estimated solid angle A |n.d| / |d|^3 (d eye to centroid), best
   `occluders` taken, each certainly front-facing also as the device rounds it (tbfc's bound).
   Any front-facing world triangle is opaque in the final image (with or without
   GL_CULL_FACE), so this needs no frame history.
2. They are clipped to the near plane and rasterised as one UNION (geometry/raster.py): a pixel
   is covered only when wholly inside it; edges are split at T-junctions beforehand, so shared
   edges, creases and T-junctions leave no cracks. Each covered pixel holds a depth bound >=
   the nearest occluder's depth everywhere over it. A sparse table answers exact
   "max depth over a pixel rectangle" queries.
3. Node boxes are tested: hidden when the box's nearest depth is beyond that maximum over its
   screen rectangle (plus the 24-bit depth buffer's resolution there), or the rectangle is off
   screen with the box in front. Visible inner nodes touching covered pixels are expanded.
4. Each triangle gathered from the surviving nodes gets the same test with its own vertices.
   Optionally (`self_occluders`) the survivors that certainly face the eye, nearest first, are
   rasterised too (objects hiding objects) and the test reruns against the pointwise minimum of
   both buffers (each bounds the nearest real surface, so their minimum does); optionally
   (`screen`) a triangle covering no pixel centre of the device's screen goes too.
Occluders are clipped slightly beyond the near plane (NEAR_RELATIVE plus device rounding), so
only parts the GPU certainly draws occlude: the item buffer sees through walls nearer than near.

Device rounding (issue 17). The device draws rounded vertices from a rounded eye: relative to
the eye every point moves by at most m = 2 device_move(arithmetic) per coordinate. A tested box
or triangle is taken with all its moves (rectangle grown by the projection of m, nearest depth
lowered by sqrt(3) m); an occluder point at depth z >= z_occ (the nearest occluder point, at
least the clip depth) shifts on screen by at most sqrt(3) m / z_occ (1 + tan) and recedes by at
most sqrt(3) m, so the rectangle grows by that shift too and the depth test gains sqrt(3) m.
Contract: never drops a triangle that the full world's item buffer shows (any resolution; with
`screen`, at that resolution), also when the device moves points by m (T-junction cracks of
that width excepted).
"""
from __future__ import annotations

import numpy as np

from ..geometry.raster import (box_rects, covers_no_sample, max_table, point_rects, rect_max,
                               split_edges, to_camera, union_depth)
from ..partition.base import gather_ranges
from .precision import device_move
from .state import CullState
from .tree import Tree
from .triangle_backface import (DEVICE_ABSOLUTE, DEVICE_RELATIVE, certainly_backfacing,
                                triangle_cross)

# Depth margin in units of z^2 / near: the GPU's 24-bit depth buffer resolves z^2 / near * 2^-24
# (window depth 1 - near / z); 64x that keeps z-fighting pairs visible.
ZBUFFER_MARGIN = 2.0 ** -18
# Occluders seen more edge-on than this (|cos| of the view angle) are skipped: their projected
# winding would be unreliable.
GRAZING = 1e-6
# Occluders are clipped this much (relative) beyond the near plane, plus the device's rounding.
NEAR_RELATIVE = 2.0 ** -10


class DepthBufferOcclusion:
    """`occlusion`: software depth buffer occlusion culling; refines state.nodes.

    width, height : depth buffer size in pixels (default 60 x 80, a quarter of 240 x 320)
    occluders     : large triangles rasterised per frame (the best by estimated solid angle)
    candidates    : size of the precomputed pool of largest triangles they are chosen from
    triangles     : also test each surviving triangle (a filter after the node pass)
    self_occluders: up to this many of the frame's surviving candidates that certainly face the
                    eye (objects' near sides), nearest first, are rasterised into a second
                    buffer for the triangle test; 0 turns it off
    screen        : (width, height) of the device's screen, or None. When given, the triangle
                    test also drops triangles that cover no pixel centre of that screen
                    (geometry.raster.covers_no_sample): safe only for that resolution, without
                    multisampling (the item buffer's), so it is off unless the caller says
    """

    name = "occlusion"
    cost = 50
    arithmetic = "float64"  # the Culler sets its mode: the device-rounding margin follows it

    def __init__(self, width: int = 60, height: int = 80, occluders: int = 256,
                 candidates: int = 16384, triangles: bool = True, self_occluders: int = 0,
                 screen=None):
        self.width, self.height = int(width), int(height)
        self.occluders, self.candidates = int(occluders), int(candidates)
        self.triangles = bool(triangles)
        self.self_occluders = int(self_occluders)
        if min(self.width, self.height, self.occluders, self.candidates) < 1:
            raise ValueError("occlusion needs positive width, height, occluders and candidates")
        if self.self_occluders < 0:
            raise ValueError("occlusion needs self_occluders >= 0")
        self.screen = None if screen is None else tuple(int(v) for v in screen)
        if self.screen is not None and (len(self.screen) != 2 or min(self.screen) < 1):
            raise ValueError(f"occlusion screen must be (width, height) > 0, got {screen!r}")
        self.last_buffer = None
        self.nearest = np.inf  # nearest depth of this frame's rasterised occluder points

    def prepare(self, tree: Tree) -> None:
        self.tree = tree
        world = tree.world
        count = min(self.candidates, world.triangle_count)
        pool = np.argsort(-world.areas, kind="stable")[:count]
        self.pool = pool = pool[world.areas[pool] > 0]  # world ids of the large-occluder pool
        self.pool_normals, self.pool_areas = world.normals[pool], world.areas[pool]
        self.pool_centroids, self.pool_v0 = world.centroids[pool], world.corners[pool, 0]
        self.pool_radius = np.linalg.norm(world.corners[pool] - self.pool_centroids[:, None],
                                          axis=2).max(1)
        # Every triangle can occlude: each point once, so shared corners project to
        # bit-identical values; edges split at every world vertex lying on them.
        corners = world.corners
        self.points, index = np.unique(corners.reshape(-1, 3), axis=0, return_inverse=True)
        self.tri_points = index.reshape(-1, 3)
        tri, a, b = split_edges(self.points, self.tri_points)
        self.piece_a, self.piece_b, self.piece_tri = a, b, tri
        ids = np.arange(world.triangle_count)
        self.piece_start = np.searchsorted(tri, ids, "left")
        self.piece_end = np.searchsorted(tri, ids, "right")
        # Planes by exact value: a group's members share one plane equation bit for bit.
        self.offsets = np.einsum("ij,ij->i", world.normals, corners[:, 0])
        key = np.column_stack([world.normals, self.offsets])
        _, group = np.unique(key, axis=0, return_inverse=True)
        self.groups = group.ravel()
        self.cross, self.abs_cross, self.edge_a, self.edge_b = triangle_cross(corners)
        self.magnitude = float(np.abs(world.vertices).max()) if world.vertices.size else 0.0

    def facing(self, ids, eye) -> np.ndarray:
        """(n,) bool: triangle certainly faces the eye, also as the device rounds it, and is not
        seen more edge-on than GRAZING (its projected winding is reliable).

        Errs toward False (not an occluder) by the device rounding bound delta per coordinate.
        ids : (n,) int64 world triangle ids;  eye : (3,) float64"""
        world = self.tree.world
        delta = DEVICE_RELATIVE * max(self.magnitude, float(np.abs(eye).max())) + DEVICE_ABSOLUTE
        # The flipped triangle (negated cross product) certainly faces away = this one faces.
        v0 = world.corners[ids, 0]
        sure = certainly_backfacing(-self.cross[ids], self.abs_cross[ids], self.edge_a[ids],
                                    self.edge_b[ids], v0, eye, delta)
        d = world.centroids[ids] - eye
        towards = -np.einsum("ij,ij->i", world.normals[ids], v0 - eye)
        return sure & (towards > GRAZING * np.sqrt(np.einsum("ij,ij->i", d, d)))

    def select(self, camera) -> np.ndarray:
        """(K,) int64 world ids of this frame's large occluders, best first."""
        eye, pool, centroids = camera.eye, self.pool, self.pool_centroids
        d = centroids - eye
        dist2 = np.einsum("ij,ij->i", d, d)
        facing = -np.einsum("ij,ij->i", self.pool_normals, self.pool_v0 - eye)
        planes = camera.frustum_planes()
        # Bounding spheres (centroid, farthest corner): loose is fine, only picks candidates.
        in_frustum = ((centroids @ planes[:, :3].T + planes[:, 3])
                      >= -self.pool_radius[:, None]).all(axis=1)
        usable = (facing > GRAZING * np.sqrt(dist2)) & in_frustum
        score = np.where(usable, self.pool_areas * facing / np.maximum(dist2 ** 1.5, 1e-300),
                         0.0)
        good = np.flatnonzero(usable)
        if len(good) > self.occluders:
            good = good[np.argpartition(-score[good], self.occluders - 1)[:self.occluders]]
        good = good[np.argsort(-score[good], kind="stable")]
        return pool[good[self.facing(pool[good], eye)]]

    def move(self, camera) -> float:
        """m: per-coordinate move of any point relative to the eye on the device (its own
        rounding and the eye's), at this world's and eye's scale."""
        scale = max(self.magnitude, float(np.abs(camera.eye).max()))
        return 2.0 * device_move(self.arithmetic, scale)

    def near_clip(self, camera) -> float:
        """Depth occluders are clipped at: beyond the near plane by more than the device's error
        in placing it (sqrt(3) m, and DEVICE_RELATIVE x scale as before), so only parts the GPU
        certainly draws occlude (it clips at `near`)."""
        scale = max(self.magnitude, float(np.abs(camera.eye).max()))
        return (camera.near * (1.0 + NEAR_RELATIVE)
                + max(DEVICE_RELATIVE * scale, 2.0 * self.move(camera)))

    def shift(self, camera, move: float) -> float:
        """Largest screen shift (x / z units) of a rasterised occluder point moved by `move` per
        coordinate: sqrt(3) move / z (1 + |x| / z) at z >= self.nearest; inf when too near."""
        reach = np.sqrt(3.0) * move
        z = self.nearest - reach
        if not z > 0:
            return np.inf
        ty = np.tan(np.radians(camera.fov) / 2.0)
        tangent = max(ty, ty * camera.aspect) * self.nearest / z + reach / z
        return reach / z * (1.0 + tangent)

    def rasterise(self, camera, chosen) -> np.ndarray:
        """(H, W) union depth buffer (geometry/raster.py) of world triangles `chosen` (K,) int64,
        which must certainly face the eye."""
        chosen = np.asarray(chosen, dtype=np.int64)
        if not len(chosen):
            return np.full((self.height, self.width), np.inf)
        right, up, forward = camera.basis()
        rotation = np.stack([right, up, forward])
        pieces = gather_ranges(np.arange(len(self.piece_tri)), self.piece_start[chosen],
                               self.piece_end[chosen])
        local = np.full(self.tree.world.triangle_count, -1, dtype=np.int64)
        local[chosen] = np.arange(len(chosen))
        # Split points may be other triangles' corners: project them too.
        used = np.unique(np.concatenate([self.tri_points[chosen].ravel(), self.piece_a[pieces],
                                         self.piece_b[pieces]]))
        where = np.full(len(self.points), -1, dtype=np.int64)
        where[used] = np.arange(len(used))
        points = to_camera(self.points[used], camera.eye, rotation)
        clip = self.near_clip(camera)
        self.nearest = min(self.nearest, max(clip, float(points[:, 2].min())))
        # Camera-space planes n.x = d, d > 0 (n away from the eye), from the exact world planes.
        normals = self.tree.world.normals[chosen]
        n = -normals @ rotation.T
        d = normals @ camera.eye - self.offsets[chosen]
        ty = np.tan(np.radians(camera.fov) / 2.0)
        return union_depth(points, where[self.tri_points[chosen]],
                           (local[self.piece_tri[pieces]], where[self.piece_a[pieces]],
                            where[self.piece_b[pieces]]),
                           self.groups[chosen], np.column_stack([n, d]), clip,
                           ty * camera.aspect, ty, self.width, self.height)

    def depth_buffer(self, camera) -> tuple:
        """(H, W) large-occluder depth buffer for the camera, and the number of occluders."""
        chosen = self.select(camera)
        return self.rasterise(camera, chosen), len(chosen)

    def apply(self, state: CullState) -> None:
        tree, camera = self.tree, state.camera
        self.nearest = np.inf
        buffer, drawn = self.depth_buffer(camera)
        self.last_buffer = buffer
        covered = np.isfinite(buffer)
        state.count(f"{self.name}.occluders", drawn)
        state.count(f"{self.name}.pixels_covered", covered.sum())
        right, up, forward = camera.basis()
        rotation = np.stack([right, up, forward])
        ty = np.tan(np.radians(camera.fov) / 2.0)
        tx = ty * camera.aspect
        margin = ZBUFFER_MARGIN / camera.near
        move = self.move(camera)
        recede = np.sqrt(3.0) * move  # an occluder point moves this much farther at most
        table = max_table(buffer) if covered.any() else None
        if table is not None:
            area = np.zeros((self.height + 1, self.width + 1), dtype=np.int64)
            area[1:, 1:] = covered.cumsum(axis=0).cumsum(axis=1)
            active = state.nodes
            kept, visited, hidden_count = [], 0, 0
            while len(active):
                x0, x1, y0, y1, zmin, testable = box_rects(
                    tree.node_bounds[active], camera.eye, rotation, camera.near, tx, ty,
                    self.width, self.height, move, self.shift(camera, move))
                far = rect_max(table, x0, x1, y0, y1)
                hidden = testable & (zmin > far + margin * far * far + recede)
                touches = ~testable | (area[y1 + 1, x1 + 1] - area[y0, x1 + 1]
                                       - area[y1 + 1, x0] + area[y0, x0] > 0)
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
        if self.triangles and (table is not None or self.self_occluders or self.screen):
            hidden = self._hidden_triangles(state, buffer, table, rotation, tx, ty, margin, move)
            state.filters.append(lambda ids: ~hidden[ids])

    def _hidden_triangles(self, state, buffer, table, rotation, tx, ty, margin,
                          move) -> np.ndarray:
        """(T,) bool over the world: surviving triangles hidden by the large occluders' buffer,
        or by a second buffer that adds the survivors certainly facing the eye, nearest first,
        or (with `screen`) covering no pixel centre. A triangle is hidden by a buffer when in
        front of the near plane and either off screen or behind the buffer's maximum over its
        rectangle (each grown by the device's moves, as for nodes)."""
        world, camera = self.tree.world, state.camera
        ids = np.unique(self.tree.refs(state.nodes))
        cam = to_camera(world.vertices[world.triangles[ids]], camera.eye, rotation)
        recede = np.sqrt(3.0) * move

        def rects():
            return point_rects(cam, camera.near, tx, ty, self.width, self.height, move,
                               self.shift(camera, move))

        x0, x1, y0, y1, zmin, testable, onscreen = rects()

        def behind(table_):
            far = rect_max(table_, x0, x1, y0, y1)
            return testable & (~onscreen | (zmin > far + margin * far * far + recede))

        hidden = behind(table) if table is not None else testable & ~onscreen
        state.count("triangles_tested", len(ids))
        if self.screen is not None:
            delta = DEVICE_RELATIVE * max(self.magnitude, float(np.abs(camera.eye).max()))
            empty = ~hidden & covers_no_sample(cam, camera.near, tx, ty, *self.screen,
                                               move=max(delta + DEVICE_ABSOLUTE, move))
            state.count(f"{self.name}.subpixel_culled", empty.sum())
            hidden |= empty
        if self.self_occluders:
            live = np.flatnonzero(~hidden & testable & onscreen)
            live = live[self.facing(ids[live], camera.eye)]
            if len(live) > self.self_occluders:  # nearest first: they hide the most
                live = live[np.argpartition(zmin[live], self.self_occluders - 1)
                            [:self.self_occluders]]
            state.count(f"{self.name}.self_occluders", len(live))
            if len(live):
                extra = self.rasterise(camera, ids[live])  # may lower self.nearest
                x0, x1, y0, y1, zmin, testable, onscreen = rects()
                hidden |= behind(max_table(np.minimum(buffer, extra)))
        state.count(f"{self.name}.triangles_culled", hidden.sum())
        mask = np.zeros(world.triangle_count, dtype=bool)
        mask[ids[hidden]] = True
        return mask

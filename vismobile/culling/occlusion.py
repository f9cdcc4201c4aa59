"""`occlusion`: a conservative tiled depth buffer on the CPU (culling/hiz/), in the style of
Masked Occlusion Culling (Hasselgren, Andersson, Akenine-Moller 2016) and the hierarchical
Z-buffer (Greene 1993).

OpenGL ES 1.1 has no occlusion queries and no depth readback, so all of this runs on the CPU.
Each frame:
1. Occluder candidates come from the frustum around the eye, never from a global pool: the
   frame's nodes (after vfc or portals), each replaced by its highest ancestor still small as
   seen from the eye (diagonal < `detail` x distance: coarse far away), offer their
   precomputed lists of their `candidates` largest triangles, plus last frame's best sent
   triangles (`observe`). The first round walks shells of distance from the eye, nearest
   first, until the lists offered `first_candidates` ids (the rooms around the eye; farther
   occluders come from the second round, out of what the first left visible). They are
   ranked by estimated solid angle A |n.d| / |d|^3 and the best `occluders` that certainly
   face the eye, also as the device rounds it (tbfc's bound), are rasterised. Any front-facing world triangle is opaque in the final image (with or
   without GL_CULL_FACE).
2. hiz.rasterise: per exact-plane group, a pixel counts only when wholly inside the union of the
   group's triangles (or, across a crease between groups, of both) clipped slightly beyond the
   near plane (NEAR_RELATIVE plus device rounding: only parts the GPU certainly draws
   occlude), with the plane's farthest depth over it; shared edges (both corners shared) leave
   no cracks, T-junctions stay boundaries (the GPU may leave a pixel open there). Tiles of
   `tile` pixels keep the farthest depth of their pixels.
3. Node boxes are tested (hiz.cull_nodes), entered from the tree's root through the
   ancestors of the frame's nodes, so hidden regions go at a coarse level: hidden when the
   box's nearest depth is beyond the largest depth over its screen rectangle (plus the 24-bit
   depth buffer's resolution there), or the rectangle is off screen with the box in front.
   Visible inner nodes touching covered tiles are expanded, except subtrees of at most
   `whole_refs` triangle references, kept whole for the triangle test (hiz.walks.
   walk_child_counts). With `rounds` > 1 the fused walk stops expanding after
   hiz.frame.WALK_BUDGET nodes (the nodes it kept unexpanded are
   refined after the rounds, never dropped untested). With `rounds` > 1, the surviving
   nodes (what is seen through doors and windows) offer occluders again, they are added to the
   buffer and the nodes are tested again.
4. Each triangle gathered from the surviving nodes gets the same test with its own vertices
   (hiz.hidden_triangles). Optionally (`self_occluders`) the survivors that certainly face the
   eye, nearest first, are rasterised too (objects hiding objects) and the test reruns;
   optionally (`screen`) a triangle covering no pixel centre of the device's screen goes too.
   With `screen` the triangle test (and the node test of boxes spanning a few pixels) reads
   only the buffer pixels near the screen's centres under the rectangle, within the local
   shift of the occluders over it (per tile, from their nearest depth there: hiz._centre_rect).

Over an animated partition the moving objects occlude too: after the node passes, the largest
moving objects in the frustum offer their triangles posed at this frame's time
(`extra_occluders`, culling/moving_occluders.py), rasterised, and the nodes are tested again.

Device rounding (issue 17). The device draws rounded vertices from a rounded eye: relative to
the eye every point moves by at most m = 2 device_move(arithmetic) per coordinate. A tested box
or triangle is taken with all its moves (rectangle grown by the projection of m, nearest depth
lowered by sqrt(3) m); an occluder point at depth z >= z_occ (the nearest occluder point, at
least the clip depth) shifts on screen by at most sqrt(3) m / z_occ (1 + tan) and recedes by at
most sqrt(3) m, so the rectangle grows by that shift too and the depth test gains sqrt(3) m.
The device's float32 transform also errs in depth: its normalised depth is off by up to m / z,
so it orders two surfaces only when they are a relative depth_order(m, near) apart; occluder
depths are pushed back by that much. When m >= 2 near (a near plane within the device's error
of the eye: near 1e-3 at a 1e5 offset in float32) it cannot order depths at all and may leave
any occluder undrawn: the buffer then hides nothing (`occlusion.unordered` counts such frames;
the frustum and the screen's centre test still apply).

Memory. On an in-memory World the stage slices whole-world tables (normals, areas, the
rasteriser's mesh); on any other world (a memory-mapped .vmp, mapped.MappedWorld) it keeps
nothing per triangle but a 1-bit candidate map: the node lists are read from the file (stored
by the out-of-core build) or built at prepare from each leaf's references and the corners
(partition/occluders.py), and each frame computes its candidates' scores and rows
(occluder_rows) and its occluders' mesh (occluder_rows.occluder_mesh_of) with the World's
bits, so both send the same triangles (tests).

DepthBufferOcclusion's mixins: the occluder choice (occluder_choice.py, OccluderChoice) and the
node and triangle tests against the buffer (occlusion_tests.py, BufferTests).

Contract: never drops a triangle that the full world's item buffer shows (any resolution; with
`screen`, at that resolution), also when the device moves points by m, and through the cracks
the GPU may leave at T-junctions (never counted as closed).
"""
from __future__ import annotations

import numpy as np

from ..partition.base import gather_ranges
from ..partition.occluders import candidate_lists
from ..world.world import World
from .backface import half_tangents
from .frustum import frustum_refine
from .hiz import (DEPTH_SLACK, GUARD_PX, SAMPLE_HALF, SLACK_PX, build_tiles, rasterise,
                  shift_table_size, stamp_near, tile_max_size, tile_shifts)
from .hiz.edges import buffer_length
from .hiz.frame import FRAME_SLOTS, occluder_shift, occlusion_frame, sample_clip
from .hiz.walks import WHOLE_REFS, walk_child_counts
from .occluder_choice import GRAZING, SHELL_GROWTH, OccluderChoice
from .occluder_mesh import world_tables
from .occluder_rows import occluder_mesh_of
from .occlusion_tests import BufferTests
from .precision import depth_order, device_move, world_scale
from .shared import per_object
from .state import CullResult, CullState
from .tree import Tree
from .triangle_backface import DEVICE_ABSOLUTE, DEVICE_RELATIVE, GAMMA_8

# Depth margin in units of z^2 / near: the GPU's 24-bit depth buffer resolves z^2 / near * 2^-24
# (window depth 1 - near / z); 64x that keeps z-fighting pairs visible.
ZBUFFER_MARGIN = 2.0 ** -18
# Occluders are clipped this much (relative) beyond the near plane, plus the device's rounding.
NEAR_RELATIVE = 2.0 ** -10
# With `screen`, per-tile (local) occluder shifts are computed only in frames whose global shift
# after the first occluders exceeds this many buffer pixels (thesis worlds: rarely); without,
# only when it exceeds hiz.GUARD_PX (the screen border's test needs them then).
LOCAL_SHIFT_PX = 0.25
# hiz.frame.occlusion_frame's counters, by slot; the first four are counted on every frame.
FRAME_COUNTERS = ("occlusion.occluders", "occlusion.pixels_covered", "occlusion.candidates",
                  "occlusion.candidate_nodes", "nodes_visited", "plane_tests",
                  "vfc.nodes_culled", "vfc.nodes_accepted", "occlusion.nodes_tested",
                  "occlusion.nodes_culled")


# The first round's candidate count (shells stop once the lists offered this many ids): the
# near rooms' walls; what shows through their openings comes in the second round. 96 against
# the former 256 (= occluders), W2 150 frames: 0.94x the time, sent 143.9 -> 142.2; w2x3:
# 0.78x, 215.3 -> 212.8; W1, W3-W6 0.91-1.0x, sent within +-0.5 (docs/culling-performance.md).
FIRST_CANDIDATES = 96
# `samples` is on by default (with a screen) from this many world triangles: tiled W2 at 923k
# sends 210 -> 154 a frame (1.94x -> 1.42x the visible set), W2 (102k) 141 -> 119 but at 1.9x
# the time there (docs/culling-performance.md, issue 32).
SAMPLES_FROM = 1 << 19


class DepthBufferOcclusion(BufferTests, OccluderChoice):
    """`occlusion`: conservative tiled depth buffer occlusion culling; refines state.nodes.

    width, height : depth buffer size in pixels (default 120 x 160, half of 240 x 320)
    tile          : (w, h) pixels per tile of the coarse buffer (default 8 x 4)
    occluders     : triangles rasterised per frame (the best candidates by solid angle)
    candidates    : largest triangles listed per node (the candidates a node offers)
    detail        : a node offers its list once its diagonal is below detail x its distance
    rounds        : rasterise-then-cull rounds; each round after the first takes its occluders
                    from the nodes the previous one left (what is seen through openings)
    triangles     : also test each surviving triangle (a filter after the node pass)
    self_occluders: up to this many of the frame's surviving candidates that certainly face the
                    eye (objects' near sides), nearest first, are rasterised too before the
                    triangle test; 0 turns it off
    screen        : (width, height) of the device's screen, or None. When given, the triangle
                    test also drops triangles that cover no pixel centre of that screen
                    (hiz._no_sample), and the buffer tests read only the pixels under the
                    centres a triangle or small box may cover (hiz._centre_rect): safe only
                    for that resolution, without multisampling (the item buffer's), so it is
                    off unless the caller says
    fuse          : with `vfc` as the only other node stage, test the frustum in the first node
                    pass (hiz.frustum_cull_nodes, one walk from the root: hidden subtrees are
                    never entered); occluder candidates then come from the root's frustum walk
                    (Culler._fuse). False: vfc walks first, the node pass re-enters its nodes
    first_candidates: the first round takes its candidates from the nodes nearest the eye
                    only: shells of distance from the smallest leaf's diagonal, each sqrt(2)
                    wider, until their lists offered this many ids (default FIRST_CANDIDATES;
                    None: `occluders`; 0: the whole frustum). What shows through the near rooms' openings offers occluders
                    in the second round. The reach follows the scene and the tree, not world
                    units (docs/culling-performance: faster and tighter on tiled W2)
    first_reach   : None, or a depth (world units) overriding first_candidates: the first
                    round takes its candidates only from nodes nearer than it
    samples       : with `screen`, a buffer of the screen's size (width and height ignored)
                    whose pixels bound the occluders over the SAMPLE_HALF neighbourhood of
                    their centres only, not their whole squares (the GPU writes only at
                    centres): coverage and depth close to a centre-sampled buffer's, within the
                    occluders' screen shift. Occluders are clipped where their shift would
                    exceed it (sample_clip), so every test stays conservative at that
                    resolution. None (default): on with a screen for worlds of SAMPLES_FROM
                    triangles or more, where far detail seen through openings is most of what
                    is sent and the buffer's cost is small beside the node passes
    """

    name = "occlusion"
    cost = 50
    # The usual frame (vfc deferred, in-memory World, shells) in one compiled call with the same
    # decisions (hiz.frame); False runs the Python path it mirrors (tests compare the two).
    compiled = True
    # Subtrees of at most this many references are walked as one node (hiz.walks).
    whole_refs = WHOLE_REFS
    arithmetic = "float64"  # the Culler sets its mode: the device-rounding margin follows it

    def __init__(self, width: int = 120, height: int = 160, tile=(8, 4), occluders: int = 256,
                 candidates: int = 8, detail: float = 0.125, rounds: int = 2,
                 triangles: bool = True, self_occluders: int = 0, screen=None,
                 fuse: bool = True, first_reach=None, first_candidates=FIRST_CANDIDATES,
                 samples=None):
        if samples not in (None, True, False):
            raise ValueError(f"occlusion samples must be True, False or None, got {samples!r}")
        if samples and screen is None:
            raise ValueError("occlusion samples needs a screen")
        self.samples_option = samples  # None: decided at prepare (SAMPLES_FROM)
        self.sampled, self.half = False, 0.5
        self.width, self.height = int(width), int(height)
        self._size = (self.width, self.height)  # the buffer's without samples
        self.tile = tuple(int(v) for v in tile)
        self.occluders, self.candidates = int(occluders), int(candidates)
        self.detail = float(detail)
        self.rounds = int(rounds)
        if self.rounds < 1:
            raise ValueError("occlusion needs rounds >= 1")
        self.triangles = bool(triangles)
        self.fuse = bool(fuse)
        self.first_reach = None if first_reach is None else float(first_reach)
        if self.first_reach is not None and not self.first_reach > 0:
            raise ValueError("occlusion needs first_reach > 0 (or None)")
        self.first_candidates = (int(occluders) if first_candidates is None
                                 else int(first_candidates))
        if self.first_candidates < 0:
            raise ValueError("occlusion needs first_candidates >= 0 (or None)")
        self.self_occluders = int(self_occluders)
        if min(self.width, self.height, self.occluders, self.candidates) < 1:
            raise ValueError("occlusion needs positive width, height, occluders and candidates")
        if len(self.tile) != 2 or min(self.tile) < 1:
            raise ValueError(f"occlusion tile must be (width, height) > 0, got {tile!r}")
        if not self.detail > 0:
            raise ValueError("occlusion needs detail > 0")
        if self.self_occluders < 0:
            raise ValueError("occlusion needs self_occluders >= 0")
        self.screen = None if screen is None else tuple(int(v) for v in screen)
        if self.screen is not None and (len(self.screen) != 2 or min(self.screen) < 1):
            raise ValueError(f"occlusion screen must be (width, height) > 0, got {screen!r}")
        self.nearest = np.inf  # nearest depth of this frame's rasterised occluder points
        self.history = np.zeros(0, dtype=np.int64)
        self.frame_occluders = np.zeros(0, dtype=np.int64)  # this frame's rasterised ids
        self._frame = 0
        self._view_of = self._view_now = None
        # None, or a weak reference (weakref.WeakMethod) to a function (state, stage) ->
        # rasteriser tables or None: a Culler over an animated partition sets it to offer this
        # frame's posed moving objects as occluders (moving_occluders.py)
        self.extra_occluders = None

    def prepare(self, tree: Tree) -> None:
        self.tree = tree
        world = tree.world
        count = world.triangle_count
        self.sampled = self.screen is not None and (
            count >= SAMPLES_FROM if self.samples_option is None else bool(self.samples_option))
        self.half = SAMPLE_HALF if self.sampled else 0.5
        # with samples the screen's pixels, each bounded near its centre
        self.width, self.height = self.screen if self.sampled else self._size
        # Read per candidate from the world (float64 in memory, or a float32 mapped file).
        self.vertices, self.triangles_ = np.asarray(world.vertices), np.asarray(world.triangles)
        self.magnitude = world_scale(self.vertices)
        # An in-memory World keeps whole-world tables (rows and the rasteriser's mesh are sliced
        # per frame); any other world (mapped.MappedWorld) computes them per frame for the
        # candidates and occluders only (occluder_rows, occluder_mesh): same bits, same result.
        self.tables = isinstance(world, World)
        if self.tables:
            (self.points, self.tri_points, self.normals, self.offsets, self.groups,
             self.piece_start, self.piece_end, self.piece_a, self.piece_b, self.partner,
             self.partner_any, self.areas, self.centroids, self.v0, self.radius) = per_object(
                world, "occlusion", lambda: world_tables(world))
            self.stamp = np.full(count, -1, dtype=np.int64)
        # Candidate lists: each node's largest triangles, (N, k), nothing per triangle kept;
        # read from the file when its build stored at least k a node (the first k columns:
        # partition/occluders.py), else from each leaf's references and their corners.
        stored = tree.partition.extras.get("occluders")
        if stored is not None and len(stored) == tree.node_count \
                and stored.shape[1] >= self.candidates:
            self.lists = np.ascontiguousarray(stored[:, :self.candidates], dtype=np.int64)
        else:
            self.lists = per_object(tree.partition, ("candidates", self.candidates),
                                    lambda: candidate_lists(
                                        tree.first_child, tree.child_count, tree.ref_start,
                                        tree.ref_end, tree.tri_refs, self.vertices,
                                        self.triangles_, self.candidates))
        # Scratch, allocated once: frames reuse it.
        pixels = self.width * self.height
        tw, th = self.tile
        self._cols, self._rows = (self.width + tw - 1) // tw, (self.height + th - 1) // th
        self.tiles = self._cols * self._rows
        # The bounds, then room for the edge records of a frame's occluders' pieces (hiz.edges:
        # the triangle test reads them at the screen's centres; the sample buffer's pixels are
        # the screen's, bounded near their centres: none there).
        records = 0 if self.sampled else 3 * self.occluders * self.rounds
        self.depth = np.full(buffer_length(pixels, records) if records else pixels, np.inf)
        self.mask = np.zeros(pixels, dtype=np.uint8)
        self.centre = np.zeros(pixels, dtype=np.uint8)
        self.crease_far = np.zeros(pixels)
        self.tile_max = np.full(tile_max_size(self._rows, self._cols), np.inf)  # + blocks
        self.tile_any = np.zeros(self.tiles, dtype=np.bool_)
        self.tile_min = np.full(self.tiles, np.inf)
        # Per tile the nearest rasterised occluder depth over it and the largest screen shift
        # of an occluder point there (the tests' local shift).
        self.tile_near = np.full(self.tiles, np.inf)
        self.tile_shift = np.full(shift_table_size(self._rows, self._cols), np.inf)
        self._shift_written = False  # tile_near / tile_shift hold a frame's values (else inf)
        self._local = None
        self.bits = np.zeros(count // 64 + 1, dtype=np.uint64)  # candidates' dedup, 1 bit each
        self._stack = np.empty(tree.node_count + 64, dtype=np.int64)
        self._masks = np.empty(tree.node_count + 64, dtype=np.int64)
        self._below = np.empty(tree.node_count + 64, dtype=np.uint8)
        self.parent = np.full(tree.node_count, -1, dtype=np.int64)
        inner = np.flatnonzero(tree.child_count > 0)
        self.parent[gather_ranges(np.arange(tree.node_count), tree.first_child[inner],
                                  tree.first_child[inner] + tree.child_count[inner])] = \
            np.repeat(inner, tree.child_count[inner])
        # The walks' child counts: small subtrees taken whole (hiz.walks.walk_child_counts).
        self.walk_children = walk_child_counts(tree.child_count, tree.ref_start, tree.ref_end,
                                               self.whole_refs)
        self.draw_mark = np.full(tree.node_count, -1, dtype=np.int64)
        self.up_mark = np.full(tree.node_count, -1, dtype=np.int64)
        self._out = np.empty(tree.node_count + 64, dtype=np.int64)
        self._cands = np.empty(self.lists.size + self.occluders, dtype=np.int64)
        self._later = np.empty(tree.node_count + 64, dtype=np.int64)
        self._roots = np.empty(tree.node_count + 64, dtype=np.int64)
        # The first round's candidate shells start at the smallest leaf's diagonal (the finest
        # scale the tree resolves); self.reach is this frame's last shell (inf: whole frustum).
        leaves = (tree.child_count == 0) & tree.nonempty
        diagonal = np.linalg.norm(tree.hi[leaves] - tree.lo[leaves], axis=1)
        self.shell = float(diagonal[diagonal > 0].min()) if (diagonal > 0).any() else 1.0
        self.reach = np.inf

    def observe(self, result: CullResult) -> None:
        """Keeps the best `occluders` of the frame's sent triangles (ranked from this frame's
        eye) as next frame's extra candidates: cost follows what was sent."""
        camera = getattr(self, "_camera", None)
        if camera is None or not len(result.triangles):
            self.history = np.zeros(0, dtype=np.int64)
            return
        ids = np.ascontiguousarray(result.triangles, dtype=np.int64)
        self.history = self.best(ids, np.asarray(camera.eye, dtype=np.float64), self._planes,
                                 self.occluders).copy()

    def move(self, camera) -> float:
        """m: per-coordinate move of any point relative to the eye on the device (its own
        rounding and the eye's), at this world's and eye's scale."""
        return self._view(camera)[4]

    def near_clip(self, camera) -> float:
        """Depth occluders are clipped at: beyond the near plane by more than the device's error
        in placing it (sqrt(3) m, and DEVICE_RELATIVE x scale as before), so only parts the GPU
        certainly draws occlude (it clips at `near`)."""
        return self._view(camera)[5]

    def _view(self, camera) -> tuple:
        """(eye (3,), rotation (3, 3) rows right, up, forward, tx, ty, move, near clip, scale,
        depth_order slack) of the camera, computed once per camera (cameras are frozen; a frame
        asks many times)."""
        if camera is self._view_of:
            return self._view_now
        tx, ty = half_tangents(camera.fov, camera.aspect)
        scale = max(self.magnitude, *map(abs, camera.position))
        move = 2.0 * device_move(self.arithmetic, scale)
        clip = camera.near * (1.0 + NEAR_RELATIVE) + max(DEVICE_RELATIVE * scale, 2.0 * move)
        if self.half < 0.5:
            clip = sample_clip(clip, move, tx, ty, self.width, self.height, self.half)
        self._view_of = camera
        self._view_now = (camera.eye, np.array(camera.axes()), tx, ty, move, clip, scale,
                          depth_order(move, camera.near))
        return self._view_now

    def mesh(self, chosen) -> tuple:
        """(order, the rasteriser's tables, stamp) for world triangles `chosen` (K,) int64:
        order indexes the tables' triangles sorted by plane group (stable). On an in-memory
        World the world's tables with order = chosen sorted; else occluder_mesh of the chosen
        triangles alone (occluder_rows.occluder_mesh_of, local ids 0..K-1): points, groups and
        pieces match by exact value as in the world's, so the rasteriser sees the same
        triangles, planes and shared edges."""
        if self.tables:
            order = chosen[np.argsort(self.groups[chosen], kind="stable")]
            return (order, self.groups, self.tri_points, self.points, self.normals, self.offsets,
                    self.piece_start, self.piece_end, self.piece_a, self.piece_b, self.partner,
                    self.partner_any, self.stamp)
        (points, tri_points, normals, offsets, groups, piece_start, piece_end, piece_a, piece_b,
         partner, partner_any) = occluder_mesh_of(chosen, self.vertices, self.triangles_)
        order = np.argsort(groups, kind="stable").astype(np.int64)
        return (order, groups, tri_points, points, normals, offsets, piece_start, piece_end,
                piece_a, piece_b, partner, partner_any, np.full(len(chosen), -1, np.int64))

    def rasterise(self, camera, chosen) -> int:
        """Adds world triangles `chosen` (K,) int64 (they must certainly face the eye) to the
        depth buffer and rebuilds the tiles; returns pixels newly covered."""
        return self.rasterise_tables(camera, self.mesh(np.ascontiguousarray(chosen,
                                                                           dtype=np.int64)))

    def rasterise_tables(self, camera, tables) -> int:
        """rasterise for the tables of mesh's form (any triangles certainly facing the eye:
        world ids, or moving objects' posed triangles, culling/moving_occluders.py)."""
        eye, rotation, tx, ty, move, clip, _, order = self._view(camera)
        self._frame += 1
        nearest, written = rasterise(*tables, self._frame, eye, rotation, clip, tx, ty,
                                     self.width, self.height, self.depth, self.mask,
                                     self.centre, self.crease_far, DEPTH_SLACK + order,
                                     self.half)
        self.nearest = min(self.nearest, nearest)
        if self._local is None:  # the frame's first occluders: is a local shift worth it?
            pixels = self.shift(camera, move) * 0.5 * max(self.width / tx, self.height / ty)
            self._local = bool(pixels > (GUARD_PX if self.screen is None else LOCAL_SHIFT_PX))
        if self._local:  # else the table stays inf: the global shift everywhere
            self._shift_written = True
            stamp_near(tables[0], tables[2], tables[3], eye, rotation, clip, tx, ty, self.width,
                       self.height, *self.tile, self.tile_near)
            tile_shifts(self.tile_near, np.sqrt(3.0) * move, max(tx, ty), self._rows,
                        self._cols, self.tile_shift)
        build_tiles(self.depth, self.width, self.height, *self.tile, self.tile_max,
                    self.tile_any, self.tile_min)
        return written

    def apply(self, state: CullState) -> None:
        tree, camera = self.tree, state.camera
        fused, state.frustum_pending = state.frustum_pending, False  # vfc deferred to this walk
        self._camera, self._planes = camera, np.ascontiguousarray(state.planes)
        self.nearest = np.inf
        self.depth.fill(np.inf)
        if self._shift_written:  # no local bound until the table is built (most W2 frames
            self.tile_near.fill(np.inf)  # never build it: 115 kB not rewritten)
            self.tile_shift.fill(np.inf)
            self._shift_written = False
        self._local = None
        self.reach = np.inf if self.first_reach is None else self.first_reach
        if not self._view(camera)[7] < np.inf:  # the device cannot order depths: no occluder
            self._unordered(state, fused)
            return
        if self.compiled and fused and self.tables and self.first_reach is None \
                and self.first_candidates > 0:
            self._apply_compiled(state)  # the same kernels in one call
            return
        chosen = self.select(state, reach=self.first_reach, limit=self.first_candidates)
        written = self.rasterise(camera, chosen) if len(chosen) else 0
        if not len(chosen):
            self.tile_max.fill(np.inf)
            self.tile_min.fill(np.inf)
            self.tile_any.fill(False)
        state.count(f"{self.name}.occluders", len(chosen))
        state.count(f"{self.name}.pixels_covered", written)
        eye, rotation, tx, ty, move = self._view(camera)[:5]
        margin = ZBUFFER_MARGIN / camera.near
        recede = np.sqrt(3.0) * move  # an occluder point moves this much farther at most
        if not written and fused:  # nothing occludes: the frustum walk alone
            state.nodes = frustum_refine(tree, state, "vfc")
        if written:
            # refined: no node is left deferred by the fused walk's budget (hiz.frame)
            refined = not self._node_pass(state, eye, rotation, tx, ty, move, margin, recede,
                                          fused=fused)
            for _ in range(self.rounds - 1 if not np.isfinite(self.tile_max).all() else 0):
                # Occluders seen through what is still open: the surviving nodes' largest
                # triangles (far walls behind doors and windows), then the nodes again.
                extra = self.select(state, history=np.zeros(0, np.int64), skip=chosen)
                if not len(extra):
                    break
                chosen = np.concatenate([chosen, extra])
                state.count(f"{self.name}.occluders", len(extra))
                more = self.rasterise(camera, extra)
                state.count(f"{self.name}.pixels_covered", more)
                if not more:
                    break
                self._node_pass(state, eye, rotation, tx, ty, move, margin, recede, False)
                refined = True
            if not refined:
                self._node_pass(state, eye, rotation, tx, ty, move, margin, recede, False)
        self.frame_occluders = chosen  # read by tools (bench_peers' MOC rows); not a copy
        written += self._moving_occluders(state)
        self._triangle_filter(state, written, move, margin, recede)

    def _moving_occluders(self, state) -> int:
        """The frame's moving occluders (`extra_occluders`, set by a Culler over an animated
        partition: culling/moving_occluders.py, posed at this frame's time) into the buffer,
        then the frame's nodes tested again against it; returns the pixels they covered."""
        offer = None if self.extra_occluders is None else self.extra_occluders()
        if offer is None:
            return 0
        tables = offer(state, self)
        if tables is None:
            return 0
        camera = state.camera
        state.count(f"{self.name}.moving_occluders", len(tables[0]))
        written = self.rasterise_tables(camera, tables)
        state.count(f"{self.name}.pixels_covered", written)
        if written and len(state.nodes):
            eye, rotation, tx, ty, move = self._view(camera)[:5]
            self._node_pass(state, eye, rotation, tx, ty, move, ZBUFFER_MARGIN / camera.near,
                            np.sqrt(3.0) * move, False)
        return written

    def _triangle_filter(self, state, written, move, margin, recede) -> None:
        if self.triangles and (written or self.self_occluders or self.screen):
            def keep_of(ids):
                return ~self._hidden_triangles(state, ids, move, margin, recede, written > 0)
            state.late_filters.append(keep_of)

    def _apply_compiled(self, state) -> None:
        """apply's path with vfc deferred on an in-memory World (shells, no first_reach) in one
        compiled call (hiz.frame.occlusion_frame: the same kernels, the same decisions)."""
        arguments, move, margin, recede = self._frame_arguments(state.camera)
        stats = np.zeros(FRAME_SLOTS, dtype=np.int64)
        (kept, self._frame, self.nearest, self.reach, chosen, self._out, self._stack,
         self._below, local) = occlusion_frame(*arguments, stats)
        self._shift_written = local == 1
        self._local = None if local < 0 else bool(local)
        for name, value in zip(FRAME_COUNTERS[:4] if kept < 0 else FRAME_COUNTERS, stats):
            state.count(name, value)
        self.frame_occluders = chosen
        written = stats[1]
        state.nodes = (frustum_refine(self.tree, state, "vfc") if kept < 0
                       else self._out[:kept].copy())
        written += self._moving_occluders(state)
        self._triangle_filter(state, written, move, margin, recede)

    def _frame_arguments(self, camera) -> tuple:
        """(arguments, move, margin, recede): hiz.frame.occlusion_frame's arguments for camera
        up to and with the frame number (occlusion_chain.chained_frame takes the same first),
        against self._planes; move, margin and recede as the triangle test takes them."""
        tree = self.tree
        eye, rotation, tx, ty, move, clip, _, order = self._view(camera)
        eye = np.asarray(eye, dtype=np.float64)
        margin, recede = ZBUFFER_MARGIN / camera.near, np.sqrt(3.0) * move
        delta = DEVICE_RELATIVE * max(self.magnitude, *map(abs, eye)) + DEVICE_ABSOLUTE
        arguments = (
            tree.lo, tree.hi, tree.first_child, self.walk_children, tree.nonempty, self.parent,
            tree.tol, self.vertices, self.triangles_, self.normals, self.v0, self.centroids,
            self.radius, self.areas, self.groups, self.tri_points, self.points, self.offsets,
            self.piece_start, self.piece_end, self.piece_a, self.piece_b, self.partner,
            self.partner_any, self.stamp, self.lists, self.history, self.bits, self._cands,
            self._stack, self._later, self._out, self._masks, self._below, self._roots,
            self.up_mark, self.draw_mark, self._planes, eye, rotation, camera.near, tx, ty, move,
            clip, order, self.half, margin, recede, delta, GAMMA_8, GRAZING, self.detail,
            self.shell, self.first_candidates, SHELL_GROWTH, self.occluders, self.rounds,
            self.width, self.height, *self.tile, self.depth, self.mask, self.centre,
            self.crease_far, self.tile_max, self.tile_any, self.tile_min, self.tile_near,
            self.tile_shift, GUARD_PX if self.screen is None else LOCAL_SHIFT_PX,
            *self.samples(camera, move), self._frame)
        return arguments, move, margin, recede

    def _unordered(self, state, fused) -> None:
        """The frame without a buffer (depth_order is inf): the deferred frustum walk, and with
        `screen` the triangles covering no pixel centre; nothing else is dropped."""
        state.count(f"{self.name}.unordered", 1)
        self.frame_occluders = np.zeros(0, dtype=np.int64)
        self.tile_max.fill(np.inf)
        self.tile_min.fill(np.inf)
        self.tile_any.fill(False)
        if fused:
            state.nodes = frustum_refine(self.tree, state, "vfc")
        if self.triangles and self.screen:
            move = self._view(state.camera)[4]
            state.late_filters.append(lambda ids: ~self._hidden_triangles(
                state, ids, move, 0.0, np.sqrt(3.0) * move, False))

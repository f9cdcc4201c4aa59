"""`portals`: cells-and-portals traversal (Luebke & Georges 1995, "Portals and Mirrors") for the
portal octree, whose cells are the voxels of an irregular grid, each with its own octree.

Starting in the eye's cell with the whole screen, the traversal walks through portals; the
region of the screen through which a cell can be seen is the intersection of the region of the
cell it is entered from with the portal's screen rectangle (a conservative bound of the convex
portal polygon). A cell reached along several paths keeps the bounding rectangle of their
union. Each visited cell's octree is then frustum-culled with the frustum narrowed to its
rectangle (4 planes through the eye, plus near and far), all cells at once, level by level.

The portals cover every part of a shared face a sight line from free space can cross; they
block hollow walls, slabs and closed objects (partition/portal.py). So the traversal runs only
for an eye in free space: no triangle's box within the near plane's reach (the near plane
clips nearer geometry, so the item buffer sees through it), and six axis rays from the eye
(Moller-Trumbore against the triangles along each axis line) each hit a triangle from its
front or meet nothing (at most MAX_ESCAPES of them, or any number when the ray down meets a
front: an eye standing over the ground or a floor, outdoors). An eye seeing a back face or
mostly nothing (inside a wall or a slab, past a slab's edge), an eye near a surface, an eye outside
every cell, or a partition without portals falls back to plain `vfc` (portals.fallbacks).

Device rounding. The device draws corners and eye moved by up to m = sqrt(3) device_move
(precision.py) each, in the Culler's arithmetic mode. Shifting a device sight line by the eye's
move gives a line from the exact eye that passes within D = 2 m of every portal it crossed and
ends within D of the exact triangle; so each portal's rectangle bounds its polygon grown by a
ball of radius D (a portal within D of the eye's plane takes the whole current rectangle), the
cell frusta's four side planes are pushed out by D plus the frustum margin, and the eye must be
D farther from every triangle's box to count as in free space. At a 1e5 offset in float32, D
is about 0.33: eyes that close to a wall fall back to `vfc`. A near plane within the device's
move of the eye (near <= device_move: 0.095 at 1e5 in float32) falls back too: the device then
cannot place the near plane or order depths (at 1e5 in float32 with near 1e-3 its item buffer
is mostly background or far rooms seen through walls), so no wall certainly hides anything.

Doors (issue 25, culling/doors.py): a closed door - a closed box at rest, not moved this frame
- blocks the portals wholly inside it (deeper than the device's moves) for an eye outside it
beyond the near plane's reach; an open or moving door blocks nothing (use_doors).

Cracks (culling/portal_cracks.py): where two cell faces closed by walls meet in a crease whose
edges do not share corners (a T-junction), the rasteriser may leave pixels open and the item
buffer shows what lies behind, though no portal leads there. With `cracks` (default: over
cells on both faces of every wall, portal walls=true) each frame follows the unshared edges
in the reached cells: every line through such a gap lies in a thin sliver from the eye, which
floods the cells beyond across their faces (through only their portals where their walls face
the line) and walks them with its own planes.

Contract: conservative for free-space eyes provided the portals cover every opening between
cells, and, with cracks on, for gaps within pvs_cracks' crack width of an unshared edge; portal rectangles err outward (by RECT_SLACK and the device's moves), a portal that
crosses the eye's plane widens to the whole current rectangle; every other eye gets plain `vfc`.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from ..geometry.boxes import boxes_contain_point
from ..geometry.planes import planes_through_eye
from ..geometry.raster import to_camera
from ..geometry.ray import EDGE_TOLERANCE, ray_hit_t
from .doors import blocked, closed_doors, door_pairs
from .frustum import frustum_refine, frustum_traverse
from .portal_cracks import CrackSlivers
from .precision import device_move, margin, world_scale
from ..partition.portal import THICKNESS
from ..partition.pvs_cracks import CRACK_SLOPE
from .state import CullState
from .tree import Tree

EXTRAS = ("cell_node", "cell_bounds", "portal_cells", "portal_start", "portal_vertices",
          "cell_portal_start", "cell_portals")
RECT_SLACK = 1e-7  # NDC units added around every rectangle
MAX_ESCAPES = 2  # axis rays from a free-space eye that may meet nothing (through windows)
GROUND_ESCAPES = True  # ... or any number when the ray down hits a front face (outdoors)


def portal_rects(vertices, starts, eye, rotation, tx: float, ty: float,
                 grow: float = 0.0) -> tuple:
    """Screen rectangles of convex portal polygons grown by a ball of radius `grow` (world
    units): (rects (P, 4) float64 u0, u1, v0, v1 in NDC, state (P,) int8: 0 visible rectangle,
    1 wholly behind the eye's plane by more than grow (invisible), 2 within grow of it or
    crossing it (rectangle unknown: use the whole current region)).

    Errs outward: bounds of the projected grown vertices, plus RECT_SLACK.
    vertices : (M, 3) float64;  starts : (P + 1,) int64 offsets of each polygon in vertices
    """
    starts = np.asarray(starts, dtype=np.int64)
    count = len(starts) - 1
    rects = np.tile([-1.0, 1.0, -1.0, 1.0], (count, 1))
    state = np.full(count, 2, dtype=np.int8)
    if count == 0:
        return rects, state
    cam = to_camera(vertices, eye, rotation)
    z = cam[:, 2]
    zmin = np.minimum.reduceat(z, starts[:-1])
    zmax = np.maximum.reduceat(z, starts[:-1])
    # The ball's projection lies within the box [x +- grow] x [z +- grow]'s: x / z is monotone
    # in x, and in z for z > 0, so its bounds are at the box's corners.
    near, far = z - grow, z + grow
    near = np.where(near > 0, near, 1.0)
    bounds = []
    for coord, t in ((cam[:, 0], tx), (cam[:, 1], ty)):
        low, high = coord - grow, coord + grow
        bounds.append(np.minimum(low / near, low / far) / t)
        bounds.append(np.maximum(high / near, high / far) / t)
    u0, u1, v0, v1 = bounds
    rects = np.column_stack([np.minimum.reduceat(u0, starts[:-1]) - RECT_SLACK,
                             np.maximum.reduceat(u1, starts[:-1]) + RECT_SLACK,
                             np.minimum.reduceat(v0, starts[:-1]) - RECT_SLACK,
                             np.maximum.reduceat(v1, starts[:-1]) + RECT_SLACK])
    state = np.where(zmin > grow, 0, np.where(zmax < -grow, 1, 2)).astype(np.int8)
    return rects, state


@njit(cache=True, nogil=True)
def flood_cells(rect, starts, cell_portal_start, cell_portals, portal_cells, prects, pstates):
    """Spread screen regions from the start cells through the portals until nothing grows:
    rect[c] becomes the bounding rectangle of every path's region into c (a cell entered with
    region r through portal p gets r clipped to p's rectangle, or r itself when pstates[p] is
    2; never through a portal with pstates[p] 1). Errs outward: bounding rectangles of unions.

    rect   : (C, 4) float64 u0, u1, v0, v1, in/out: the starts' regions set, others empty
             (u0 > u1);  starts : (K,) int64;  prects, pstates : portal_rects' output
    returns the number of (cell, portal) pairs tested
    """
    stack = np.empty(max(16, 4 * len(rect)), dtype=np.int64)
    top = 0
    for k in range(len(starts)):
        stack[top] = starts[k]
        top += 1
    tested = 0
    while top > 0:
        top -= 1
        c = stack[top]
        h0, h1, h2, h3 = rect[c, 0], rect[c, 1], rect[c, 2], rect[c, 3]
        for q in range(cell_portal_start[c], cell_portal_start[c + 1]):
            p = cell_portals[q]
            tested += 1
            if pstates[p] == 1:
                continue
            r0, r1, r2, r3 = h0, h1, h2, h3
            if pstates[p] == 0:
                r0, r1 = max(r0, prects[p, 0]), min(r1, prects[p, 1])
                r2, r3 = max(r2, prects[p, 2]), min(r3, prects[p, 3])
            if r0 > r1 or r2 > r3:
                continue
            other = portal_cells[p, 1] if portal_cells[p, 0] == c else portal_cells[p, 0]
            n0, n1 = min(rect[other, 0], r0), max(rect[other, 1], r1)
            n2, n3 = min(rect[other, 2], r2), max(rect[other, 3], r3)
            if n0 != rect[other, 0] or n1 != rect[other, 1] or n2 != rect[other, 2] \
                    or n3 != rect[other, 3]:
                rect[other, 0], rect[other, 1], rect[other, 2], rect[other, 3] = n0, n1, n2, n3
                if top == len(stack):
                    bigger = np.empty(2 * len(stack), dtype=np.int64)
                    bigger[:top] = stack
                    stack = bigger
                stack[top] = other
                top += 1
    return tested


@njit(cache=True, nogil=True, inline="always")
def _box_holds(bounds, k, eye, grow, axes):
    """bounds[k] grown by `grow` holds the eye on the given axes (closed)."""
    for a in axes:
        if not (bounds[k, 0, a] - grow <= eye[a] and eye[a] <= bounds[k, 1, a] + grow):
            return False
    return True


@njit(cache=True, nogil=True)
def _axis_hits(eye, axis, sign, tol, cell_bounds, cell_node, ref_start, ref_end, tri_refs,
               tri_bounds, corners, normals, nearest):
    """Along the ray from the eye in direction sign * axis, over the triangles of the cells the
    axis line crosses: the nearest hit t when nearest is inf (first pass), else whether a
    triangle hit within tol of `nearest` is seen from behind or edge-on (second pass)."""
    others = (1, 2) if axis == 0 else ((0, 2) if axis == 1 else (0, 1))
    d = np.zeros(3)
    d[axis] = sign
    best = np.inf
    for c in range(len(cell_node)):
        if not _box_holds(cell_bounds, c, eye, tol, others):
            continue
        node = cell_node[c]
        for r in range(ref_start[node], ref_end[node]):
            tri = tri_refs[r]
            if not _box_holds(tri_bounds, tri, eye, tol, others):
                continue
            t = ray_hit_t(eye[0], eye[1], eye[2], d[0], d[1], d[2], corners[tri],
                          EDGE_TOLERANCE)
            if np.isinf(nearest):
                best = min(best, t)
            elif np.isfinite(t) and t <= nearest + tol and sign * normals[tri, axis] >= 0:
                return 1.0
    return best if np.isinf(nearest) else 0.0


@njit(cache=True, nogil=True)
def free_space(eye, reach, tol, max_escapes, ground, cell_bounds, cell_node, ref_start, ref_end,
               tri_refs, tri_bounds, corners, normals):
    """PortalStage.eye_in_free_space over flat arrays (reach already grown by tol): no
    triangle box within reach, and each of the six axis rays first hits a front face or
    escapes, at most max_escapes escaping unless `ground` and the ray down (-y) hits a front
    face. Errs toward False (see the method)."""
    every = (0, 1, 2)
    for c in range(len(cell_node)):
        if not _box_holds(cell_bounds, c, eye, reach, every):
            continue
        node = cell_node[c]
        for r in range(ref_start[node], ref_end[node]):
            if _box_holds(tri_bounds, tri_refs[r], eye, reach, every):
                return False
    nearest = np.empty((3, 2))
    for axis in range(3):
        for k, sign in enumerate((1.0, -1.0)):
            nearest[axis, k] = _axis_hits(eye, axis, sign, tol, cell_bounds, cell_node,
                                          ref_start, ref_end, tri_refs, tri_bounds, corners,
                                          normals, np.inf)
    # more escapes only over ground: the ray down must hit (a front face, checked below)
    if np.isinf(nearest).sum() > max_escapes and not (ground and np.isfinite(nearest[1, 1])):
        return False
    for axis in range(3):
        for k, sign in enumerate((1.0, -1.0)):
            if np.isfinite(nearest[axis, k]) and _axis_hits(
                    eye, axis, sign, tol, cell_bounds, cell_node, ref_start, ref_end, tri_refs,
                    tri_bounds, corners, normals, nearest[axis, k]) > 0:
                return False
    return True


def rect_planes(rects, camera, push: float = 0.0, limits=None) -> np.ndarray:
    """(K, 6, 4) float64 frustum planes narrowed to NDC rectangles (K, 4): four through the eye,
    pushed out by `push` (world units), then near and far: limits (2, 4) (the Culler's
    conservative frustum planes [4:]) or the camera's own. Errs outward by push."""
    right, up, forward = camera.basis()
    ty = np.tan(np.radians(camera.fov) / 2.0)
    tx = ty * camera.aspect
    rects = np.asarray(rects, dtype=np.float64).reshape(-1, 4)
    u0, u1 = rects[:, 0] - RECT_SLACK, rects[:, 1] + RECT_SLACK  # never a zero-width pyramid
    v0, v1 = rects[:, 2] - RECT_SLACK, rects[:, 3] + RECT_SLACK
    us = np.stack([u0, u1, u1, u0], axis=1)  # (K, 4)
    vs = np.stack([v0, v0, v1, v1], axis=1)
    dirs = forward + (us * tx)[..., None] * right + (vs * ty)[..., None] * up
    out = np.empty((len(rects), 6, 4))
    out[:, :4] = planes_through_eye(camera.eye, dirs)
    out[:, :4, 3] += push
    out[:, 4:] = camera.frustum_planes()[4:] if limits is None else limits
    return out


def subtree_sizes(partition) -> np.ndarray:
    """(N,) int64 nodes in each node's subtree (itself included); levels breadth-first, each
    node's children contiguous in the next level."""
    first, count = partition.first_child, partition.child_count
    size = np.ones(len(first), dtype=np.int64)
    levels = partition.level_start
    for k in range(len(levels) - 2, 0, -1):  # level k - 1's nodes sum their children's
        parents = np.arange(levels[k - 1], levels[k])
        parents = parents[first[parents] >= 0]
        cum = np.concatenate([[0], np.cumsum(size)])
        starts = first[parents].astype(np.int64)
        size[parents] += cum[starts + count[parents]] - cum[starts]
    return size


class PortalStage:
    """`portals`: cells-and-portals traversal, then vfc per visited cell; replaces `vfc`."""

    name = "portals"
    cost = 5
    arithmetic = "float64"  # the Culler sets its mode: the device-rounding margin follows it
    back_culled = True  # the Culler sets it: a back-face stage runs (crack slivers pass walls
    # seen from behind only then; True errs toward passing)

    def __init__(self, cracks=None):
        """cracks: follow the rasteriser's cracks (culling/portal_cracks.py) - True, False,
        or None (default): only over cells on both faces of every wall (portal walls=true),
        whose faces meet in T-junction creases; automatic cells keep the slab's crease in an
        open band (about 1.8x the cull time where on: docs/dynamic.md)."""
        if cracks is not None and not isinstance(cracks, (bool, np.bool_)):
            raise ValueError(f"portals cracks must be true, false or None, got {cracks!r}")
        self.crack_option = cracks

    def prepare(self, tree: Tree) -> None:
        self.tree = tree
        extras = tree.partition.extras or {}
        self.available = all(key in extras for key in EXTRAS) and len(extras["cell_node"]) > 0
        if self.available:
            self.x = {key: np.asarray(extras[key]) for key in EXTRAS}
            self.cell_node = self.x["cell_node"].astype(np.int64)
            world = tree.world
            self.corners, self.normals, self.bounds = world.corners, world.normals, world.bounds
            self.magnitude = world_scale(world.vertices)  # no abs copy of a mapped world
            bounds = np.asarray(self.x["cell_bounds"], dtype=np.float64)
            self.cell_lo = np.ascontiguousarray(bounds[:, 0])
            self.cell_hi = np.ascontiguousarray(bounds[:, 1])
            self.portal_vertices = np.ascontiguousarray(self.x["portal_vertices"],
                                                        dtype=np.float64)
            size = float(np.ptp(world.extent, axis=0).max())
            thickness = float(tree.partition.params.get("thickness", THICKNESS * size))
            # pieces within twice the widest crack of an eye in the world box (crack_reach)
            self.crack_reach = 2.0 * CRACK_SLOPE * float(np.linalg.norm(
                np.ptp(world.extent, axis=0))) + thickness
            self.crack_slivers = bool(tree.partition.params.get("walls", False)) \
                if self.crack_option is None else bool(self.crack_option)
            self.cracks = CrackSlivers(world, extras, thickness, self.crack_reach) \
                if self.crack_slivers else None
            self.cell_subtree = subtree_sizes(tree.partition)[self.cell_node]
        self.frame_cells = None  # this frame's visible cells (None: it fell back to vfc)
        if not self.available:
            self.crack_slivers, self.cracks = False, None
        self.door_boxes = None  # use_doors: rest boxes (D, 2, 3) of the doors in portals
        self.door_matrices = None  # this frame's door matrices (D, 4, 4), set per frame

    def use_doors(self, boxes) -> None:
        """Doors (culling/doors.py): closed outward boxes (D, 2, 3) at rest; each frame,
        `door_matrices` (D, 4, 4) set before apply says where they stand (None: all open).
        A closed door blocks the portals wholly inside its box (doors.blocked)."""
        self.door_boxes = np.asarray(boxes, dtype=np.float64).reshape(-1, 2, 3)
        self.door_pairs = door_pairs(self.x["portal_vertices"], self.x["portal_start"],
                                     self.door_boxes) if self.available else None

    def eye_in_free_space(self, eye, reach: float) -> bool:
        """True when no triangle's box comes within `reach` of the eye and each of the six axis
        rays from the eye either first hits a triangle's front or escapes; at most MAX_ESCAPES
        escape, or any number when the ray down hits a front face (GROUND_ESCAPES: an eye on
        a street over the ground sees the sky and the street's two ends).

        Errs toward False: a back face among the triangles hit within the slack of the nearest
        one counts. Single-sided surfaces face free space, so from inside a hollow wall, a slab
        or a closed object a ray meets a back face; an eye past the edge of a slab (nothing
        around it) sees nothing in most directions, a room's eye escapes only through windows; an
        eye over the front of a ground or floor is not past an edge, whatever else it sees.
        The near plane clips what lies closer than `reach`, so an eye that close to a wall sees
        through it.
        eye : (3,) float64;  reach : float, distance of the near plane's corners from the eye
        """
        tree = self.tree
        return free_space(np.asarray(eye, dtype=np.float64), reach + tree.tol, tree.tol,
                          MAX_ESCAPES, GROUND_ESCAPES, self.x["cell_bounds"], self.cell_node, tree.ref_start,
                          tree.ref_end, tree.tri_refs, self.bounds, self.corners, self.normals)

    def _cracks_reach(self, camera, grow: float) -> bool:
        """The cells' stored crack pieces hold every crack this eye may see through: the
        widest gap (grow + CRACK_SLOPE x the farthest cell corner's distance) is within the
        reach they were clipped with (an eye far outside the world falls back to vfc)."""
        eye = np.asarray(camera.eye, dtype=np.float64)
        low, high = self.tree.world.extent
        farthest = float(np.linalg.norm(np.maximum(np.abs(eye - low), np.abs(high - eye))))
        return grow + CRACK_SLOPE * farthest <= self.crack_reach

    def device_reach(self, camera) -> tuple:
        """(D, push): how far the device's rounding can move a sight line relative to the exact
        eye (2 sqrt(3) device_move: eye and point), and the cell frusta's side-plane push
        (D plus the frustum margin), for coordinates up to the world's and the eye's."""
        scale = max(self.magnitude, float(np.abs(camera.eye).max()))
        reach = 2.0 * np.sqrt(3.0) * device_move(self.arithmetic, scale)
        return reach, reach + margin(self.arithmetic, scale)

    def apply(self, state: CullState) -> None:
        tree, camera = self.tree, state.camera
        cells = self.visible_cells(camera, state) if self.available else None
        self.frame_cells = None if cells is None else cells[0]  # read by moving.py
        if cells is None:
            state.count(f"{self.name}.fallbacks", 1)
            state.nodes = frustum_refine(tree, state, self.name)
            return
        ids, rects = cells
        state.count(f"{self.name}.cells_visited", len(ids))
        grow, push = self.device_reach(camera)
        planes = rect_planes(rects, camera, push, state.planes[4:])
        nodes = frustum_traverse(tree, self.cell_node[ids], planes, np.arange(len(ids)), state,
                                 self.name)
        if self.cracks is not None:
            x = self.x
            slivers, met, met_sets = self.cracks.frame(
                camera, ids, planes, grow, push, float(tree.tol),
                (x["cell_portal_start"], x["cell_portals"], x["portal_cells"],
                 x["portal_start"], self.portal_vertices, *self._portals), self.back_culled)
            state.count(f"{self.name}.crack_slivers", len(slivers))
            self.frame_cells = np.union1d(ids, met)  # moving objects seen through a crack
            # a walk accepts at most its roots' subtrees' nodes, and Tree.walk's buffer holds
            # the tree's: walks of consecutive roots whose subtrees add up to at most that
            ends = np.cumsum(self.cell_subtree[met])
            cuts = np.searchsorted(ends, np.arange(1, ends[-1] // tree.node_count + 2)
                                   * tree.node_count, side="right") if len(met) else []
            walks = [nodes]
            for lo, hi in zip(np.concatenate([[0], cuts]), np.concatenate([cuts, [len(met)]])):
                if hi > lo:
                    walks.append(frustum_traverse(tree, self.cell_node[met[lo:hi]], slivers,
                                                  met_sets[lo:hi], state, self.name))
            nodes = np.concatenate(walks)
        state.nodes = nodes

    def visible_cells(self, camera, state: CullState):
        """(cell ids (V,), rects (V, 4)) reached through portals, or None when the eye is in
        no cell, not in free space (also once the device moves it: see device_reach), or
        nearer to the near plane than the device's move."""
        x = self.x
        grow = self.device_reach(camera)[0]
        if camera.near <= grow / (2.0 * np.sqrt(3.0)):  # near within the device's move
            return None
        # the device's eye may sit in any cell within its move of the exact eye
        starts = np.flatnonzero(boxes_contain_point(x["cell_bounds"], camera.eye,
                                                    self.tree.tol + grow))
        ty = np.tan(np.radians(camera.fov) / 2.0)
        reach = camera.near * np.sqrt(1.0 + ty * ty * (1.0 + camera.aspect ** 2)) + grow
        if not len(starts) or not self.eye_in_free_space(np.asarray(camera.eye, np.float64),
                                                         reach):
            return None
        if self.crack_slivers and not self._cracks_reach(camera, grow):
            return None
        right, up, forward = camera.basis()
        prect, pstate = portal_rects(x["portal_vertices"], x["portal_start"], camera.eye,
                                     np.stack([right, up, forward]), ty * camera.aspect, ty,
                                     grow)
        if self.door_boxes is not None and self.door_matrices is not None:
            closed, slack = closed_doors(self.door_matrices)
            scale = max(self.magnitude, float(np.abs(camera.eye).max()))
            shut = blocked(*self.door_pairs, self.door_boxes, closed, slack * (scale + 1.0),
                           camera.eye, reach, 1.5 * grow)  # grow + the device's move of a door
            pstate = pstate.copy()
            pstate[shut] = 1
            state.count(f"{self.name}.portals_shut", len(shut))
        count = len(x["cell_node"])
        rect = np.tile([np.inf, -np.inf, np.inf, -np.inf], (count, 1))
        rect[starts] = [-1.0, 1.0, -1.0, 1.0]
        tested = flood_cells(rect, starts.astype(np.int64), x["cell_portal_start"],
                             x["cell_portals"], x["portal_cells"], prect, pstate)
        state.count(f"{self.name}.portals_tested", tested)
        self._portals = (pstate,)  # the crack slivers cross portals too (not shut doors)
        ids = np.flatnonzero(rect[:, 0] <= rect[:, 1])
        return ids, rect[ids]

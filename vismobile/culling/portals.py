"""`portals`: cells-and-portals traversal (Luebke & Georges 1995, "Portals and Mirrors") for the
portal octree, whose cells are the voxels of an irregular grid, each with its own octree.

Starting in the eye's cell with the whole screen, the traversal walks through portals; the
region of the screen through which a cell can be seen is the intersection of the region of the
cell it is entered from with the portal's screen rectangle (a conservative bound of the convex
portal polygon). A cell reached along several paths keeps the bounding rectangle of their
union. Each visited cell's octree is then frustum-culled with the frustum narrowed to its
rectangle (4 planes through the eye, plus near and far), all cells at once, level by level.
The eye outside every cell (or a partition without portals) falls back to plain `vfc`.

Contract: conservative provided the partition's portals cover every opening between cells
(geometry-free parts of shared faces); portal rectangles err outward, a portal that crosses the
eye's plane widens to the whole current rectangle.
"""
from __future__ import annotations

import numpy as np

from ..geometry.boxes import boxes_contain_point
from ..geometry.planes import planes_through_eye
from ..geometry.raster import to_camera
from .frustum import frustum_traverse
from .state import CullState
from .tree import Tree

EXTRAS = ("cell_node", "cell_bounds", "portal_cells", "portal_start", "portal_vertices",
          "cell_portal_start", "cell_portals")
RECT_SLACK = 1e-7  # NDC units added around every rectangle


def portal_rects(vertices, starts, eye, rotation, tx: float, ty: float) -> tuple:
    """Screen rectangles of convex portal polygons: (rects (P, 4) float64 u0, u1, v0, v1 in NDC,
    state (P,) int8: 0 visible rectangle, 1 wholly behind the eye (invisible), 2 crosses the
    eye's plane (rectangle unknown: use the whole current region)).

    Errs outward: bounds of the projected vertices grown by RECT_SLACK.
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
    zsafe = np.where(z > 0, z, 1.0)
    u, v = cam[:, 0] / (zsafe * tx), cam[:, 1] / (zsafe * ty)
    rects = np.column_stack([np.minimum.reduceat(u, starts[:-1]) - RECT_SLACK,
                             np.maximum.reduceat(u, starts[:-1]) + RECT_SLACK,
                             np.minimum.reduceat(v, starts[:-1]) - RECT_SLACK,
                             np.maximum.reduceat(v, starts[:-1]) + RECT_SLACK])
    state = np.where(zmin > 0, 0, np.where(zmax <= 0, 1, 2)).astype(np.int8)
    return rects, state


def rect_planes(rects, camera) -> np.ndarray:
    """(K, 6, 4) float64 frustum planes narrowed to NDC rectangles (K, 4): four through the eye,
    then the camera's near and far planes (exact for the rectangle)."""
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
    out[:, 4:] = camera.frustum_planes()[4:]
    return out


class PortalStage:
    """`portals`: cells-and-portals traversal, then vfc per visited cell; replaces `vfc`."""

    name = "portals"
    cost = 5

    def prepare(self, tree: Tree) -> None:
        self.tree = tree
        extras = tree.partition.extras or {}
        self.available = all(key in extras for key in EXTRAS) and len(extras["cell_node"]) > 0
        if self.available:
            self.x = {key: np.asarray(extras[key]) for key in EXTRAS}

    def apply(self, state: CullState) -> None:
        tree, camera = self.tree, state.camera
        cells = self.visible_cells(camera, state) if self.available else None
        if cells is None:
            state.count(f"{self.name}.fallback", 1)
            roots = state.nodes
            state.nodes = frustum_traverse(tree, roots, state.planes[None],
                                           np.zeros(len(roots), dtype=np.int64), state, self.name)
            return
        ids, rects = cells
        state.count(f"{self.name}.cells_visited", len(ids))
        state.nodes = frustum_traverse(tree, self.x["cell_node"][ids].astype(np.int64),
                                       rect_planes(rects, camera), np.arange(len(ids)), state,
                                       self.name)

    def visible_cells(self, camera, state: CullState):
        """(cell ids (V,), rects (V, 4)) reached through portals, or None when the eye is in
        no cell."""
        x = self.x
        starts = np.flatnonzero(boxes_contain_point(x["cell_bounds"], camera.eye, self.tree.tol))
        if not len(starts):
            return None
        right, up, forward = camera.basis()
        ty = np.tan(np.radians(camera.fov) / 2.0)
        prect, pstate = portal_rects(x["portal_vertices"], x["portal_start"], camera.eye,
                                     np.stack([right, up, forward]), ty * camera.aspect, ty)
        count = len(x["cell_node"])
        rect = np.tile([np.inf, -np.inf, np.inf, -np.inf], (count, 1))
        rect[starts] = [-1.0, 1.0, -1.0, 1.0]
        queue, tested = list(starts), 0
        cps, cp, pcells = x["cell_portal_start"], x["cell_portals"], x["portal_cells"]
        while queue:  # loop over visible portals
            c = queue.pop()
            here = rect[c]
            for p in cp[cps[c]:cps[c + 1]]:
                tested += 1
                if pstate[p] == 1:
                    continue
                r = here.copy() if pstate[p] == 2 else np.array([
                    max(here[0], prect[p, 0]), min(here[1], prect[p, 1]),
                    max(here[2], prect[p, 2]), min(here[3], prect[p, 3])])
                if r[0] > r[1] or r[2] > r[3]:
                    continue
                a, b = pcells[p]
                other = b if a == c else a
                old = rect[other]
                new = np.array([min(old[0], r[0]), max(old[1], r[1]),
                                min(old[2], r[2]), max(old[3], r[3])])
                if not np.array_equal(new, old):
                    rect[other] = new
                    queue.append(other)
        state.count(f"{self.name}.portals_tested", tested)
        ids = np.flatnonzero(rect[:, 0] <= rect[:, 1])
        return ids, rect[ids]

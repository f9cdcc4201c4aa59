"""Which occluders the `occlusion` stage rasterises (a mixin of DepthBufferOcclusion): each
frame's candidates from the node lists around the eye and last frame's history, ranked by
estimated solid angle, kept when they certainly face the eye. Only chooses occluders: never
affects safety, except `facing`, which errs toward False (an occluder must certainly face the
eye, also as the device rounds it).
"""
from __future__ import annotations

import numpy as np

from .hiz import (facing_occluders, gather_candidates, gather_shell_candidates, lod_ancestors,
                  score_candidates)
from .hiz.frame import top_scored
from .occluder_rows import score_corners, triangle_rows
from .state import CullState
from .triangle_backface import DEVICE_ABSOLUTE, DEVICE_RELATIVE, GAMMA_8

# Occluders seen more edge-on than this (|cos| of the view angle) are skipped: their projected
# winding would be unreliable.
GRAZING = 1e-6
# The first round's candidate shells grow by this factor (hiz.gather_shell_candidates).
SHELL_GROWTH = np.sqrt(2.0)


class OccluderChoice:
    """The occluder choice of DepthBufferOcclusion (which sets up the tables, lists and scratch
    these methods read in its prepare)."""

    def rows(self, ids) -> tuple:
        """(index (n,), normals, v0, centroids, radius, areas) for ids (n,) int64: the tables
        and ids on an in-memory World, else the rows computed from the corners (occluder_rows)
        and arange(n); row index[k] belongs to ids[k]."""
        if self.tables:
            return ids, self.normals, self.v0, self.centroids, self.radius, self.areas
        return (np.arange(len(ids), dtype=np.int64),
                *triangle_rows(ids, self.vertices, self.triangles_))

    def facing(self, ids, eye) -> np.ndarray:
        """(n,) bool: triangle certainly faces the eye, also as the device rounds it, and is not
        seen more edge-on than GRAZING (its projected winding is reliable).

        Errs toward False (not an occluder) by the device rounding bound delta per coordinate.
        ids : (n,) int64 world triangle ids;  eye : (3,) float64"""
        ids = np.ascontiguousarray(ids, dtype=np.int64)
        eye = np.asarray(eye, dtype=np.float64)
        delta = DEVICE_RELATIVE * max(self.magnitude, *map(abs, eye)) + DEVICE_ABSOLUTE
        index, normals, v0, centroids, _, _ = self.rows(ids)
        return facing_occluders(ids, self.vertices, self.triangles_, index, normals, v0,
                                centroids, eye, delta, GAMMA_8, GRAZING)

    def best(self, ids, eye, planes, count) -> np.ndarray:
        """(<= count,) int64 of ids with the largest positive estimated solid angle, best first."""
        ids = np.ascontiguousarray(ids, dtype=np.int64)
        planes = np.ascontiguousarray(planes, dtype=np.float64)
        eye = np.asarray(eye, dtype=np.float64)
        if self.tables:
            score = score_candidates(*self.rows(ids), planes, eye, GRAZING)
        else:  # rows from the corners on the way, nothing stored
            score = score_corners(ids, self.vertices, self.triangles_, planes, eye, GRAZING)
        return top_scored(ids, score, count)

    def select(self, state: CullState, roots=None, history=None, skip=None,
               reach=None, limit=0) -> np.ndarray:
        """(K,) int64 world ids of this frame's occluders, best first: candidates of
        the walk from `roots` (default: the tree's root, coarse far away) and `history`
        (default: last frame's), not in `skip`; with `reach`, only nodes nearer than that depth
        (the walk's far plane pulled in); else with `limit` > 0, only nodes in the nearest
        shells of distance (from the smallest leaf's diagonal, growing by SHELL_GROWTH) that
        offer `limit` ids (hiz.gather_shell_candidates; self.reach is the last shell). Which
        occluders are chosen never affects safety."""
        tree, camera = self.tree, state.camera
        eye = np.asarray(camera.eye, dtype=np.float64)
        self._frame += 1
        if roots is None:  # the frame's nodes, coarsened far away
            count = lod_ancestors(np.ascontiguousarray(state.nodes, dtype=np.int64),
                                  self.parent, tree.lo, tree.hi, eye, self.detail,
                                  self.up_mark, self._frame, self._out)
            roots = self._out[:count].copy()
        roots = np.ascontiguousarray(roots, dtype=np.int64)
        history = self.history if history is None else history
        if len(roots) + tree.node_count > len(self._stack):
            self._stack = np.empty(len(roots) + tree.node_count, dtype=np.int64)
            self._below = np.empty(len(roots) + tree.node_count, dtype=np.uint8)
        skip = np.zeros(0, np.int64) if skip is None else np.ascontiguousarray(skip, np.int64)
        need = self.lists.size + len(history)
        if need > len(self._cands):
            self._cands = np.empty(need, dtype=np.int64)
        planes = np.array(state.planes, dtype=np.float64)
        if reach is not None and reach < camera.far:  # planes[5] is the far plane (camera.py)
            planes[5, 3] -= (camera.far - reach) * np.linalg.norm(planes[5, :3])
        if limit and reach is None:  # nearest shells first, until `limit` ids were offered
            if len(roots) + tree.node_count > len(self._later):
                self._later = np.empty(len(roots) + tree.node_count, dtype=np.int64)
            found, visited, self.reach = gather_shell_candidates(
                tree.lo, tree.hi, tree.first_child, self.walk_children, tree.nonempty, roots,
                planes, tree.tol, eye, self.detail, self.lists, history, skip, self.bits,
                self._cands, self._stack, self._later, self.shell, limit, SHELL_GROWTH)
        else:
            found, visited = gather_candidates(tree.lo, tree.hi, tree.first_child,
                                               self.walk_children, tree.nonempty, roots, planes,
                                               tree.tol, eye, self.detail, self.lists, history,
                                               skip, self.bits, self._cands, self._stack)
        state.count(f"{self.name}.candidates", found)
        state.count(f"{self.name}.candidate_nodes", visited)
        chosen = self.best(self._cands[:found], eye, state.planes, self.occluders)
        return chosen[self.facing(chosen, eye)]


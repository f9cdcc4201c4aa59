"""The `occlusion` stage's buffer tests (a mixin of DepthBufferOcclusion, culling/occlusion.py):
node boxes (hiz.cull_nodes, or hiz.frustum_cull_nodes with the deferred frustum walk) and the
gathered triangles (hiz.hidden_triangles, then the `self_occluders` rerun) against the frame's
depth buffer, with the occluders' screen shift under the device's rounding and, with `screen`,
the pixel-centre tests' arguments.

Contract: the kernels' (errs toward keeping: a box or triangle is hidden only when every point
it may cover under the device's moves lies beyond the buffer's depth there, plus the 24-bit
margin and the occluders' recede), as culling/occlusion.py states for the stage.
"""
from __future__ import annotations

import numpy as np

from .hiz import cull_nodes, frustum_cull_nodes, hidden_triangles
from .hiz.frame import WALK_BUDGET
from .hiz.walks import NO_BUDGET
from .triangle_backface import DEVICE_ABSOLUTE, DEVICE_RELATIVE


class BufferTests:
    """The buffer tests of DepthBufferOcclusion (which sets up the buffer, tiles and scratch
    these methods read in its prepare, and the per-camera view in _view)."""

    def shift(self, camera, move: float) -> float:
        """Largest screen shift (x / z units) of a rasterised occluder point moved by `move` per
        coordinate: sqrt(3) move / z (1 + |x| / z) at z >= self.nearest; inf when too near."""
        if self.nearest == np.inf:
            return 0.0  # nothing rasterised: nothing to shift
        reach = np.sqrt(3.0) * move
        z = self.nearest - reach
        if not z > 0:
            return np.inf
        tx, ty = self._view(camera)[2:4]
        tangent = max(ty, tx) * self.nearest / z + reach / z
        return reach / z * (1.0 + tangent)

    def nearest_far(self, margin, recede) -> float:
        """D + margin D^2 + recede for the smallest covered depth bound D: nothing nearer than
        that can be hidden anywhere."""
        d = float(self.tile_min.min()) if len(self.tile_min) else np.inf
        return d + margin * d * d + recede

    def _node_pass(self, state, eye, rotation, tx, ty, move, margin, recede,
                   from_root=True, fused=False) -> int:
        """state.nodes refined by hiz.cull_nodes against the current buffer (entered through
        their ancestors, or, from_root False, at the nodes themselves); fused: by the frustum
        and the buffer in one walk from them (hiz.frustum_cull_nodes, vfc's counters too), which
        stops expanding after WALK_BUDGET nodes when later rounds follow. Returns the nodes the
        fused walk deferred (kept unexpanded: the caller refines them with a later pass)."""
        tree, camera = self.tree, state.camera
        roots = np.ascontiguousarray(state.nodes, dtype=np.int64)
        if len(roots) + tree.node_count > len(self._out):
            self._out = np.empty(len(roots) + tree.node_count, dtype=np.int64)
        if len(roots) + tree.node_count > len(self._stack):
            self._stack = np.empty(len(roots) + tree.node_count, dtype=np.int64)
            self._below = np.empty(len(roots) + tree.node_count, dtype=np.uint8)
            self._masks = np.empty(len(roots) + tree.node_count, dtype=np.int64)
        if fused:
            budget = WALK_BUDGET if self.rounds > 1 else NO_BUDGET
            kept, visited, tests, outside, culled, tested, deferred = frustum_cull_nodes(
                tree.lo, tree.hi, tree.first_child, self.walk_children, tree.nonempty, roots,
                np.ascontiguousarray(state.planes, dtype=np.float64), tree.tol, eye, rotation,
                camera.near, tx, ty, self.width, self.height, move, self.shift(camera, move),
                margin, recede, self.depth, self.tile_max, self.tile_any, self.tile_shift,
                *self.tile, self._out, self._stack, self._masks, self.nearest_far(margin, recede),
                *self.samples(camera, move), budget)
            state.nodes = self._out[:kept].copy()
            state.count("nodes_visited", visited)
            state.count("plane_tests", tests)
            state.count("vfc.nodes_culled", outside)
            state.count("vfc.nodes_accepted", kept)
            state.count(f"{self.name}.nodes_tested", tested)
            state.count(f"{self.name}.nodes_culled", culled)
            return deferred
        self._frame += 1
        kept, visited, culled = cull_nodes(
            tree.lo, tree.hi, tree.first_child, self.walk_children, tree.nonempty, self.parent,
            roots, self.draw_mark, self.up_mark, self._frame, eye, rotation, camera.near, tx, ty,
            self.width, self.height, move, self.shift(camera, move), margin, recede, self.depth,
            self.tile_max, self.tile_any, self.tile_shift, *self.tile, self._out, self._stack,
            self._below, self.nearest_far(margin, recede), from_root,
            *self.samples(camera, move))
        state.nodes = self._out[:kept].copy()
        state.count("nodes_visited", visited)
        state.count(f"{self.name}.nodes_tested", visited)
        state.count(f"{self.name}.nodes_culled", culled)
        return 0

    def samples(self, camera, move) -> tuple:
        """(screen width, height, the move of a tested point's screen position) for the centre
        tests with `screen`, else (0, 0, move): the centre tests are off."""
        if self.screen is None:
            return 0, 0, move
        return (*self.screen, max(DEVICE_RELATIVE * self._view(camera)[6] + DEVICE_ABSOLUTE,
                                  move))

    def _test(self, camera, ids, move, margin, recede, use_buffer) -> tuple:
        eye, rotation, tx, ty = self._view(camera)[:4]
        n = len(ids)
        hidden, subpixel = np.empty(n, dtype=np.bool_), np.empty(n, dtype=np.bool_)
        zmin = np.empty(n)
        hidden_triangles(ids, self.vertices, self.triangles_, eye, rotation, camera.near, tx, ty,
                         self.width, self.height, move, self.shift(camera, move), margin, recede,
                         self.depth, self.tile_max, self.tile_shift, *self.tile, use_buffer,
                         *self.samples(camera, move), hidden, subpixel, zmin)
        return hidden, subpixel, zmin

    def _hidden_triangles(self, state, ids, move, margin, recede, use_buffer) -> np.ndarray:
        """(n,) bool over the gathered ids: hidden by the buffer, or (with `screen`) covering no
        pixel centre, or hidden once the survivors certainly facing the eye, nearest first, are
        rasterised too (`self_occluders`)."""
        camera = state.camera
        ids = np.ascontiguousarray(ids, dtype=np.int64)
        hidden, subpixel, zmin = self._test(camera, ids, move, margin, recede, use_buffer)
        state.count("triangles_tested", len(ids))
        state.count(f"{self.name}.triangles_tested", len(ids))
        state.count(f"{self.name}.subpixel_culled", subpixel.sum())
        if self.self_occluders and self._view(camera)[7] < np.inf:
            live = np.flatnonzero(~hidden & ~subpixel & np.isfinite(zmin))
            live = live[self.facing(ids[live], camera.eye)]
            if len(live) > self.self_occluders:  # nearest first: they hide the most
                live = live[np.argpartition(zmin[live], self.self_occluders - 1)
                            [:self.self_occluders]]
            state.count(f"{self.name}.self_occluders", len(live))
            if len(live):
                extra = ids[live]
                if self.rasterise(camera, extra):  # may lower self.nearest
                    again, _, _ = self._test(camera, ids, move, margin, recede, True)
                    hidden |= again
        state.count(f"{self.name}.triangles_culled", hidden.sum())
        return hidden | subpixel

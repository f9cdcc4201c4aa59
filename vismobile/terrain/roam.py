"""ROAM (Duchaineau et al. 1997) as Samec 2003 (seed 003) and Pires 2003 describe it.

A right-triangle bintree over the (2^n+1)^2 heightmap: two root triangles share the diagonal
(0, 0)-(S, S) (S = N - 1); splitting a triangle T = (apex, v0, v1) at its hypotenuse midpoint
vc gives T0 = (vc, apex, v0) and T1 = (vc, v1, apex). T and its base neighbour (across the
hypotenuse) form a diamond; only diamonds split, both halves at once, and a coarser base
neighbour is split first (forced split, recursively), so the mesh never has a T-junction.

Diamonds are stored by their split vertex: every sample except the four map corners is the
hypotenuse midpoint of exactly one diamond, so the mesh state is one byte per sample
(split[v]), with flat arrays and no per-triangle objects. A diamond's apexes are its parents
(the diamonds that must be split for its triangles to exist, one on the border), its four
children are the midpoints of its legs. The finest diamonds (one coordinate odd, the other
even) split into half cells; the finest triangles form the 4-8 mesh of alternating diagonals,
the same full-resolution surface as Röttger's finest fans (`Heightmap.height_at(alternating=
True)`).

Error: nested wedgie thickness per diamond, bottom-up,
    e(v) = |h(v) - (h(v0) + h(v1)) / 2| + max(e(children of v)),   0 below the finest level,
which is at least the seed's per-triangle e_T = max(e_T0, e_T1) + |...| for both triangles of
the diamond, so the full-resolution surface over each of its triangles lies within +-e(v) of
the triangle's plane, and a parent's wedgie encloses its children's.

Priority in pixels: p(v) = lambda_b * e(v) / d(v), d the distance from the eye to the box that
holds the diamond's wedgies (its corners' x-z extent, their heights -+ e(v)), lambda_b the
off-axis bound of tiles.pixel_scale. Every vertical gap inside a leaf is a segment inside that
box, so it projects to at most p pixels: when no leaf candidate has p > tau, every
full-resolution sample in the frustum is drawn within tau pixels (this is the seed's projected
wedgie, made a strict bound instead of evaluated at the three vertices). Diamonds whose box is
outside the frustum get priority 0 (they merge away, and their triangles are not emitted);
frustum flags are IN / OUT / PARTIAL per diamond, and only PARTIAL diamonds test their
triangles one by one.

Frame: start from last frame's mesh; recompute the priorities of the split queue (unsplit
diamonds with at least one triangle in the mesh) and of the merge queue (split diamonds none
of whose children is split); merge while the lowest merge priority is <= tau (or the mesh is
over the budget), then split the highest-priority leaf (with its forced splits) while its
priority is > tau and the whole forced chain fits the budget. In budget mode, a blocked split
first merges cheaper diamonds (ROAM's max(Qs) > min(Qm) exchange), within a bounded number of
operations. Without a budget, a split candidate scored <= tau is not re-scored until the eye
has travelled d - lambda_b e / tau (the seed's deferred wait-lists, from distance alone).

Incremental (the default without a budget; issue 30): no walk of the whole mesh; candidates
on the safe side of tau wait on a heap keyed by the eye travel at which their priority may
cross tau (roam_frame._rewake), split candidates kept <= tau only by the frustum are parked
and tested against it each frame, and triangles come from cached blocks re-emitted only
where diamonds changed (roam_emit.py), so a frame's work follows the motion. A frame whose
due wake-ups exceed walk_share of the split diamonds (a fast eye) walks the mesh instead,
and the next slow frame reseeds the queues; `incremental=False` always walks.

Samec's forced merge (seed 003, Fig. 22; `forced_merge`, incremental frames, no budget): his
merge unit is a triangle whose two children are leaves, and when its base neighbour is
split deeper, merging forces that side down first, the inverse of the forced split. Here:
a split diamond with one such triangle (half-mergeable) scored <= tau joins the merge queue,
and popping it merges its split descendants, children first (post-order over the child
DAG), then itself, only if every one of them scores <= tau this frame (else it is refused
and waits; a child's box reaches into its other parent's half, so it can outrank a parent).
A walking frame gains nothing from it (its merge phase re-queues a parent as soon as its
last child merges, so every such set merges anyway) and would pay for refusals, so only
incremental frames force-merge: there a parent that wakes takes its set along instead of
waiting for each descendant's own wake-up.

Geomorphing: a vertex created by a split moves from the midpoint of its hypotenuse to its
height over `geomorph` frames (h_t = (1 - t) (h(v0) + h(v1)) / 2 + t h(v)). On each of its
triangles the drawn surface is then a blend of the parent's plane and the children's, so its
gap to the ground is at most e(v): while a vertex morphs, the screen error is bounded by its
diamond's priority p(v) (which was > tau when it split) instead of by tau. Merges morph too
(issue 30): a diamond due to merge lowers its vertex to the midpoint over `geomorph` frames
first, with the same blend, so its error stays within p(v) <= tau while it descends; it
stops (and pops back up) if its priority rises above tau or a child splits; a merge the
budget forces does not wait, nor one of a diamond outside the frustum. A forced merge's
set descends as one (one start, one t): each vertex goes to the coarse surface, the
midpoint of its hypotenuse ends' targets, so the drawn surface is (1 - t) fine + t coarse,
both within tau.
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from .bintree import _geometry, horizontal_wedgies, wedgie_ranges, wedgies
from .heightmap import Heightmap
from .roam_emit import BlockEmitter
from .roam_frame import _emit, _frame, _rewake
from .roam_heap import _due
from .tiles import pixel_scale


def full_mesh(heightmap: Heightmap) -> np.ndarray:
    """(2 S^2, 3) int64 finest bintree triangles (sample ids, counter-clockwise from +y): the
    4-8 mesh, cells with i + j odd cut along (i, j+1)-(i+1, j)."""
    n = heightmap.size
    i, j = np.meshgrid(np.arange(n - 1), np.arange(n - 1), indexing="ij")
    v00 = (i * n + j).ravel()
    v01, v10, v11 = v00 + 1, v00 + n, v00 + n + 1
    odd = ((i + j) % 2 == 1).ravel()
    a = np.where(odd[:, None], np.stack([v00, v10, v01], 1), np.stack([v00, v11, v01], 1))
    b = np.where(odd[:, None], np.stack([v01, v10, v11], 1), np.stack([v00, v10, v11], 1))
    return np.stack([a, b], axis=1).reshape(-1, 3).astype(np.int64)


@dataclass
class RoamFrame:
    """One ROAM frame.

    triangles  : (T, 3) int64 sample ids (row * N + col) of the drawn leaves, CCW from +y
    leaves     : leaf triangles of the whole bintree mesh (drawn or culled)
    splits, merges, forced : diamond operations this frame (forced: splits of coarser bases)
    bound_px   : the largest priority left among leaf diamonds (pixels): with no geomorph the
                 screen error of every sample in the frustum is at most this
    budget_hit : a split was refused because its forced chain would exceed the budget
    deferred   : split candidates not re-scored (their priority is known to be <= tau)
    lod_ms     : queue rebuild + split/merge + emission wall time
    morph      : (ids (M,) int64, heights (M,) float64) drawn heights of morphing vertices
    forced_merges : Samec's forced merges this frame (each merges a diamond with its split
                 descendants; those diamonds are counted in merges too)
    forced_merged : diamonds merged by them
    forced_refused : forced merges refused because a split descendant was above tau
    """

    triangles: np.ndarray
    leaves: int
    splits: int
    merges: int
    forced: int
    bound_px: float
    budget_hit: bool
    deferred: int
    lod_ms: float
    morph: tuple
    forced_merges: int = 0
    forced_merged: int = 0
    forced_refused: int = 0


class Roam:
    """Frame-coherent ROAM mesh of one heightmap with one pixel knob (and a triangle budget).

    geomorph: frames over which a new vertex rises from its hypotenuse midpoint to its height
    (0: pop at once). defer: skip re-scoring candidates that the eye's travel since they were
    scored cannot have brought above tau (no budget only; the mesh is the same either way).
    incremental (default): wake-up queues and block emission (module doc): frames within
    tau as well, with the merges of diamonds that left the view deferred and whole blocks
    drawn; False: every frame walks the whole mesh (the seed's frame).
    walk_share: with incremental, a frame whose due wake-ups are at least this share of the
    split diamonds walks the mesh and emits per triangle instead, and so do the next frames
    while the eye's step stays above 0.8x that frame's (the queues are reseeded on the first
    slower one): at speeds where most candidates wake anyway, walking is cheaper.
    walk_above: instead of walk_share, walk the frames whose eye moved more than this many
    world units since the last one (np.inf: never walk for speed).
    forced_merge: without a budget, Samec's forced merge (module doc); False: a diamond
    merges only once its children are leaves (the seed's Duchaineau merge).
    """

    def __init__(self, heightmap: Heightmap, geomorph: int = 0, defer: bool = True,
                 incremental: bool = True, walk_above: float | None = None,
                 walk_share: float = 0.15, forced_merge: bool = True):
        self.heightmap = heightmap
        self.n = heightmap.exponent
        N = heightmap.size
        self.heights = heightmap.heights.astype(np.float64)
        start = time.perf_counter()
        error = wedgies(self.heights, self.n)
        if heightmap.valid is not None:  # seed 002's holes: e = length(e_h, e_v), nested
            error = np.hypot(error, horizontal_wedgies(heightmap.valid, self.n,
                                                       heightmap.spacing))
        lo, hi = wedgie_ranges(self.heights, error, self.n)
        # Per diamond, one 16-byte row read by the per-frame priorities: the wedgie box's
        # height range and e (float32 rounded up), so a priority costs one cache line.
        e32 = error.astype(np.float32)
        e32 = np.where(e32 < error, np.nextafter(e32, np.float32(np.inf)), e32)
        self.wedge = np.stack([lo, hi, e32, np.zeros_like(e32)], axis=1)
        del lo, hi, e32, error
        self.build_seconds = time.perf_counter() - start
        self.geomorph = int(geomorph)
        self.defer = bool(defer)
        self.split = np.zeros(N * N, np.uint8)
        S = N - 1
        for v in (0, S, S * N, S * N + S):
            self.split[v] = 1  # the corners: "parents" of the root diamond, always present
        self.alive = np.zeros(min(N * N + 64 * (self.n + 2), 1 << 16), np.int64)
        self.alive_count = 0
        self.leaves = 2
        self.qs = np.zeros(N * N, np.int32)
        self.qm = np.zeros(N * N, np.int32)
        self.mark = np.zeros(N * N, np.int64)
        self.until = np.zeros(N * N, np.float32)  # deferred priorities (see _frame)
        self.travel = 0.0
        self.last_eye = None
        self.knob = None
        self.frame_number = 0  # stamps (may advance twice in one update)
        self.clock = 0  # updates (geomorph time)
        self.out = np.zeros((1 << 16, 3), np.int64)
        self.morph_ids = np.zeros(0, np.int64)
        self.morph_start = np.zeros(0, np.int64)
        self.dying = np.zeros(N * N if self.geomorph else 1, np.int64)  # merge morphs
        # Incremental queues (no budget): a wake-up heap of candidates keyed by the travel at
        # which their priority may cross tau, so a frame re-scores only those (module doc).
        self.incremental = bool(incremental)
        self.hk = np.empty(1 << 12, np.float64)
        self.hv = np.empty(1 << 12, np.int64)
        self.hsize = np.zeros(1, np.int64)
        self.wake_at = np.full(N * N if incremental else 1, -1.0)
        self.parked = np.zeros(min(N * N, 1 << 20) if incremental else 1, np.int64)
        self.pcount = np.zeros(1, np.int64)
        self.parked_at = np.zeros(N * N if incremental else 1, np.uint8)
        self.touched = np.zeros(min(N * N, 1 << 22) if incremental else 1, np.int64)
        self.tcount = np.zeros(4, np.int64)
        self.changed = np.zeros(min(N * N, 1 << 20) if incremental else 1, np.int64)
        self.emitter = BlockEmitter(self.heights, self.n, heightmap.spacing) \
            if incremental else None
        self.need_walk = True
        self.walk_above = None if walk_above is None else float(walk_above)
        self.walk_share = float(walk_share)
        self.fast_step = None  # the step that sent the last frames walking (walk_share)
        self.forced_merge = bool(forced_merge)
        self.fast_frames = 0  # frames walked for their speed (walk_share, walk_above)

    def reset(self):
        """Back to the two root triangles (the next frame refines from scratch)."""
        N = self.heightmap.size
        S = N - 1
        self.split[:] = 0
        for v in (0, S, S * N, S * N + S):
            self.split[v] = 1
        self.alive_count = 0
        self.leaves = 2
        self.morph_ids = self.morph_start = np.zeros(0, np.int64)
        self.dying[:] = 0
        self.knob = None
        self.need_walk = True
        self.fast_step = None

    def update(self, camera, resolution, tau: float, cull: bool = True,
               budget: int | None = None) -> RoamFrame:
        """Split and merge last frame's mesh for this camera; emit the drawn leaves."""
        if not tau > 0:
            raise ValueError("tau must be > 0")
        _, lam = pixel_scale(camera, resolution)
        planes = camera.frustum_planes()
        N = self.heightmap.size
        self.frame_number += 1
        self.clock += 1
        start = time.perf_counter()
        stats = np.zeros(11)
        eye = camera.eye
        step = 0.0
        if self.last_eye is not None:
            step = float(np.linalg.norm(eye - self.last_eye))
            self.travel += step
        self.last_eye = eye
        if self.knob != (lam, float(tau)) or not self.defer:  # one lambda and tau only
            self.until[:] = 0.0
            self.travel = 0.0
            self.knob = (lam, float(tau))
            self.need_walk = True
        lazy = self.incremental and budget is None
        if self.walk_above is not None:
            fast = lazy and step > self.walk_above
        elif lazy and self.fast_step is not None and self.need_walk:
            # after a walking frame the heap is stale: keep walking while the eye moves
            # about as fast as when the due wake-ups sent it walking (else reseed)
            fast = step >= 0.8 * self.fast_step
            if not fast:
                self.fast_step = None
        else:  # walk when more wake-ups are due than a share of the split diamonds
            cap = int(self.walk_share * self.alive_count) + 1
            fast = (lazy and not self.need_walk and self.alive_count > 0
                    and _due(self.hk, int(self.hsize[0]), self.travel, cap) >= cap)
            if fast:
                self.fast_step = step
        if fast:  # walk this frame; the queues are reseeded on the next slow one
            lazy = False
            self.need_walk = True
            self.fast_frames += 1
        walk = not lazy or self.need_walk or self.alive_count == 0
        if lazy and walk:  # (re)seed the wake-up heap from a full walk
            self.hsize[0] = 0
            self.wake_at[:] = -1.0
            self.pcount[0] = 0
            self.parked_at[:] = 0
            self.until[:] = 0.0
        limit = -1 if budget is None else int(budget)
        if budget is not None and budget < 2:
            raise ValueError("budget must be at least 2 triangles")
        born_all = []
        while True:
            born = np.zeros(len(self.alive) if self.geomorph else 0, np.int64)
            self.alive_count, self.leaves, born_count = _frame(
                self.wedge, self.heightmap.spacing, self.n, self.split,
                self.alive, self.alive_count, self.qs, self.qm, self.mark, self.frame_number,
                camera.eye, planes, lam, float(tau), limit, self.leaves, cull, born, stats,
                self.until, self.travel, walk, self.hk, self.hv, self.hsize, self.wake_at,
                self.touched, self.tcount, self.changed, self.dying, self.clock,
                self.geomorph, self.parked, self.pcount, self.parked_at, self.forced_merge)
            born_all.append(born[:born_count])
            if self.emitter is not None and not fast:
                if walk or self.tcount[3]:
                    self.emitter.invalidate()
                else:
                    self.emitter.mark(self.changed, int(self.tcount[2]))
            if lazy:
                self._rewake(eye, lam, float(tau))
            self.need_walk = bool(fast or (lazy and (self.tcount[1] or stats[6])))
            if not stats[6]:
                break
            walk = True
            if lazy:
                self.hsize[0] = 0
                self.wake_at[:] = -1.0
                self.pcount[0] = 0
                self.parked_at[:] = 0
            # The split list filled up: grow it and carry on (same mesh, new stamps).
            grown = np.zeros(min(N * N + 64 * (self.n + 2), 4 * len(self.alive)), np.int64)
            grown[:self.alive_count] = self.alive[:self.alive_count]
            self.alive = grown
            self.frame_number += 1
        centre = (N // 2) * N + N // 2
        if fast and self.emitter is not None:
            self.emitter.invalidate()
        if self.emitter is not None and self.split[centre] and not fast:
            triangles = self.emitter.emit(self.split, self.alive, self.alive_count, planes,
                                          cull)
        else:
            while True:
                count = _emit(self.wedge, self.heightmap.spacing, self.n, self.split,
                              self.alive, self.alive_count, planes, cull, self.out)
                if count >= 0:
                    break
                self.out = np.zeros((2 * len(self.out), 3), np.int64)
            triangles = self.out[:count].copy()
        morph = self._morph(np.concatenate(born_all))
        lod_ms = (time.perf_counter() - start) * 1000.0
        return RoamFrame(triangles, int(self.leaves), int(stats[0]),
                         int(stats[1]), int(stats[2]), float(stats[3]), bool(stats[5]),
                         int(stats[7]), lod_ms, morph, int(stats[8]), int(stats[9]),
                         int(stats[10]))

    def _rewake(self, eye, lam, tau):
        """Push this frame's safe-side candidates on the wake-up heap (grown as needed;
        rebuilt without its stale entries when they dominate)."""
        count = int(self.tcount[0])
        size = int(self.hsize[0])
        if size + count > len(self.hk) or size > 4 * (4 * self.alive_count + 4096):
            keys, vals = self.hk[:size], self.hv[:size]
            live = self.wake_at[vals] == keys
            keys, vals = keys[live], vals[live]
            order = np.argsort(keys, kind="stable")  # a sorted array is a min-heap
            room = max(2 * (len(keys) + count), 1 << 12)
            self.hk, self.hv = np.empty(room), np.empty(room, np.int64)
            self.hk[:len(keys)], self.hv[:len(keys)] = keys[order], vals[order]
            self.hsize[0] = len(keys)
        _rewake(self.wedge, self.heightmap.spacing, self.n, self.split, self.touched, count,
                eye, lam, tau, self.travel, self.hk, self.hv, self.hsize, self.wake_at,
                self.parked, self.pcount, self.parked_at, self.forced_merge)

    def _morph(self, born) -> tuple:
        """Drawn heights of vertices still rising (ids, heights); empty without geomorph."""
        if not self.geomorph:
            return np.zeros(0, np.int64), np.zeros(0)
        ids = np.r_[self.morph_ids, born]
        starts = np.r_[self.morph_start, np.full(len(born), self.clock)]
        t = (self.clock - starts + 1) / (self.geomorph + 1)
        keep = (t < 1) & (self.split[ids] == 1)
        ids, starts, t = ids[keep], starts[keep], t[keep]
        ids, first = np.unique(ids[::-1], return_index=True)  # re-split vertices restart
        starts, t = starts[::-1][first], t[::-1][first]
        self.morph_ids, self.morph_start = ids, starts
        N = self.heightmap.size
        g = np.empty((4, 2), np.int64)
        mid = np.empty(len(ids))
        for k, v in enumerate(ids.tolist()):  # only this frame's few morphing vertices
            _geometry(v // N, v % N, self.n, g)
            mid[k] = 0.5 * (self.heights[g[2, 0], g[2, 1]] + self.heights[g[3, 0], g[3, 1]])
        r, c = np.divmod(ids, N)
        rising = (1 - t) * mid + t * self.heights[r, c]
        # Vertices of diamonds due to merge descend to the coarse surface (merge phase,
        # _frame): a lone merge's vertex to its hypotenuse midpoint; in a forced merge's set
        # (one start clock, one t) each vertex to the midpoint of its hypotenuse ends' own
        # targets, coarser ones first, so at t = 1 the fine mesh lies on the coarse one.
        down = np.flatnonzero(self.dying)
        down = down[(self.split[down] == 1) & ~np.isin(down, ids)]
        if not len(down):
            return ids, rising
        r, c = np.divmod(down, N)
        step = (r | c) & -(r | c)
        square = (r & -r) == (c & -c)
        order = np.lexsort((~square, -step))  # larger step first, a square before its edges
        down, r, c = down[order], r[order], c[order]
        t = np.minimum((self.clock - self.dying[down] + 1) / (self.geomorph + 1), 1.0)
        target = {}
        low = np.empty(len(down))
        flat = self.heights.ravel()
        for k, v in enumerate(down.tolist()):
            _geometry(v // N, v % N, self.n, g)
            a, b = int(g[2, 0] * N + g[2, 1]), int(g[3, 0] * N + g[3, 1])
            low[k] = target[v] = 0.5 * (target.get(a, flat[a]) + target.get(b, flat[b]))
        return (np.r_[ids, down], np.r_[rising, (1 - t) * self.heights[r, c] + t * low])

"""The dynamic structure: a BVH over the moving objects' boxes, refitted every frame and rebuilt
when its surface-area cost has degraded; and AnimatedPartition, the static triangles' ordinary
partition beside it.

Static triangles keep their partition (any kind, built over AnimatedWorld.static_world()); the
moving objects live in the BVH, whose leaves hold up to LEAF objects. A frame refits the boxes
bottom-up (nodes are stored parent before child), O(nodes + moving objects), and compares the
tree's SAH cost (traversal 1 per inner node, 1 per object in a leaf, each weighted by its box's
surface area over the root's) with the cost it had when it was built: above REBUILD times that,
it is rebuilt (median split on the longest axis of the objects' centres; O(M log^2 M)).
Nothing here is proportional to the static world.

BVH arrays (N nodes, M objects; flat, numba kernels):
    lo, hi  : (N, 3) float64 node boxes
    first   : (N,) int64 first child (children are first, first + 1), -1 at a leaf
    start, count : (N,) int64 a leaf's objects are order[start:start + count]
    order   : (M,) int64 object indices (rows of the boxes given to build/refit)
"""
from __future__ import annotations

import numpy as np
from numba import njit

LEAF = 4  # objects per leaf at most
REBUILD = 1.5  # rebuild when the refitted SAH cost exceeds this times the cost at build


@njit(cache=True, nogil=True)
def _build(centres, order, lo, hi, first, start, count, stack_a, stack_b, stack_n, leaf):
    """Top-down median split (longest axis of the centres' box) over order[a:b]; nodes in
    pre-order (parent before children, children adjacent). Returns the node count."""
    n_nodes = 1
    top = 1
    stack_a[0], stack_b[0], stack_n[0] = 0, len(order), 0
    while top > 0:
        top -= 1
        a, b, node = stack_a[top], stack_b[top], stack_n[top]
        start[node], count[node], first[node] = a, b - a, -1
        if b - a <= leaf:
            continue
        best, extent = 0, -1.0
        for axis in range(3):
            low, high = np.inf, -np.inf
            for i in range(a, b):
                v = centres[order[i], axis]
                low, high = min(low, v), max(high, v)
            if high - low > extent:
                best, extent = axis, high - low
        keys = np.empty(b - a)
        for i in range(a, b):
            keys[i - a] = centres[order[i], best]
        sub = np.argsort(keys, kind="mergesort")
        chunk = order[a:b].copy()
        for i in range(b - a):
            order[a + i] = chunk[sub[i]]
        mid = (a + b) // 2
        first[node] = n_nodes
        left, right = n_nodes, n_nodes + 1
        n_nodes += 2
        stack_a[top], stack_b[top], stack_n[top] = mid, b, right
        top += 1
        stack_a[top], stack_b[top], stack_n[top] = a, mid, left
        top += 1
    return n_nodes


@njit(cache=True, nogil=True, inline="always")
def _node_box(boxes, order, lo, hi, first, start, count, node):
    """lo[node], hi[node]: the box of a leaf's object boxes (M, 2, 3), or of an inner node's
    two children (already refitted)."""
    for j in range(3):
        lo[node, j], hi[node, j] = np.inf, -np.inf
    if first[node] < 0:
        for i in range(start[node], start[node] + count[node]):
            k = order[i]
            for j in range(3):
                lo[node, j] = min(lo[node, j], boxes[k, 0, j])
                hi[node, j] = max(hi[node, j], boxes[k, 1, j])
    else:
        for c in range(first[node], first[node] + 2):
            for j in range(3):
                lo[node, j] = min(lo[node, j], lo[c, j])
                hi[node, j] = max(hi[node, j], hi[c, j])


@njit(cache=True, nogil=True)
def _refit(boxes, order, lo, hi, first, start, count, n_nodes):
    """Node boxes bottom-up from the object boxes (M, 2, 3); returns the SAH cost."""
    for node in range(n_nodes - 1, -1, -1):
        _node_box(boxes, order, lo, hi, first, start, count, node)
    root = _area(lo, hi, 0)
    cost = 0.0
    for node in range(n_nodes):
        weight = _area(lo, hi, node) / root if root > 0 else 1.0
        cost += weight * (1.0 if first[node] >= 0 else count[node])
    return cost


@njit(cache=True, nogil=True)
def _links(first, start, count, order, n_nodes, parent, leaf_of):
    """parent (N,) of each node (-1 at the root) and leaf_of (M,) the leaf holding each object."""
    parent[0] = -1
    for node in range(n_nodes):
        if first[node] >= 0:
            parent[first[node]] = node
            parent[first[node] + 1] = node
        else:
            for i in range(start[node], start[node] + count[node]):
                leaf_of[order[i]] = node


@njit(cache=True, nogil=True)
def _area_sum(lo, hi, first, count, n_nodes):
    """The SAH cost's numerator: sum over nodes of box area x (1 inner, objects at a leaf)."""
    total = 0.0
    for node in range(n_nodes):
        total += _area(lo, hi, node) * (1.0 if first[node] >= 0 else count[node])
    return total


@njit(cache=True, nogil=True)
def refit_rows(boxes, rows, order, lo, hi, first, start, count, parent, leaf_of, n_nodes,
               area_sum):
    """Refit only the nodes above the objects rows (K,) (their boxes changed): from each one's
    leaf up, while a node's box changes (above an unchanged node all already hold it). The
    same node boxes as _refit over all (min / max are exact: each node ends the box of its
    children's), in O(K x the levels that change), nothing over the whole tree; with more than
    N / 4 objects, one bottom-up pass over every node (_refit) instead. Returns (SAH cost, its
    numerator kept up to date from area_sum, rounding aside the value _refit sums)."""
    if 4 * len(rows) > n_nodes:  # most paths would reach the root: one pass over every node
        cost = _refit(boxes, order, lo, hi, first, start, count, n_nodes)
        return cost, _area_sum(lo, hi, first, count, n_nodes)
    total = area_sum
    for i in range(len(rows)):
        node = leaf_of[rows[i]]
        while node >= 0:
            x0, y0, z0 = lo[node, 0], lo[node, 1], lo[node, 2]
            x1, y1, z1 = hi[node, 0], hi[node, 1], hi[node, 2]
            weight = 1.0 if first[node] >= 0 else float(count[node])
            total -= _area(lo, hi, node) * weight
            _node_box(boxes, order, lo, hi, first, start, count, node)
            total += _area(lo, hi, node) * weight
            if (x0 == lo[node, 0] and y0 == lo[node, 1] and z0 == lo[node, 2]
                    and x1 == hi[node, 0] and y1 == hi[node, 1] and z1 == hi[node, 2]):
                break
            node = parent[node]
    if n_nodes == 0:
        return 0.0, total
    root = _area(lo, hi, 0)
    if root > 0:
        return total / root, total
    # every weight 1: the inner nodes ((N - 1) / 2 of a full binary tree) and the objects
    return float((n_nodes - 1) // 2 + len(order)), total


@njit(cache=True, nogil=True, inline="always")
def _area(lo, hi, node):
    dx = max(hi[node, 0] - lo[node, 0], 0.0)
    dy = max(hi[node, 1] - lo[node, 1], 0.0)
    dz = max(hi[node, 2] - lo[node, 2], 0.0)
    return dx * dy + dy * dz + dz * dx


class DynamicBVH:
    """A BVH over M boxes (module docstring), kept current by update(boxes) each frame.

    built_cost : SAH cost right after the last build;  cost : after the last refit
    rebuilds   : how many times update rebuilt it
    """

    def __init__(self, boxes, leaf: int = LEAF, rebuild: float = REBUILD):
        boxes = np.ascontiguousarray(boxes, dtype=np.float64).reshape(-1, 2, 3)
        self.leaf, self.rebuild = max(int(leaf), 1), float(rebuild)
        m = len(boxes)
        size = max(2 * m, 1)
        self.lo, self.hi = np.zeros((size, 3)), np.zeros((size, 3))
        self.first = np.full(size, -1, dtype=np.int64)
        self.start = np.zeros(size, dtype=np.int64)
        self.count = np.zeros(size, dtype=np.int64)
        self.order = np.arange(m, dtype=np.int64)
        self._stacks = tuple(np.zeros(size + 64, dtype=np.int64) for _ in range(3))
        self.parent = np.full(size, -1, dtype=np.int64)
        self.leaf_of = np.zeros(m, dtype=np.int64)
        self.rebuilds = 0
        self.node_count = 0
        self._build(boxes)

    def _build(self, boxes) -> None:
        centres = (boxes[:, 0] + boxes[:, 1]) * 0.5
        self.order[:] = np.arange(len(boxes))
        self.node_count = _build(centres, self.order, self.lo, self.hi, self.first, self.start,
                                 self.count, *self._stacks, self.leaf) if len(boxes) else 0
        if self.node_count:
            _links(self.first, self.start, self.count, self.order, self.node_count, self.parent,
                   self.leaf_of)
        self.cost = self.built_cost = self._refit(boxes)

    def _refit(self, boxes) -> float:
        """Every node refitted; returns the SAH cost (and keeps area_sum, its numerator)."""
        if not self.node_count:
            self.area_sum = 0.0
            return 0.0
        cost = float(_refit(boxes, self.order, self.lo, self.hi, self.first, self.start,
                            self.count, self.node_count))
        self.area_sum = float(_area_sum(self.lo, self.hi, self.first, self.count,
                                        self.node_count))
        return cost

    def update(self, boxes) -> bool:
        """Refit to boxes (M, 2, 3) (the same objects, moved); rebuild when the SAH cost went
        above `rebuild` times its cost at the last build. Returns True when it rebuilt."""
        boxes = np.ascontiguousarray(boxes, dtype=np.float64)
        cost = self._refit(boxes)
        return self.refitted(cost, self.area_sum, boxes)

    def refitted(self, cost, area_sum, boxes) -> bool:
        """After a refit to boxes (M, 2, 3) done elsewhere (refit_rows on this tree's arrays,
        which returned the SAH cost `cost` and its numerator `area_sum`): rebuild when it
        degraded (update's rule); True if so."""
        self.cost, self.area_sum = float(cost), float(area_sum)
        if self.cost > self.rebuild * self.built_cost:
            self._build(boxes)
            self.rebuilds += 1
            return True
        return False

    def __repr__(self) -> str:
        return (f"DynamicBVH({len(self.order):,} objects, {self.node_count:,} nodes, SAH "
                f"{self.cost:.1f} (built {self.built_cost:.1f}), {self.rebuilds} rebuilds)")


class AnimatedPartition:
    """An AnimatedWorld's static partition plus what culling needs of its moving objects.

    animated   : world.animated.AnimatedWorld
    static     : Partition over animated.static_world() (its triangle ids are static-world ids;
                 animated.static_ids maps them to the world's)
    world      : the rest-pose World (every triangle id)
    kind, params : the static partition's
    Each Culler makes its own DynamicBVH (refitting is per-culler state).
    """

    def __init__(self, animated, static):
        self.animated, self.static = animated, static
        self.world = animated.world
        self.kind, self.params, self.extras = static.kind, static.params, static.extras

    def __repr__(self) -> str:
        return f"AnimatedPartition({self.static!r} + {len(self.animated.motion):,} moving objects)"

    def check(self) -> None:
        self.static.check()

    def stats(self) -> dict:
        """The static partition's statistics, plus the moving objects' count."""
        return {**self.static.stats(), "moving_objects": len(self.animated.motion)}

    def __getattr__(self, name):
        # node arrays, counts and sizes are the static partition's (the study's tables, the
        # viewer's node overlay read them); the moving objects have no nodes of their own
        if name.startswith("__") or name == "static":
            raise AttributeError(name)
        return getattr(self.static, name)

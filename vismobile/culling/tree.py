"""Read-only indexes over a Partition that every stage shares: children, leaves in depth-first
order, each node's leaf range, and the world's coordinate scale."""
from __future__ import annotations

import numpy as np

from ..geometry.planes import slack
from ..partition.base import Partition, gather_ranges
from ..partition.tight import shrunk_bounds
from .gather import Bitmap, Groups, count_marked, extract_marked, mark_nodes
from .kernels import frustum_walk, inner_records, node_records


class Tree:
    """A Partition plus derived index arrays, built once per Culler.

    leaf_order : (L,) int64 leaves sorted by ref_start (depth-first order of tri_refs)
    leaf_lo, leaf_hi : (N,) int64 each node's leaves are leaf_order[leaf_lo:leaf_hi]
    tol        : float distance slack for plane tests at this world's coordinate scale
    node_bounds: (N, 2, 3) float64 the partition's boxes shrunk to their references
                 (partition/tight.py)
    """

    def __init__(self, partition: Partition):
        self.partition = p = partition
        self.world = partition.world
        # Boxes shrunk to what the nodes reference (octree and grid cells are regions, mostly
        # empty in a large world): every walk tests and descends into less.
        self.node_bounds = shrunk_bounds(p)
        self.first_child = np.asarray(p.first_child, dtype=np.int64)
        self.child_count = np.asarray(p.child_count, dtype=np.int64)
        self.ref_start = np.asarray(p.ref_start, dtype=np.int64)
        self.ref_end = np.asarray(p.ref_end, dtype=np.int64)
        # Kept as stored (int32, perhaps a memory-mapped file); refs() widens what it gathers.
        self.tri_refs = np.asarray(p.tri_refs)
        self.node_count = len(self.first_child)
        self.nonempty = self.ref_end > self.ref_start
        leaves = np.flatnonzero(self.child_count == 0)
        # Ties (empty leaves) go first, so a non-empty leaf sits right where its refs start.
        self.leaf_order = leaves[np.lexsort((self.ref_end[leaves] - self.ref_start[leaves],
                                             self.ref_start[leaves]))]
        starts = self.ref_start[self.leaf_order]
        self.leaf_lo = np.searchsorted(starts, self.ref_start, side="left")
        self.leaf_hi = np.searchsorted(starts, self.ref_end, side="left")
        # A node whose range ends where an empty leaf of the next subtree starts is harmless:
        # empty leaves hold no triangles.
        self.tol = slack(self.node_bounds[self.nonempty]) if self.node_count else 0.0
        self.scale = self.tol / 1e-9
        # Kernel inputs and scratch, allocated once: frames reuse them.
        self.lo = np.ascontiguousarray(self.node_bounds[:, 0])
        self.hi = np.ascontiguousarray(self.node_bounds[:, 1])
        self._bitmap = Bitmap(self.world.triangle_count)
        self.groups = Groups(self)
        # What gathering a node costs: the pairs it reads (gather.mark_nodes).
        self.read_size = self.groups.end - self.groups.start
        self._box, self._links = node_records(self.node_bounds, self.first_child, self.child_count,
                                              self.nonempty)
        self._inner = inner_records(self._box, self._links)
        self._inner_links = self._inner.view(self._links.dtype)
        self._stacks = self._stack_scratch(64)

    def _stack_scratch(self, roots: int) -> tuple:
        size = self.node_count + roots
        return tuple(np.empty(size, dtype=np.int64) for _ in range(4))

    def walk(self, roots, root_sets, plane_sets, whole_below: int = -1,
             covering: bool = False) -> tuple:
        """Frustum walk (kernels.frustum_walk) from roots (K,) int64 with plane_sets (S, P, 4)
        and root_sets (K,) int64: (accepted nodes (A,) int64, visited, plane tests, culled,
        straddling nodes accepted whole, nodes accepted by their cover). whole_below >= 0: a
        straddling inner node whose gather reads at most that many references (read_size) is
        accepted whole. covering: a straddling inner node below which no node would be rejected
        is accepted whole (the same triangles as its accepted leaves)."""
        roots = np.ascontiguousarray(roots, dtype=np.int64)
        if len(roots) + self.node_count > len(self._stacks[0]):
            self._stacks = self._stack_scratch(2 * len(roots))
        out, nodes, sets, masks = self._stacks
        count, *counters = frustum_walk(
            self._box, self._links, self.read_size, int(whole_below), self._inner,
            self._inner_links, bool(covering), roots,
            np.ascontiguousarray(root_sets, dtype=np.int64),
            np.ascontiguousarray(plane_sets, dtype=np.float64), self.tol, out, nodes, sets, masks)
        return (out[:count].copy(), *counters)

    def distinct_refs(self, nodes) -> np.ndarray:
        """(S,) int64 sorted distinct triangle ids of the nodes' subtrees; cost follows the
        references gathered, not the world's triangle count (gather.mark_nodes)."""
        return self.gather(nodes)[0]

    def gather(self, nodes) -> tuple:
        """(sorted distinct triangle ids (S,) int64 of the nodes' subtrees, runs of consecutive
        ids among them). Nodes read (word, mask) pairs, whole ones their levels' (gather.Groups)."""
        nodes = np.ascontiguousarray(nodes, dtype=np.int64)
        g, b = self.groups, self._bitmap
        ntops = mark_nodes(g.words, g.masks, g.span, nodes, b.bits, b.summary, b.tops,
                           b.node_ranges(len(nodes)))
        ids = b.output(count_marked(b.bits, b.summary, b.tops, ntops))
        return ids, extract_marked(b.bits, b.summary, b.tops, ntops, ids)

    def children(self, nodes) -> tuple:
        """(children (C,) int64, parent_index (C,) int64 index into nodes) of inner nodes."""
        nodes = np.asarray(nodes, dtype=np.int64)
        counts = self.child_count[nodes]
        kids = gather_ranges(np.arange(self.node_count, dtype=np.int64),
                             self.first_child[nodes], self.first_child[nodes] + counts)
        return kids, np.repeat(np.arange(len(nodes)), counts)

    def leaves_under(self, nodes) -> np.ndarray:
        """(K,) int64 ranks (positions in leaf_order) of the leaves of the nodes' subtrees."""
        nodes = np.asarray(nodes, dtype=np.int64)
        return gather_ranges(np.arange(len(self.leaf_order), dtype=np.int64),
                             self.leaf_lo[nodes], self.leaf_hi[nodes])

    def refs(self, nodes) -> np.ndarray:
        """Concatenated tri_refs (int64, may repeat ids) of the nodes' subtrees."""
        nodes = np.asarray(nodes, dtype=np.int64)
        return gather_ranges(self.tri_refs, self.ref_start[nodes],
                             self.ref_end[nodes]).astype(np.int64, copy=False)

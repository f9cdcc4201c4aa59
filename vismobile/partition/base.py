"""The Partition: every structure as one flat tree of numpy arrays (structure of arrays).

Layout contract, shared by all structures and relied on by the culling stages:
- Nodes are stored breadth-first, so each tree level is the contiguous range
  `level_start[k]:level_start[k+1]`, and node 0 is the root.
- The children of a node are contiguous: `first_child[i] : first_child[i] + child_count[i]`;
  a leaf has child_count 0 (and first_child -1).
- `tri_refs` lists triangle ids leaf by leaf in depth-first order, so the references of a
  whole subtree are the one contiguous range `ref_start[i]:ref_end[i]` (a leaf's own range
  when it is a leaf). A triangle may be referenced by several leaves; it is never split.
- `node_bounds[i]` is a box holding everything of node i's subtree that is referenced,
  clipped to the node's region where the structure has one (octree cells).
- Structure-specific arrays live in `extras` (for example BSP split planes, portal polygons).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..world import World

KINDS = ("grid", "octree", "portal", "bsp")


@dataclass(eq=False)
class Partition:
    """A world and its spatial partition as flat arrays.

    kind        : one of KINDS
    params      : dict of build parameters (JSON-serialisable)
    world       : World the references index into
    node_bounds : (N, 2, 3) float64 min/max corner per node
    first_child : (N,) int32 index of the first child, -1 for leaves
    child_count : (N,) int32
    ref_start   : (N,) int64 start of the node's subtree in tri_refs
    ref_end     : (N,) int64 end (exclusive) of the node's subtree in tri_refs
    level_start : (L + 1,) int64 first node of each level, then N
    tri_refs    : (R,) int32 triangle ids
    extras      : dict of str -> ndarray, structure-specific
    """

    kind: str
    params: dict
    world: World
    node_bounds: np.ndarray
    first_child: np.ndarray
    child_count: np.ndarray
    ref_start: np.ndarray
    ref_end: np.ndarray
    level_start: np.ndarray
    tri_refs: np.ndarray
    extras: dict = field(default_factory=dict)

    ARRAYS = ("node_bounds", "first_child", "child_count", "ref_start", "ref_end",
              "level_start", "tri_refs")

    @property
    def node_count(self) -> int:
        return len(self.first_child)

    @property
    def is_leaf(self) -> np.ndarray:
        """(N,) bool."""
        return self.child_count == 0

    @property
    def leaf_ids(self) -> np.ndarray:
        return np.flatnonzero(self.is_leaf)

    @property
    def depth(self) -> int:
        """Number of levels below the root."""
        return len(self.level_start) - 2

    def node_levels(self) -> np.ndarray:
        """(N,) int32 level of each node (root 0)."""
        return (np.searchsorted(self.level_start, np.arange(self.node_count), side="right")
                - 1).astype(np.int32)

    def stats(self) -> dict:
        leaves = self.leaf_ids
        leaf_refs = self.ref_end[leaves] - self.ref_start[leaves]
        return {
            "kind": self.kind,
            "nodes": self.node_count,
            "leaves": int(len(leaves)),
            "depth": self.depth,
            "references": int(len(self.tri_refs)),
            "refs_per_triangle": len(self.tri_refs) / max(self.world.triangle_count, 1),
            "max_leaf_refs": int(leaf_refs.max()) if len(leaves) else 0,
        }

    def save(self, path) -> None:
        """Write this partition to a .vmp file, atomically (see store.py)."""
        from .store import save_partition

        save_partition(self, path)

    def check(self) -> None:
        """Raise ValueError when the layout contract above does not hold (cheap, vectorised)."""
        n = self.node_count
        if self.level_start[0] != 0 or self.level_start[-1] != n:
            raise ValueError("level_start must run from 0 to the node count")
        inner = np.flatnonzero(self.child_count > 0)
        if len(inner) and (self.first_child[inner].min() <= 0
                           or (self.first_child[inner] + self.child_count[inner]).max() > n):
            raise ValueError("child range out of bounds")
        if np.any(self.ref_start > self.ref_end) or (n and self.ref_end.max() > len(self.tri_refs)):
            raise ValueError("reference range out of bounds")
        if len(self.tri_refs) and (self.tri_refs.min() < 0
                                   or self.tri_refs.max() >= self.world.triangle_count):
            raise ValueError("triangle reference out of range")


def gather_ranges(values: np.ndarray, starts: np.ndarray, ends: np.ndarray) -> np.ndarray:
    """values[starts[0]:ends[0]] ++ values[starts[1]:ends[1]] ++ ..., without a Python loop."""
    starts = np.asarray(starts, dtype=np.int64)
    lengths = np.asarray(ends, dtype=np.int64) - starts
    total = int(lengths.sum())
    if total == 0:
        return values[:0]
    offsets = np.repeat(starts - np.cumsum(lengths) + lengths, lengths)
    return values[np.arange(total, dtype=np.int64) + offsets]

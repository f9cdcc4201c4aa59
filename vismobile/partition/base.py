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

from ..world.world import World
from .spec import KINDS, format_spec  # noqa: F401  (KINDS re-exported: its older home)

# The largest vertex coordinate a stage may meet (the OBJ reader's limit): squares and cross
# products of coordinates stay finite in float64.
MAX_COORDINATE = 1e30
CHECK_ROWS = 1 << 20  # vertices checked per block


@dataclass(eq=False, repr=False)
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

    def __repr__(self) -> str:
        return (f"Partition({format_spec(self.kind, self.params)} of {self.world.name!r}: "
                f"{self.node_count:,} nodes, {int(self.is_leaf.sum()):,} leaves, "
                f"{len(self.tri_refs) / max(self.world.triangle_count, 1):.2f} refs/triangle)")

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

    def check(self) -> None:
        """Raise ValueError when the layout contract above, or any invariant a culling stage
        relies on, does not hold (vectorised; a loaded file must never crash a stage).

        Shapes and dtypes; one breadth-first tree (root alone on level 0, child ranges inside
        the next level, first_child derived from child_count); finite node boxes; reference
        ranges nested like the tree (children contiguous and tiling their parent, the root
        all of tri_refs) so no traversal gathers more than len(tri_refs); triangle ids in
        range; finite vertices within MAX_COORDINATE; the structure's extras (portals, BSP
        planes, grid boundaries, octants) consistent with the tree.
        """
        n = self.node_count
        arrays = {name: np.asarray(getattr(self, name)) for name in self.ARRAYS}
        for name, array in arrays.items():
            if array.dtype.kind not in ("f" if name == "node_bounds" else "iu"):
                raise ValueError(f"{name} has dtype {array.dtype}, not numeric of its kind")
        if n < 1 or arrays["node_bounds"].shape != (n, 2, 3):
            raise ValueError("node_bounds must be (N, 2, 3) for N >= 1 nodes")
        for name in ("child_count", "ref_start", "ref_end"):
            if arrays[name].shape != (n,):
                raise ValueError(f"{name} must hold one entry per node")
        if arrays["level_start"].ndim != 1 or arrays["tri_refs"].ndim != 1:
            raise ValueError("level_start and tri_refs must be one-dimensional")
        count = arrays["child_count"].astype(np.int64)
        level_start = arrays["level_start"].astype(np.int64)
        if (len(level_start) < 2 or level_start[0] != 0 or level_start[-1] != n
                or level_start[1] != 1 or np.any(np.diff(level_start) <= 0)):
            raise ValueError("level_start must run from 0 (the root alone) to the node count")
        if count.min() < 0 or int(count.sum()) != n - 1:
            raise ValueError("child counts must be non-negative and sum to N - 1")
        first = np.where(count > 0, 1 + np.cumsum(count) - count, -1)
        if not np.array_equal(first, arrays["first_child"].astype(np.int64)):
            raise ValueError("first_child does not follow from child_count (breadth-first)")
        level = np.searchsorted(level_start, np.arange(n), side="right") - 1
        inner = np.flatnonzero(count > 0)
        last = first[inner] + count[inner] - 1
        if len(inner) and (np.any(first[inner] < level_start[np.minimum(level[inner] + 1,
                                                                        len(level_start) - 1)])
                           or np.any(last >= level_start[np.minimum(level[inner] + 2,
                                                                    len(level_start) - 1)])):
            raise ValueError("a node's children lie outside the next level")
        bounds = arrays["node_bounds"]
        if not np.isfinite(bounds).all() or np.any(bounds[:, 0] > bounds[:, 1]):
            raise ValueError("node bounds must be finite boxes (min <= max)")
        start, end = arrays["ref_start"].astype(np.int64), arrays["ref_end"].astype(np.int64)
        total = len(arrays["tri_refs"])
        if start[0] != 0 or end[0] != total or np.any(start > end) or start.min() < 0:
            raise ValueError("reference range out of bounds (the root must cover tri_refs)")
        if len(inner):
            kids = np.arange(1, n)
            parent = np.repeat(np.arange(n), count)
            first_of = first[parent] == kids
            last_of = first[parent] + count[parent] - 1 == kids
            middle = kids[~last_of]  # a next sibling follows each
            if (np.any(start[kids][first_of] != start[parent][first_of])
                    or np.any(end[kids][last_of] != end[parent][last_of])
                    or np.any(end[middle] != start[middle + 1])):
                raise ValueError("reference ranges do not nest like the tree")
        refs = arrays["tri_refs"]
        if total and (refs.min() < 0 or refs.max() >= self.world.triangle_count):
            raise ValueError("triangle reference out of range")
        ids = self.world.object_ids
        if len(ids) and (ids.min() < 0 or ids.max() >= max(len(self.world.object_names), 1)):
            raise ValueError("object id without an object name")
        vertices = self.world.vertices
        for s in range(0, len(vertices), CHECK_ROWS):  # blocks: a mapped world stays mapped
            block = np.asarray(vertices[s:s + CHECK_ROWS])
            if not np.isfinite(block).all() or np.abs(block).max(initial=0) > MAX_COORDINATE:
                raise ValueError(f"world vertices must be finite and within "
                                 f"+-{MAX_COORDINATE:g}")
        self._check_extras(n, count)

    def _check_extras(self, n, count) -> None:
        x = {name: np.asarray(value) for name, value in (self.extras or {}).items()}
        for name, value in x.items():
            if value.dtype.kind not in "biuf":
                raise ValueError(f"extras {name} has dtype {value.dtype}, not numeric")
        if "octant" in x and (x["octant"].shape != (n,) or x["octant"].min(initial=0) < -1
                              or x["octant"].max(initial=0) > 7):
            raise ValueError("octant codes must be -1..7, one per node")
        for axis in "xyz":
            edges = x.get(f"grid_{axis}")
            if edges is not None and (edges.ndim != 1 or len(edges) < 2
                                      or not np.isfinite(edges).all()
                                      or np.any(np.diff(edges) < 0)):
                raise ValueError(f"grid_{axis} must be at least 2 finite ascending boundaries")
        if "lod_triangles" in x:
            from ..lod.chains import LodChains

            LodChains.from_extras(x).check(self.world)
        if "split_planes" in x:
            planes = x["split_planes"]
            if planes.shape != (n, 4) or not np.isfinite(planes[count > 0]).all():
                raise ValueError("split_planes must be (N, 4), finite on inner nodes")
            if np.any((count != 0) & (count != 2)):
                raise ValueError("BSP nodes must have 0 or 2 children")
        if "split_axis" in x:  # kd-tree planes
            axis = x["split_axis"]
            if (axis.shape != (n,) or axis.min(initial=0) < -1 or axis.max(initial=0) > 2
                    or np.any((axis >= 0) != (count > 0)) or np.any((count != 0) & (count != 2))):
                raise ValueError("split_axis must be 0..2 on inner nodes (2 children), -1 on leaves")
        if "occluders" in x:  # occlusion's per-node lists (partition/occluders.py)
            lists = x["occluders"]
            if (lists.ndim != 2 or lists.shape[0] != n or lists.shape[1] < 1
                    or lists.dtype.kind not in "iu" or lists.min(initial=0) < -1
                    or lists.max(initial=0) >= self.world.triangle_count):
                raise ValueError("occluders must be (N, k) triangle ids or -1, one row per node")
        if "cell_node" in x:
            self._check_portals(x, n)
        from .pvs_check import check_pvs

        check_pvs(x, self.world.triangle_count)

    @staticmethod
    def _check_portals(x, n) -> None:
        names = ("cell_node", "cell_bounds", "portal_cells", "portal_start", "portal_vertices",
                 "cell_portal_start", "cell_portals")
        missing = [name for name in names if name not in x]
        if missing:
            raise ValueError(f"portal extras missing: {', '.join(missing)}")
        cells = len(x["cell_node"])
        portals = len(x["portal_cells"])
        vertices = x["portal_vertices"]
        if (x["cell_node"].ndim != 1 or np.any(x["cell_node"] < 0) or np.any(x["cell_node"] >= n)
                or x["cell_bounds"].shape != (cells, 2, 3)
                or not np.isfinite(x["cell_bounds"]).all()):
            raise ValueError("portal cells must name nodes and have finite bounds")
        if (x["portal_cells"].shape != (portals, 2) or np.any(x["portal_cells"] < 0)
                or np.any(x["portal_cells"] >= cells)):
            raise ValueError("portal_cells must be (P, 2) cell ids")
        if vertices.ndim != 2 or vertices.shape[1] != 3 or not np.isfinite(vertices).all():
            raise ValueError("portal_vertices must be (M, 3) finite")
        for name, size, length in (("portal_start", portals, len(vertices)),
                                   ("cell_portal_start", cells, len(x["cell_portals"]))):
            offsets = x[name].astype(np.int64)
            if (offsets.shape != (size + 1,) or offsets[0] != 0 or offsets[-1] != length
                    or np.any(np.diff(offsets) < (1 if name == "portal_start" else 0))):
                raise ValueError(f"{name} must be ascending offsets from 0 to {length}")
        if np.any(x["cell_portals"] < 0) or np.any(x["cell_portals"] >= portals):
            raise ValueError("cell_portals must be portal ids")


def gather_ranges(values: np.ndarray, starts: np.ndarray, ends: np.ndarray) -> np.ndarray:
    """values[starts[0]:ends[0]] ++ values[starts[1]:ends[1]] ++ ..., without a Python loop."""
    starts = np.asarray(starts, dtype=np.int64)
    lengths = np.asarray(ends, dtype=np.int64) - starts
    total = int(lengths.sum())
    if total == 0:
        return values[:0]
    offsets = np.repeat(starts - np.cumsum(lengths) + lengths, lengths)
    return values[np.arange(total, dtype=np.int64) + offsets]

"""What flows between stages within one frame, and the result handed to the renderer."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..world.camera import Camera
from .kernels import run_count
from .tree import Tree


@dataclass
class CullResult:
    """One frame's culling output.

    triangles : (S,) int64 sorted unique triangle ids to send to the pipeline
    nodes     : (D,) int64 draw nodes (each sends its subtree's refs, minus dropped triangles)
    stats     : dict str -> int counters (see Culler.cull)
    cull_back : bool, the driver's GL_CULL_FACE render flag (set by the `bfc` stage)
    """

    triangles: np.ndarray
    nodes: np.ndarray
    stats: dict
    cull_back: bool = False

    def __repr__(self) -> str:
        flag = ", GL_CULL_FACE on" if self.cull_back else ""
        return (f"CullResult({len(self.triangles):,} triangles from {len(self.nodes):,} draw "
                f"nodes, {self.stats.get('nodes_visited', 0):,} nodes visited{flag})")


@dataclass
class CullState:
    """Per-frame working set: node stages refine `nodes`; triangle stages append filters.

    nodes   : (D,) int64 draw nodes; initially the root (everything)
    filters : list of functions (ids (n,) int64) -> (n,) bool keep, or the kept ids themselves
              (int64, in their order), applied after gathering
    frustum_pending : True when `vfc` left its frustum test to the next node stage (`occlusion`
              walks frustum and buffer in one pass: Culler._fuse); that stage clears it
    late_filters : filters applied after `filters`: costly tests (occlusion's triangle test)
              that should see only the survivors of the cheap ones (tbfc); same result
    gathered : None, or (ids, runs): what gathering `nodes` gives, already done by the stage
              that set them (pvs's one compiled call walks, gathers and filters by its set:
              culling/pvs_frame.py); finish then starts from it
    """

    tree: Tree
    camera: Camera
    planes: np.ndarray
    nodes: np.ndarray
    stats: dict = field(default_factory=dict)
    filters: list = field(default_factory=list)
    cull_back: bool = False
    frustum_pending: bool = False
    late_filters: list = field(default_factory=list)
    gathered: tuple | None = None

    def count(self, key: str, amount) -> None:
        self.stats[key] = self.stats.get(key, 0) + int(amount)

    def finish(self) -> CullResult:
        """Gather the draw nodes' refs, apply the filters, and count what is sent.

        Filters see each referenced triangle once, and only the survivors of earlier filters.
        The filters are consumed: they close over this state (its counters), and a state left
        holding them is a reference cycle that keeps the whole Culler (tree, scratch, buffers)
        alive until the cyclic collector runs (issue 28: 1.7 MB a Culler).
        """
        ids, runs = self.gathered if self.gathered is not None else \
            self.tree.gather(self.nodes)  # leaves share triangles: each once
        filters, self.filters = self.filters + self.late_filters, []
        self.late_filters = []
        for keep_of in filters:
            kept = keep_of(ids)
            ids = ids[kept] if kept.dtype == np.bool_ else kept
        if filters:
            runs = run_count(ids)
        self.count("triangles_sent", len(ids))
        self.count("draw_batches", runs)
        self.count("nodes_drawn", len(self.nodes))
        return CullResult(ids, self.nodes, self.stats, self.cull_back)

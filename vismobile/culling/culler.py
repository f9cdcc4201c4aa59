"""The Culler: runs any combination of culling stages on a Partition, cheapest first."""
from __future__ import annotations

import weakref

import numpy as np

from ..geometry.arithmetic import MODES
from ..partition.base import Partition
from ..partition.dynamic import AnimatedPartition
from ..world.world import World
from .backface import BackfaceFlag, ConservativeBackface, ThesisBackface
from .cones import NormalConeStage
from .frustum import FrustumStage, ThesisFrustumStage
from .horizon import HorizonStage
from .doors import attach_doors
from .moving import MovingObjects
from .occlusion import DepthBufferOcclusion
from .occlusion_chain import cull_chained
from .occlusion_thesis import ThesisOcclusion
from .portals import PortalStage
from .pvs import PVSStage
from .precision import culling_planes, world_scale
from .state import CullResult, CullState
from .tree import Tree
from .triangle_backface import TriangleBackface

# name -> stage class. Each has `name`, `cost` (order of application), prepare(tree), apply(state).
STAGES = {cls.name: cls for cls in (PVSStage, PortalStage, FrustumStage, ThesisFrustumStage,
                                    NormalConeStage, ThesisOcclusion, DepthBufferOcclusion,
                                    ConservativeBackface, ThesisBackface, TriangleBackface,
                                    BackfaceFlag, HorizonStage)}

# Stages whose ground truth is the back-face-culled item buffer: they assume GL_CULL_FACE.
BACKFACE_STAGES = ("bfc", "cbfc", "cbfc_thesis", "cone", "tbfc")

# Stages that never drop a triangle the full world's item buffer shows (proved by the tests);
# cbfc_thesis is the one stage outside it: the thesis's 2D rule drops front faces.
CONSERVATIVE = ("vfc", "vfc_thesis", "bfc", "cbfc", "cone", "tbfc", "occlusion",
                "occlusion_thesis", "portals", "pvs", "horizon")


# Stages that test the nodes vfc hands on: vfc's cover would change what they decide.
NODE_TESTS = {"vfc_thesis", "occlusion_thesis", "occlusion"}


def parse_stages(stages) -> tuple:
    """Stage names from a list/tuple or a comma string ("vfc,bfc,cbfc"), deduplicated, ordered
    by cost. Raises ValueError naming the valid stages on an unknown one."""
    if isinstance(stages, str):
        stages = [s for s in stages.replace("+", ",").split(",")]
    names = [str(s).strip().lower() for s in stages if str(s).strip() and str(s).strip() != "none"]
    unknown = [n for n in names if n not in STAGES]
    if unknown:
        raise ValueError(f"unknown culling stage(s) {', '.join(map(repr, unknown))}; "
                         f"valid: {', '.join(sorted(STAGES))} (or none)")
    return tuple(sorted(dict.fromkeys(names), key=lambda n: STAGES[n].cost))


def device_options(profile) -> dict:
    """Culler keyword arguments that tie culling to a device profile: its arithmetic mode
    (vertex format) and its screen, so occlusion and horizon may drop triangles that cover no
    pixel centre."""
    screen = tuple(profile.resolution)
    return {"arithmetic": profile.vertex_format, "occlusion": {"screen": screen},
            "horizon": {"screen": screen}}


class Culler:
    """Culls a Partition for a camera with a chosen set of stages.

    partition : Partition (layout contract in partition/base.py)
    stages    : list/tuple of names or a string joined by + (or ,), e.g. "vfc+bfc+cbfc"; "" or
                "none" = no culling. Valid names: STAGES. Applied in order of cost: node stages (portals,
                vfc, vfc_thesis, cone, occlusion_thesis, occlusion) refine the set of draw nodes,
                triangle stages (cbfc, tbfc) then filter the gathered references, bfc sets a flag.
    arithmetic: the device's arithmetic mode (float64, float32, fixed16.16); frustum planes are
                pushed out by its error bound, and stages with an `arithmetic` attribute
                (cbfc, cone, tbfc, occlusion, occlusion_thesis, portals) get it for their
                device-rounding margins (precision.device_move), so every decision stays
                conservative in that mode
    options   : per-stage keyword dicts, e.g. occlusion={"occluders": 32}, cbfc={"pitch_bands": 8}

    An AnimatedPartition (partition/dynamic.py) is culled in two halves: the stages run on its
    static partition as on any other, then its moving objects at the frame's time go through
    a BVH refitted per frame and each stage's moving-object test (culling/moving.py);
    `partition` stays the AnimatedPartition, `tree` is the static one's.
    """

    def __init__(self, partition: Partition, stages=("vfc",), arithmetic="float64", **options):
        if arithmetic not in MODES:
            raise ValueError(f"unknown arithmetic mode {arithmetic!r}; valid: {', '.join(MODES)}")
        self.arithmetic = arithmetic
        self.animated = partition if isinstance(partition, AnimatedPartition) else None
        given, partition = partition, (partition.static if self.animated else partition)
        self.world_scale = world_scale(partition.world.vertices)
        self.names = parse_stages(stages)
        extra = sorted(set(options) - set(STAGES))
        if extra:
            raise ValueError(f"options for unknown stage(s) {extra}; valid: {sorted(STAGES)}")
        self.tree = Tree(partition)
        self.partition = given
        self.stages = [STAGES[n](**options.get(n, {})) for n in self.names]
        for stage in self.stages:
            if hasattr(stage, "arithmetic"):  # stages with a device-rounding margin
                stage.arithmetic = arithmetic
            try:
                stage.prepare(self.tree)
            except AttributeError as error:
                # A memory-mapped world (mapped.MappedWorld) lacks the World's whole-world
                # tables (normals, corners, areas) that some stages precompute from.
                if isinstance(partition.world, World):
                    raise
                raise ValueError(f"culling stage {stage.name!r} needs an in-memory World "
                                 f"({error}); load the partition with load_partition instead "
                                 f"of map_partition") from None
        self._fuse()
        self._cover()
        self._chain()
        for stage in self.stages:  # pvs leaves out back faces only when they are culled,
            if stage.name in ("pvs", "portals"):  # portals' crack slivers pass them only then
                stage.back_culled = bool(set(self.names) & set(BACKFACE_STAGES))
        self.moving = None
        self._doors = None  # ([portals, pvs stages], door rows in the motion) if doors
        if self.animated is not None:
            self.world_scale = max(self.world_scale,
                                   world_scale(self.animated.animated.rest_vertices))
            self.moving = MovingObjects(self.animated,
                                        {stage.name: stage for stage in self.stages}, arithmetic)
            for stage in self.stages:  # moving objects occlude, posed at the frame's time
                if stage.name == "occlusion":
                    # weakly: the moving half holds the stages (no cycle: issue 28)
                    stage.extra_occluders = weakref.WeakMethod(self.moving.occluders)
            self._doors = attach_doors(self.stages, self.animated.animated)
            if self._doors is not None:  # their matrices every frame (pose computes them)
                self.moving.always = np.asarray(self._doors[1], dtype=np.int64)
            ids = self.animated.animated.static_ids
            self._static_prefix = not len(ids) or int(ids[-1]) == len(ids) - 1  # ids 0..S-1

    def __repr__(self) -> str:
        part = self.partition
        kind = getattr(part, "kind", type(part).__name__)
        moving = f", {len(self.moving.animated.motion):,} moving" if self.moving else ""
        return (f"Culler({'+'.join(self.names) or 'none'} over {kind} of "
                f"{part.world.triangle_count:,} triangles{moving}, {self.arithmetic})")

    def _cover(self) -> None:
        """vfc accepts covered nodes whole (FrustumStage cover) only when no later stage tests
        its nodes one by one (vfc_thesis, occlusion_thesis, occlusion): the triangle stages
        see the same triangles, and cone the same leaves (it expands nodes to their leaves)."""
        vfc = next((stage for stage in self.stages if stage.name == "vfc"), None)
        if vfc is not None:
            vfc.covering = vfc.cover and not set(self.names) & NODE_TESTS

    def _fuse(self) -> None:
        """When `vfc` and `occlusion` are the only node stages (no portals, cone or other node
        stage between them) and occlusion's `fuse` option is on, vfc defers its frustum test to
        occlusion, whose one walk rejects nodes outside the frustum or hidden behind the buffer
        (hiz.frustum_cull_nodes): hidden subtrees are never entered. Same tests, same
        conservativeness; fewer nodes visited. Likewise `pvs` takes vfc's walk (below)."""
        by_name = {stage.name: stage for stage in self.stages}
        vfc, occlusion = by_name.get("vfc"), by_name.get("occlusion")
        others = set(self.names) & {"portals", "pvs", "vfc_thesis", "cone", "occlusion_thesis",
                                    "horizon"}
        if vfc is not None and occlusion is not None and not others \
                and getattr(occlusion, "fuse", False):
            vfc.deferred = True
        # pvs then vfc alone among the node stages, on a static partition: pvs walks the
        # frustum over its set's subtrees, gathers and filters in one compiled call
        # (culling/pvs_frame.py), the same triangles as pvs's nodes walked by vfc and filtered;
        # with occlusion after them, the call only walks (occlusion tests the accepted nodes,
        # the gather follows, the set's bits filter it)
        pvs = by_name.get("pvs")
        if vfc is not None and pvs is not None and getattr(pvs, "fuse", False) \
                and self.animated is None and not others - {"pvs"}:
            pvs.walker = vfc
            pvs.gather = occlusion is None
            vfc.absorbed = True

    def _chain(self) -> None:
        """When vfc (deferred to occlusion), occlusion and tbfc are the stages (bfc, a render
        flag, may join) on a static partition, a frame runs in one compiled call
        (occlusion_chain.cull_chained: occlusion's frame, the gather, tbfc's and occlusion's
        triangle tests, observe): the same triangles and counters, without the Python between."""
        by_name = {stage.name: stage for stage in self.stages}
        occlusion, tbfc = by_name.get("occlusion"), by_name.get("tbfc")
        chained = (self.animated is None and set(self.names) <= {"vfc", "occlusion", "tbfc", "bfc"}
                   and isinstance(occlusion, DepthBufferOcclusion) and tbfc is not None
                   and getattr(by_name.get("vfc"), "deferred", False))
        self._chained = (occlusion, tbfc) if chained else None

    @property
    def cull_back(self) -> bool:
        """The render flag GL_CULL_FACE: True when `bfc` is a stage."""
        return "bfc" in self.names

    def cull(self, camera, time=None) -> CullResult:
        """Cull for one camera: CullResult with sorted unique `triangles`, `stats`, `cull_back`.

        time: seconds, the pose of an animated partition to cull (AnimatedWorld.posed(time) is
        what it draws); None: its rest pose. A static partition ignores it.

        stats counters: nodes_visited, plane_tests, triangles_tested, triangles_sent,
        draw_batches (runs of consecutive triangle ids), nodes_drawn, and per stage
        "<stage>.<counter>" (nodes_culled, refs_culled, clusters_culled, occluders, ...).
        """
        scale = max(self.world_scale, *map(abs, camera.position))
        if self.moving is not None:  # where the objects are now: their magnitude too
            scale = max(scale, self.moving.pose(time))
            if self._doors is not None:  # where the doors stand: shut ones block portals
                for stage in self._doors[0]:
                    stage.door_matrices = self.moving.matrices[self._doors[1]]
        if self._chained is not None:  # the whole frame, planes too, in one compiled call
            result, planes = cull_chained(*self._chained, camera, self.arithmetic, scale,
                                          self.cull_back)
            if result is not None:
                return result
        else:
            planes = culling_planes(camera, self.arithmetic, scale)
        state = CullState(self.tree, camera, planes, np.zeros(1, dtype=np.int64),
                          stats={"nodes_visited": 0, "plane_tests": 0, "triangles_tested": 0})
        try:
            for stage in self.stages:
                stage.apply(state)
            if state.frustum_pending:  # a deferred frustum test nobody took: a wiring error
                raise RuntimeError("vfc deferred its frustum test but no stage took it")
            result = state.finish()
        finally:
            state.filters.clear()  # they close over state: no cycle outlives the frame
            state.late_filters.clear()
        for stage in self.stages:
            observe = getattr(stage, "observe", None)
            if observe is not None:
                observe(result)  # the static half's ids: what the stages know
        if self.moving is not None:
            result = self._with_moving(state, result, time)
        return result

    def _with_moving(self, state, result, time) -> CullResult:
        """The static result's ids mapped to the world's, merged with the moving objects'."""
        static = result.triangles if self._static_prefix else \
            self.animated.animated.static_ids[result.triangles]
        ids = self.moving.cull(state, static)
        result.stats["triangles_sent"] = len(ids)
        return CullResult(ids, result.nodes, result.stats, result.cull_back)

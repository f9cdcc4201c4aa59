"""A terrain world (.vmt) run through the engine: its LOD method at tau, its objects culled.

Per frame (TerrainScene.frame): the LOD method selects the ground for the camera at tau pixels
(tiles, roettger or roam: terrain/), the drawn pieces' largest nested vertical error sets how
far the horizon sinks the ground (terrain/ground.py), the objects standing on the terrain go
through the engine's Culler with the chosen stages over their partition (`horizon` casts over
the heightmap), each kept object is drawn (with object_lod at its coarsest level of detail
whose error projects below the same tau, lod/) Z-buffered into the ground.

Renderers keep their vertex buffers across frames: the tiles' per-tile slots
(render/tile_arena.py), Röttger's chunk grids with cached index slots (render/chunks.py),
ROAM's 32x32-cell sample blocks (tile_arena.BlockArena: a leaf within one block costs three
uint16 indices a frame; the few spanning blocks are gathered).

Frame figures (TerrainFrame): triangles of the ground and of the objects, LOD and cull and
render times, the method's error bound in pixels over the drawn pieces (lambda_b E / d, E the
piece's nested vertical error, d the eye's distance to its box; the knob tau bounds it except
where a finest piece cannot refine) and E's largest value in world units. The bound sets how
far the horizon sinks the drawn ground (terrain/ground.py: P / lambda_b of slope per unit of
distance).
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from ..errors import VisMobileError

METHODS = ("tiles", "roettger", "roam")


@dataclass
class TerrainFrame:
    """One frame's figures (module doc); triangles = ground + objects."""

    ground_triangles: int
    object_triangles: int
    error_px: float
    error_world: float
    lod_ms: float
    cull_ms: float
    render_ms: float
    upload_ms: float
    nodes_hidden: int
    triangles_hidden: int
    stats: dict
    ground_calls: int = 0  # draw calls an ES 1.1 device would make for the ground

    @property
    def triangles(self) -> int:
        return self.ground_triangles + self.object_triangles


def box_distance(eye, low, high) -> np.ndarray:
    """(K,) float64 distance from eye (3,) to boxes low/high (K, 3) (0 inside)."""
    gap = np.maximum(np.maximum(low - eye, eye - high), 0.0)
    return np.sqrt((gap * gap).sum(axis=1))


def bound_px(lam, errors, distances) -> float:
    """Largest lambda_b E / d over pieces (0 when none; inf for a piece with E > 0 and the
    eye in its box)."""
    errors = np.asarray(errors, dtype=np.float64)
    positive = errors > 0
    if not positive.any():
        return 0.0
    with np.errstate(divide="ignore"):
        return float((lam * errors[positive] / distances[positive]).max())


def triangle_cut_boxes(valid, triangles) -> np.ndarray:
    """(K, 4) int64 cell boxes [i0, i1, j0, j1] of the triangles (T, 3) (sample ids) with a
    no-data corner (valid: (N, N) bool): the alpha test may open them anywhere over their
    extent (terrain/ground.py)."""
    n = valid.shape[0]
    t = np.asarray(triangles, np.int64).reshape(-1, 3)
    t = t[~valid.ravel()[t].all(axis=1)]
    r, c = np.divmod(t, n)
    return np.stack([r.min(1), np.maximum(r.max(1) - 1, r.min(1)), c.min(1),
                     np.maximum(c.max(1) - 1, c.min(1))], 1)


def block_cut_boxes(valid, rows, cols, size) -> np.ndarray:
    """(K, 4) int64 cell boxes of square blocks (first sample rows, cols (K,), side size (K,)
    cells) whose 3 x 3 samples at their own scale (corners, edge midpoints, centre: every
    vertex a Röttger fan can use) include a no-data one."""
    steps = np.array([0, 1, 2])
    r = rows[:, None] + (size[:, None] // 2) * steps[None]
    c = cols[:, None] + (size[:, None] // 2) * steps[None]
    holed = ~valid[r[:, :, None], c[:, None, :]].all(axis=(1, 2))
    r0, c0, s = rows[holed], cols[holed], size[holed]
    return np.stack([r0, r0 + s - 1, c0, c0 + s - 1], 1).astype(np.int64)


class TilesLod:
    """Seed 002's tile quadtree, drawn from per-tile vertex slots that persist."""

    name = "tiles"

    def __init__(self, heightmap, profile):
        from ..render.tile_arena import TileArena
        from ..terrain.tiles import TilePyramid

        self.pyramid = TilePyramid.build(heightmap, 16)
        self.renderer = TileArena(self.pyramid, profile)
        self.holed = tile_holes(self.pyramid) if heightmap.valid is not None else None

    def cut_boxes(self, selection) -> np.ndarray:
        """(K, 4) cell boxes that may be cut (terrain/ground.py): in each drawn tile with a
        no-data vertex, every quad of its stride grid with a no-data corner, grown by one quad
        on each side (a reduced side's triangle spans two quads)."""
        p = self.pyramid
        flat = p.offsets[selection.level] + selection.ti * (1 << selection.level) + selection.tj
        holed = self.holed[flat]
        stride = 1 << (p.levels - selection.level[holed])
        a = np.arange(p.patch + 1)
        rows = (selection.ti[holed] * p.patch)[:, None] * stride[:, None] + a * stride[:, None]
        cols = (selection.tj[holed] * p.patch)[:, None] * stride[:, None] + a * stride[:, None]
        bad = ~self.pyramid.heightmap.valid[rows[:, :, None], cols[:, None, :]]
        quads = bad[:, :-1, :-1] | bad[:, 1:, :-1] | bad[:, :-1, 1:] | bad[:, 1:, 1:]
        k, qi, qj = np.nonzero(quads)
        s = stride[k]
        r0, c0 = rows[k, qi] - s, cols[k, qj] - s
        return np.stack([r0, r0 + 3 * s - 1, c0, c0 + 3 * s - 1], 1).astype(np.int64)

    def select(self, camera, resolution, tau):
        from ..terrain.tiles import select_tiles

        return select_tiles(self.pyramid, camera, resolution, tau)

    def errors(self, selection, camera, resolution) -> tuple:
        """(bound px, largest E world units) over the drawn tiles."""
        from ..terrain.tiles import pixel_scale

        p = self.pyramid
        if not len(selection.level):
            return 0.0, 0.0
        flat = p.offsets[selection.level] + selection.ti * (1 << selection.level) + selection.tj
        # A finest tile with no reduced side draws its samples exactly.
        e = np.where((selection.level == p.levels) & (selection.sides == 0), 0.0,
                     p.flat_error[flat])
        size = p.patch * (1 << (p.levels - selection.level)) * p.heightmap.spacing
        low = np.stack([selection.tj * size, p.flat_hmin[flat], selection.ti * size], 1)
        high = np.stack([(selection.tj + 1) * size, p.flat_hmax[flat], (selection.ti + 1) * size], 1)
        _, lam = pixel_scale(camera, resolution)
        return bound_px(lam, e, box_distance(camera.eye, low, high)), float(e.max())

    def triangles(self, selection) -> int:
        return int(selection.triangles)

    def calls(self, selection) -> int:
        """One glDrawElements per tile (its own vertex buffer, uint16 indices)."""
        return len(selection.level)

    def drawn_heights(self, selection) -> np.ndarray:
        """(N, N) drawn height at every sample (NaN where nothing is drawn)."""
        from ..terrain.tiles import selection_heights

        return selection_heights(self.pyramid, selection)

    def reset(self) -> None:
        """Forget frame-to-frame state (the arena's slots stay: they are only a cache)."""

    def draw(self, selection, camera):
        return self.renderer.draw(selection, camera)


def tile_holes(pyramid) -> np.ndarray:
    """(tiles,) bool per flat tile id: one of its (P+1)^2 vertices at its level's stride is a
    no-data sample (a summed-area table per level)."""
    valid, p, levels = pyramid.heightmap.valid, pyramid.patch, pyramid.levels
    out = np.zeros(int(pyramid.offsets[-1]), np.bool_)
    for level in range(levels + 1):
        stride = 1 << (levels - level)
        bad = ~valid[::stride, ::stride]
        table = np.zeros((bad.shape[0] + 1, bad.shape[1] + 1), np.int64)
        table[1:, 1:] = bad.cumsum(0).cumsum(1)
        lo = np.arange(1 << level) * p
        hi = lo + p + 1
        count = (table[hi[:, None], hi[None]] - table[lo[:, None], hi[None]]
                 - table[hi[:, None], lo[None]] + table[lo[:, None], lo[None]])
        out[pyramid.offsets[level]:pyramid.offsets[level + 1]] = (count > 0).ravel()
    return out


class RoettgerLod:
    """Seed 000's Röttger CLOD with Pires's cached chunks (terrain/display_lists.py)."""

    name = "roettger"

    def __init__(self, heightmap, profile):
        from ..render.chunks import ChunkRenderer
        from ..terrain.display_lists import DisplayLists
        from ..terrain.roettger import Roettger

        self.roettger = Roettger(heightmap)
        self.lists = DisplayLists(self.roettger)
        self.renderer = ChunkRenderer(self.lists, profile)

    def select(self, camera, resolution, tau):
        return self.lists.update(camera, resolution, tau)

    def errors(self, frame, camera, resolution) -> tuple:
        """(bound px, largest d * d2 world units) over the drawn leaves: d * d2 bounds the
        block's exact nested error (terrain/roettger.py); a finest leaf with no skipped
        midpoint draws its samples exactly (0)."""
        from ..terrain.tiles import pixel_scale

        r = self.roettger
        rows = r.leaf_rows[:r.leaf_count]
        if not len(rows):
            return 0.0, 0.0
        level, bi, bj, sides = rows[:, 0], rows[:, 1], rows[:, 2], rows[:, 3]
        flat = r.offsets[level] + bi * (1 << level) + bj
        size = ((r.heightmap.size - 1) >> level) * r.heightmap.spacing
        e = r.d2[flat] * size
        e = np.where((level == r.levels) & (sides == 0), 0.0, e)
        low = np.stack([bj * size, r.hmin[flat], bi * size], 1)
        high = np.stack([(bj + 1) * size, r.hmax[flat], (bi + 1) * size], 1)
        _, lam = pixel_scale(camera, resolution)
        return bound_px(lam, e, box_distance(camera.eye, low, high)), float(e.max())

    def cut_boxes(self, frame) -> np.ndarray:
        """(K, 4) cell boxes of the drawn leaves with a no-data vertex (terrain/ground.py)."""
        r = self.roettger
        rows = r.leaf_rows[:r.leaf_count]
        size = (r.heightmap.size - 1) >> rows[:, 0]
        return block_cut_boxes(r.heightmap.valid, rows[:, 1] * size, rows[:, 2] * size, size)

    def triangles(self, frame) -> int:
        return int(frame.triangles)

    def calls(self, frame) -> int:
        """One glCallList per visible chunk, plus one draw of the coarse leaves."""
        return len(frame.chunks) + (len(frame.coarse) > 0)

    def drawn_heights(self, frame) -> np.ndarray:
        from ..terrain.raster import triangle_heights

        return triangle_heights(self.roettger.heightmap.heights.astype(np.float64),
                                self.lists.sample_triangles(frame))

    def reset(self) -> None:
        """Forget the cached chunks (the next frame rebuilds every visible one)."""
        self.lists.cache = [None] * len(self.lists.cache)
        self.roettger.previous = None

    def draw(self, frame, camera):
        return self.renderer.draw(frame, camera)


class RoamLod:
    """Seed 003's ROAM (frame-coherent split and merge queues)."""

    name = "roam"

    def __init__(self, heightmap, profile):
        from ..render.tile_arena import BlockArena
        from ..terrain.roam import Roam

        self.roam = Roam(heightmap)
        self.renderer = BlockArena(heightmap, profile)

    def select(self, camera, resolution, tau):
        return self.roam.update(camera, resolution, tau)

    def errors(self, frame, camera, resolution) -> tuple:
        """(the frame's bound_px, largest wedgie of the drawn leaves in world units). A leaf
        is emitted as (v, a, e), v its right-angle vertex (terrain/roam_frame.py's _emit), so
        its hypotenuse (a, e) has the midpoint of the diamond that would split it; finest
        leaves' hypotenuses are cell diagonals (no sample: exact)."""
        t = frame.triangles
        if not len(t):
            return 0.0, 0.0
        n = self.roam.heightmap.size
        r1, c1 = np.divmod(t[:, 1], n)
        r2, c2 = np.divmod(t[:, 2], n)
        mr, mc = r1 + r2, c1 + c2
        whole = (mr % 2 == 0) & (mc % 2 == 0)
        mid = (mr[whole] // 2) * n + mc[whole] // 2
        best = float(self.roam.wedge[mid, 2].max()) if len(mid) else 0.0
        centre = (n // 2) * n + n // 2
        if not self.roam.split[centre]:  # the two roots, emitted corner first
            best = max(best, float(self.roam.wedge[centre, 2]))
        return float(frame.bound_px), best

    def cut_boxes(self, frame) -> np.ndarray:
        """(K, 4) cell boxes of the drawn triangles with a no-data corner (terrain/ground.py)."""
        return triangle_cut_boxes(self.roam.heightmap.valid, frame.triangles)

    def triangles(self, frame) -> int:
        return len(frame.triangles)

    def calls(self, frame) -> int:
        """One glDrawElements per batch of 21,845 triangles (65,535 uint16 vertices)."""
        return -(-len(frame.triangles) // 21845)

    def drawn_heights(self, frame) -> np.ndarray:
        from ..terrain.raster import triangle_heights

        return triangle_heights(self.roam.heights, frame.triangles)

    def reset(self) -> None:
        """Back to the two root triangles."""
        self.roam.reset()

    def draw(self, frame, camera):
        return self.renderer.draw(frame.triangles, camera)


class PagedLod(TilesLod):
    """The tile quadtree of a .vmtiles terrain paged in under a memory budget: selection on
    its statistics, tiles read on a miss or ahead by the loader thread (terrain/paged.py)."""

    name = "tiles"

    def __init__(self, path, profile, budget_bytes):
        from ..render.tile_arena import PagedArena
        from ..terrain.paged import PagedTiles

        self.paged = PagedTiles(path, budget_bytes)
        self.pyramid = self.paged.pyramid
        self.renderer = PagedArena(self.paged, profile)

    def select(self, camera, resolution, tau):
        selection = super().select(camera, resolution, tau)
        self.paged.read_ahead(selection, camera, resolution, tau)
        return selection


class PagedRoettgerLod:
    """Röttger's CLOD of a .vmrpages terrain paged in under a memory budget: refinement on the
    coarse blocks in memory and the held pages, wanted pages read at once, the loader thread
    reading ahead (terrain/paged_roettger.py); the fans gathered each frame."""

    name = "roettger"

    def __init__(self, path, profile, budget_bytes):
        from ..render.tile_arena import PagedRenderer
        from ..terrain.paged_roettger import PagedRoettger

        self.paged = PagedRoettger(path, budget_bytes)
        self.renderer = PagedRenderer(self.paged, profile)

    def select(self, camera, resolution, tau):
        self.paged.select(camera, resolution, tau)
        return self.paged.triangles()

    def errors(self, triangles, camera, resolution) -> tuple:
        """RoettgerLod.errors over the drawn leaves (d * d2 bounds each block's error)."""
        from ..terrain.tiles import pixel_scale

        p = self.paged
        if not p.leaf_count:
            return 0.0, 0.0
        e, low_y, high_y = p.leaf_errors()
        level, bi, bj = p.leaf_rows[:p.leaf_count, :3].T
        size = ((p.size - 1) >> level) * p.heightmap.spacing
        low = np.stack([bj * size, low_y, bi * size], 1)
        high = np.stack([(bj + 1) * size, high_y, (bi + 1) * size], 1)
        _, lam = pixel_scale(camera, resolution)
        return bound_px(lam, e, box_distance(camera.eye, low, high)), float(e.max())

    def cut_boxes(self, triangles) -> np.ndarray:
        return np.zeros((0, 4), np.int64)  # a paged terrain carries no objects to cull

    def triangles(self, triangles) -> int:
        return len(triangles)

    def calls(self, triangles) -> int:
        """One glDrawElements per batch of 21,845 triangles (65,535 uint16 vertices)."""
        return -(-len(triangles) // 21845)

    def drawn_heights(self, triangles) -> np.ndarray:
        raise VisMobileError("--measure-error needs the whole heightmap; a paged terrain "
                             "does not hold it")

    def reset(self) -> None:
        """Nothing kept from frame to frame but held pages (a cache)."""

    def draw(self, triangles, camera):
        return self.renderer.draw_samples(triangles, camera,
                                          kind="shaded")


LODS = {"tiles": TilesLod, "roettger": RoettgerLod, "roam": RoamLod}
PAGED = {".vmtiles": ("tiles", PagedLod), ".vmrpages": ("roettger", PagedRoettgerLod)}


class TerrainScene:
    """A .vmt terrain with its LOD method at tau and its objects culled by `stages`.

    structure : the objects' partition ("octree:4"; "none" draws every object)
    """

    def __init__(self, path, method="tiles", tau=1.0, stages=("vfc", "horizon"),
                 structure="octree:4", profile="ipaq-hx2490b", page_budget=16 << 20,
                 object_lod: bool = False, cache_dir=None):
        from ..device.profile import get_profile
        from ..terrain import store
        from ..terrain.placement import Placement

        suffix = "." + str(path).lower().rsplit(".", 1)[-1]
        if method is None:
            method = PAGED[suffix][0] if suffix in PAGED else "tiles"
        if method not in LODS:
            raise VisMobileError(f"--terrain-method {method!r}: one of {', '.join(METHODS)}")
        tau = float(tau)
        if not np.isfinite(tau) or not tau > 0:
            raise VisMobileError(f"--lod for a terrain must be a finite number of pixels > 0, "
                                 f"got {tau}")
        self.path = str(path)
        self.profile = get_profile(profile)
        self.tau = tau
        self.method = method
        self.stages = tuple(stages)
        if suffix in PAGED:  # paged in (terrain/paged.py, terrain/paged_roettger.py)
            own, kind = PAGED[suffix]
            if method != own:
                raise VisMobileError(f"{path}: a {suffix} terrain is drawn by the {own} "
                                     f"method, not {method}")
            lod = kind(path, self.profile, page_budget)
            self.heightmap, self.placement = lod.paged.heightmap, Placement.empty()
            self.lods = {method: lod}
        else:
            self.heightmap, self.placement = store.load(path)
            self.lods = {method: LODS[method](self.heightmap, self.profile)}
        self.lod = self.lods[method]
        self.objects = self.culler = self.object_renderer = self.object_lod = None
        self.last = self.culled = None  # the last frame's selection and culled objects
        self.structure = "none"
        self.object_lod_on = bool(object_lod)
        if len(self.placement):
            self._objects(structure, cache_dir)

    def _objects(self, structure, cache_dir=None):
        from ..render.renderer import Renderer
        from ..terrain.ground import TerrainGround
        from ..world.world import World
        from .playback import Scene, make_culler, parse_structure

        parts = [World(v, t, np.zeros(len(t), np.int32), [f"{self.placement.kinds[k]}{k}"],
                       self.heightmap.name) for k, (v, t) in enumerate(self.placement.meshes())]
        objects = World.concatenate(parts, self.heightmap.name)
        objects.ground = TerrainGround(self.heightmap)  # the horizon stage's occluder
        self.objects = objects
        kind, params = parse_structure(structure)
        partition = None
        if kind is not None:
            from ..partition import partition as build_partition

            partition = build_partition(objects, kind, **params)
            self.structure = structure
        self.culler = make_culler(Scene(objects, partition, self.structure), self.stages,
                                  self.profile)
        self.object_renderer = Renderer(objects, self.profile)
        if self.object_lod_on:
            # The same knob drives the objects' level of detail (lod/: each object's coarsest
            # level whose error projects below tau pixels); chains built once per objects
            # world and kept in cache_dir (study.engine.load_chains: 40 objects took 30 s of
            # CPU to build).
            from ..lod import LodSelector, render_world
            from ..study.engine import load_chains

            chains = load_chains(objects, cache_dir)
            self.object_lod = LodSelector(objects, chains, self.profile.resolution)
            self.object_renderer = Renderer(render_world(objects, chains), self.profile)
        self.partition = partition

    def set_method(self, method: str) -> None:
        """Switch the LOD method (each built once, then kept with its frame-to-frame state)."""
        if method not in LODS:
            raise VisMobileError(f"terrain method {method!r}: one of {', '.join(METHODS)}")
        if method not in self.lods:
            if isinstance(self.lod, (PagedLod, PagedRoettgerLod)):
                raise VisMobileError(f"{self.path}: a paged terrain is drawn by the "
                                     f"{self.lod.name} method only")
            self.lods[method] = LODS[method](self.heightmap, self.profile)
        self.method, self.lod = method, self.lods[method]

    def set_stages(self, stages) -> None:
        """Cull the objects with these stages (VisMobileError when the partition cannot)."""
        from .playback import Scene, make_culler

        if self.objects is not None:
            self.culler = make_culler(Scene(self.objects, self.partition, self.structure),
                                      tuple(stages), self.profile)
        self.stages = tuple(stages)

    def frame(self, camera) -> TerrainFrame:
        """Select, cull, draw (module doc); the camera should have the profile's aspect."""
        from ..terrain.tiles import pixel_scale

        resolution = self.profile.resolution
        start = time.perf_counter()
        selected = self.last = self.lod.select(camera, resolution, self.tau)
        lod_ms = (time.perf_counter() - start) * 1000.0
        error_px, error_world = self.lod.errors(selected, camera, resolution)
        cull_ms, object_triangles, hidden, hidden_triangles, stats = 0.0, 0, 0, 0, {}
        culled = None
        if self.culler is not None:
            _, lam = pixel_scale(camera, resolution)
            self.objects.ground.sink = error_px / lam  # terrain/ground.py
            start = time.perf_counter()
            if self.heightmap.valid is not None:  # culling work: in cull_ms
                self.objects.ground.cut = self.lod.cut_boxes(selected)
            culled = self.culled = self.culler.cull(camera)
            cull_ms = (time.perf_counter() - start) * 1000.0
            stats = dict(culled.stats)
            hidden = int(stats.get("horizon.nodes_culled", 0))
            hidden_triangles = int(stats.get("horizon.triangles_culled", 0))
        drawn = self.lod.draw(selected, camera)
        render_ms, upload_ms = drawn.render_ms, drawn.upload_ms
        if culled is not None and len(culled.triangles):
            sent = culled.triangles
            if self.object_lod is not None:
                start = time.perf_counter()
                sent = self.object_lod.select(culled.triangles, camera, self.tau).triangles
                lod_ms += (time.perf_counter() - start) * 1000.0
            more = self.object_renderer.draw(sent, camera, bool(culled.cull_back), clear=False)
            render_ms += more.render_ms
            upload_ms += more.upload_ms
            object_triangles = more.triangles
        return TerrainFrame(self.lod.triangles(selected), object_triangles, error_px,
                            error_world, lod_ms, cull_ms, render_ms, upload_ms, hidden,
                            hidden_triangles, stats, self.lod.calls(selected))

    def read_rgb(self) -> np.ndarray:
        return self.lod.renderer.read_rgb()

    def visible_dropped(self, camera, renderer=None) -> int:
        """Object triangles the last frame's culling dropped that the item buffer of its drawn
        LOD ground (holes cut as drawn) plus every object at full detail shows: 0 when the
        culling was conservative. renderer: a TerrainRenderer of the heightmap (one is made
        when None). Not for timed frames."""
        from ..render.terrain import TerrainRenderer

        renderer = renderer or TerrainRenderer(self.heightmap, self.profile)
        lod, selected, objects = self.lod, self.last, self.objects
        if lod.name == "tiles":
            from ..terrain.tiles import selection_mesh

            first = renderer.draw(*selection_mesh(lod.pyramid, selected), camera,
                                  kind="item").triangles
        elif lod.name == "roettger":
            first = renderer.draw_samples(lod.lists.sample_triangles(selected), camera,
                                          kind="item").triangles
        else:
            first = renderer.draw_samples(selected.triangles, camera, kind="item").triangles
        renderer.draw_mesh_items(objects.vertices, objects.triangles, camera, first)
        ids = renderer.read_ids().ravel()
        seen = np.unique(ids[(ids >= first) & (ids < first + objects.triangle_count)]) - first
        kept = np.zeros(objects.triangle_count, bool)
        kept[self.culled.triangles] = True
        return int((~kept[seen]).sum())

    def sample_error_px(self, camera) -> float:
        """The last frame's exact largest screen error (pixels) over the samples in the
        frustum that the drawn ground covers (study.terrain.vertex_errors): the measured
        counterpart of the frame's bound; O(N^2), not for timed frames."""
        from ..study.terrain import vertex_errors

        errors = vertex_errors(self.heightmap, self.lod.drawn_heights(self.last), camera,
                               self.profile.resolution)
        return float(errors.max()) if len(errors) else 0.0


def default_cameras(heightmap, count=None, aspect=240 / 320):
    """Cameras of one lap of the fast circle path (terrain/paths.py), or count of them."""
    from ..terrain.paths import lap_frames, path_cameras

    lap = lap_frames(heightmap, "circle", "fast")
    return path_cameras(heightmap, "circle", "fast", frames=min(lap, count or lap),
                        aspect=aspect)

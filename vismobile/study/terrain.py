"""Terrain LOD against image error: triangles, LOD ms, render ms and error per frame.

Error of an LOD frame against the full-resolution render of the whole heightmap (same camera,
same renderer, same per-vertex normals and colours, so only geometry differs):
- psnr      : of the shaded RGB images, dB (inf when identical)
- differing : fraction of pixels whose colour differs at all
- pixel_height_max / _p99 : for each pixel of the LOD render, the world point under it (from
  the depth buffer) against the full-resolution ground at the same (x, z), projected: the
  vertical gap in pixels (seed 002's screen-space error, measured)
- vertex_error_max : the same gap at every full-resolution sample inside the frustum, exact
  (no depth-buffer rounding); the tile method's bound says it never exceeds tau
"""
from __future__ import annotations

import time

import numpy as np

METHODS = ("tiles", "roettger", "roam")  # the engine's terrain methods, in the sweep's order


def project(points, camera, resolution) -> tuple:
    """Pixel coordinates (..., 2) float64 of world points and (...,) bool in front of the eye."""
    points = np.asarray(points, dtype=np.float64)
    clip = points @ camera.view_projection()[:, :3].T + camera.view_projection()[:, 3]
    w = clip[..., 3]
    front = w > camera.near * 0.999
    safe = np.where(front, w, 1.0)
    px = (clip[..., 0] / safe + 1) / 2 * resolution[0]
    py = (1 - clip[..., 1] / safe) / 2 * resolution[1]
    return np.stack([px, py], axis=-1), front


def vertical_gap_pixels(x, y_drawn, y_true, z, camera, resolution) -> np.ndarray:
    """Screen distance in pixels between (x, y_drawn, z) and (x, y_true, z); NaN where either
    point is outside the frustum."""
    from ..geometry.planes import points_inside

    a = np.stack([x, y_drawn, z], axis=-1).reshape(-1, 3)
    b = np.stack([x, y_true, z], axis=-1).reshape(-1, 3)
    planes = camera.frustum_planes()
    inside = points_inside(a, planes) & points_inside(b, planes)
    pa, _ = project(a, camera, resolution)
    pb, _ = project(b, camera, resolution)
    gap = np.linalg.norm(pa - pb, axis=1)
    return np.where(inside, gap, np.nan).reshape(np.shape(x))


def vertex_errors(heightmap, drawn, camera, resolution) -> np.ndarray:
    """(M,) float64 pixel gaps at every sample with a drawn height inside the frustum.

    drawn : (N, N) float64 drawn-surface height per sample (NaN = not drawn)
    """
    i, j = np.nonzero(np.isfinite(drawn))
    x, z = j * heightmap.spacing, i * heightmap.spacing
    gap = vertical_gap_pixels(x, drawn[i, j], heightmap.heights[i, j].astype(np.float64), z,
                              camera, resolution)
    return gap[np.isfinite(gap)]


def world_error(heightmap, drawn, camera) -> float:
    """Largest vertical gap (world units) between a drawn surface (N, N; NaN = not drawn) and
    the samples, over the samples inside the frustum (0 when none)."""
    from ..geometry.planes import points_inside

    i, j = np.nonzero(np.isfinite(drawn))
    points = np.stack([j * heightmap.spacing, heightmap.heights[i, j], i * heightmap.spacing], -1)
    inside = points_inside(points, camera.frustum_planes())
    if not inside.any():
        return 0.0
    return float(np.abs(drawn[i, j] - heightmap.heights[i, j])[inside].max())


def pixel_height_errors(depth, camera, heightmap, resolution, alternating=False) -> np.ndarray:
    """(M,) float64 pixel gaps at every pixel covered by terrain in a depth image (H, W),
    against the grid mesh (or Röttger's 4-8 mesh when alternating)."""
    from ..render.terrain import unproject

    points = unproject(depth, camera)
    covered = np.isfinite(points[..., 0])
    p = points[covered]
    inside = (p[:, 0] >= 0) & (p[:, 0] <= heightmap.extent) & (p[:, 2] >= 0) & \
        (p[:, 2] <= heightmap.extent)
    p = p[inside]
    truth = heightmap.height_at(p[:, 0], p[:, 2], alternating)
    gap = vertical_gap_pixels(p[:, 0], p[:, 1], truth, p[:, 2], camera, resolution)
    return gap[np.isfinite(gap)]


def image_error(reference, image) -> dict:
    """psnr (dB, inf when equal) and differing (fraction of pixels) of two (H, W, 3) uint8."""
    diff = reference.astype(np.float64) - image.astype(np.float64)
    mse = float((diff ** 2).mean())
    psnr = float("inf") if mse == 0 else 10.0 * np.log10(255.0 ** 2 / mse)
    return {"psnr": psnr, "differing": float((diff != 0).any(axis=-1).mean())}


def draw_four_eight(renderer, heightmap, camera) -> int:
    """Draw the 4-8 mesh of the finest bintree triangles (= Röttger's finest fans), culled per
    triangle box against the frustum (errs visible); returns the triangles drawn."""
    from ..geometry.planes import classify_boxes
    from ..terrain.roam import full_mesh

    triangles = full_mesh(heightmap)
    r, c = np.divmod(triangles, heightmap.size)
    y = heightmap.heights.ravel()[triangles]
    s = heightmap.spacing
    boxes = np.stack([np.stack([c.min(1) * s, y.min(1), r.min(1) * s], -1),
                      np.stack([c.max(1) * s, y.max(1), r.max(1) * s], -1)], axis=1)
    keep = ~classify_boxes(boxes, camera.frustum_planes())[0]
    renderer.draw_samples(triangles[keep], camera)
    return int(keep.sum())


class TileMethod:
    """Seed 002's tile quadtree as a measurable method."""

    name = "tiles"
    alternating = False  # the grid's diagonals

    def __init__(self, pyramid, caster=None):
        """caster: a HorizonCaster to drop tiles hidden behind nearer ground (seed 001)."""
        self.pyramid = pyramid
        self.caster = caster
        if caster is not None:
            self.name = "tiles+horizon"

    def reference(self, renderer, camera):
        """Draw the full-resolution mesh this method converges to."""
        from ..terrain.tiles import full_selection, selection_mesh

        full = full_selection(self.pyramid, camera)
        renderer.draw(*selection_mesh(self.pyramid, full), camera)
        return full.triangles

    def frame(self, camera, resolution, tau) -> tuple:
        """(result, lod_ms, triangles) for one frame; self.cpu_ms: its thread CPU time."""
        from ..terrain.tiles import drop_hidden, select_tiles, selection_error

        cpu = time.thread_time()
        start = time.perf_counter()
        selection = select_tiles(self.pyramid, camera, resolution, tau)
        if self.caster is not None:
            lower = selection_error(self.pyramid, selection)
            selection = drop_hidden(self.pyramid, selection, self.caster.cast(camera, lower))
        wall = (time.perf_counter() - start) * 1000.0
        self.cpu_ms = (time.thread_time() - cpu) * 1000.0
        return selection, wall, selection.triangles

    def draw(self, renderer, selection, camera):
        from ..terrain.tiles import selection_mesh

        return renderer.draw(*selection_mesh(self.pyramid, selection), camera)

    def heights(self, selection) -> np.ndarray:
        from ..terrain.tiles import selection_heights

        return selection_heights(self.pyramid, selection)


class RoettgerMethod:
    """Seed 000's Röttger CLOD as a measurable method (frame-to-frame state is kept)."""

    name = "roettger"
    alternating = True  # the finest fans form a 4-8 mesh

    def __init__(self, roettger):
        self.roettger = roettger

    def reference(self, renderer, camera):
        """Draw Röttger's own full-resolution mesh, the 4-8 mesh of finest fans, frustum-culled
        per triangle (not Röttger's culled refinement: blocks beside culled ones stay coarse
        there and skip their midpoints, so that mesh is not full resolution at the frustum's
        edges)."""
        return draw_four_eight(renderer, self.roettger.heightmap, camera)

    def frame(self, camera, resolution, tau) -> tuple:
        cpu = time.thread_time()
        result = self.roettger.update(camera, resolution, tau)
        self.cpu_ms = (time.thread_time() - cpu) * 1000.0
        return result, result.lod_ms, len(result.triangles)

    def draw(self, renderer, result, camera):
        return renderer.draw_samples(result.triangles, camera)

    def heights(self, result) -> np.ndarray:
        from ..terrain.raster import triangle_heights

        return triangle_heights(self.roettger.heightmap.heights.astype(np.float64),
                                result.triangles)


class RoamMethod:
    """Seed 003's ROAM as a measurable method (the mesh persists from frame to frame).

    budget: a triangle cap (ROAM's budget mode). With a geomorphing Roam the drawn and
    measured surface is the morphed one.
    """

    alternating = True  # the finest bintree triangles form the same 4-8 mesh as Röttger's

    def __init__(self, roam, budget=None):
        self.roam = roam
        self.budget = budget
        self.name = "roam" if budget is None else f"roam/{budget}"

    def reference(self, renderer, camera):
        """Draw the finest bintree mesh (frustum-culled by triangle boxes)."""
        return draw_four_eight(renderer, self.roam.heightmap, camera)

    def frame(self, camera, resolution, tau) -> tuple:
        cpu = time.thread_time()
        result = self.roam.update(camera, resolution, tau, budget=self.budget)
        self.cpu_ms = (time.thread_time() - cpu) * 1000.0
        return result, result.lod_ms, len(result.triangles)

    def _drawn_heights(self, result):
        ids, values = result.morph
        if not len(ids):
            return None
        heights = self.roam.heightmap.heights.astype(np.float64).copy()
        heights.ravel()[ids] = values
        return heights

    def draw(self, renderer, result, camera):
        return renderer.draw_samples(result.triangles, camera,
                                     heights=self._drawn_heights(result))

    def heights(self, result) -> np.ndarray:
        """Drawn height at every sample (NaN where nothing is drawn), morphs included: the
        error of a morphing vertex is measured against where it is drawn."""
        from ..terrain.raster import triangle_heights

        drawn = self._drawn_heights(result)
        if drawn is None:
            drawn = self.roam.heightmap.heights.astype(np.float64)
        out = triangle_heights(drawn, result.triangles)
        return out


def measure(methods, heightmap, cameras, taus, profile, exact_vertices: bool = False,
            render: bool = True) -> list:
    """One row per (method, tau, camera) against the full render of the heightmap.

    Each method is compared with its own full-resolution mesh (the grid for tiles, the 4-8
    mesh of finest fans for Röttger). Cameras run in order for each (method, tau), so
    frame-to-frame methods see a path. Row keys: method, tau, frame, triangles,
    full_triangles, lod_ms, render_ms, psnr, differing, pixel_height_max, pixel_height_p99
    (with exact_vertices also vertex_error_max in pixels and vertical_error_max in world
    units, over the samples in the frustum; render=False skips renders and image errors).
    """
    from ..render.terrain import TerrainRenderer

    resolution = profile.resolution
    renderer = TerrainRenderer(heightmap, profile)
    rows = []
    for method in methods:
        references, full_counts = [], []
        for camera in cameras if render else ():
            full_counts.append(method.reference(renderer, camera))
            references.append(renderer.read_rgb())
        if not render:
            full_counts = [None] * len(cameras)
        if cameras and taus:
            warm_up(method, cameras[0], resolution, taus[0])
        for tau in taus:
            for frame, camera in enumerate(cameras):
                result, lod_ms, triangles = method.frame(camera, resolution, tau)
                row = {"method": method.name, "tau": tau, "frame": frame,
                       "triangles": triangles, "full_triangles": full_counts[frame],
                       "lod_ms": lod_ms}
                if render:
                    stats = method.draw(renderer, result, camera)
                    gaps = pixel_height_errors(renderer.read_depth(), camera, heightmap,
                                               resolution, method.alternating)
                    row.update(render_ms=stats.render_ms,
                               **image_error(references[frame], renderer.read_rgb()),
                               pixel_height_max=float(gaps.max()) if len(gaps) else 0.0,
                               pixel_height_p99=float(np.percentile(gaps, 99)) if len(gaps) else 0.0)
                if exact_vertices:
                    drawn = method.heights(result)
                    errors = vertex_errors(heightmap, drawn, camera, resolution)
                    row["vertex_error_max"] = float(errors.max()) if len(errors) else 0.0
                    row["vertical_error_max"] = world_error(heightmap, drawn, camera)
                rows.append(row)
    return rows


def warm_up(method, camera, resolution, tau) -> float:
    """One untimed frame, so numba's first-use compile (seconds; a minute for ROAM on a loaded
    machine) is in no frame's LOD ms; the frame-to-frame state is put back (ROAM refines from
    its two roots again, Röttger forgets its last chunk signatures). Returns its wall ms."""
    start = time.perf_counter()
    method.frame(camera, resolution, tau)
    if hasattr(method, "roam"):
        method.roam.reset()
    if hasattr(method, "roettger"):
        method.roettger.previous = None
    return (time.perf_counter() - start) * 1000.0


def build_method(name: str, heightmap, patch: int = 16, C: float = 8.0):
    """A measurable method by name: tiles, roettger, roam (or roam/BUDGET: budget mode), or a
    PyPI peer (martini, delatin; study.peers, static meshes at a world-unit error)."""
    if name == "tiles":
        from ..terrain.tiles import TilePyramid

        return TileMethod(TilePyramid.build(heightmap, patch))
    if name == "roettger":
        from ..terrain.roettger import Roettger

        return RoettgerMethod(Roettger(heightmap, C=C))
    if name == "roam" or name.startswith("roam/"):
        from ..terrain.roam import Roam

        budget = None
        if "/" in name:
            try:
                budget = int(name.split("/", 1)[1])
            except ValueError:
                raise ValueError(f"roam budget must be an integer: {name!r}") from None
        return RoamMethod(Roam(heightmap), budget)
    raise ValueError(f"unknown terrain method {name!r} (tiles, roettger, roam, roam/BUDGET)")


def path_frames(heightmap, kind: str, speed: str, frames: str) -> list:
    """Cameras of one lap of a path for a frames spec: all, stride:N or sample:N."""
    from ..terrain.paths import lap_frames, path_cameras

    lap = lap_frames(heightmap, kind, speed)
    mode, _, value = frames.partition(":")
    if mode == "all" and not value:
        return path_cameras(heightmap, kind, speed, frames=lap)
    try:
        count = int(value)
    except ValueError:
        count = 0
    if mode not in ("stride", "sample") or count < 1:
        raise ValueError(f"frames must be all, stride:N or sample:N (N >= 1), got {frames!r}")
    if mode == "stride":
        return path_cameras(heightmap, kind, speed, frames=-(-lap // count), every=count)
    every = max(1, lap // count)
    return path_cameras(heightmap, kind, speed, frames=min(count, lap), every=every)


SWEEP_KEYS = ("method", "path", "tau", "frames", "triangles", "full_triangles", "lod_ms",
              "render_ms", "psnr_min", "psnr_median", "differing_median", "pixel_height_max",
              "pixel_height_p99", "sample_error_max", "vertical_error_max")


def sweep(heightmap, names, paths, taus, profile, frames: str = "sample:4", patch: int = 16,
          C: float = 8.0, progress=None) -> list:
    """The pixel-knob sweep: one summary row per (method, path, tau) over the path's frames
    (keys SWEEP_KEYS; medians unless the key says min/max). paths: [(kind, speed)]."""
    rows = []
    for name in names:
        method = build_method(name, heightmap, patch, C)
        for kind, speed in paths:
            if progress:
                progress(f"{name} on the {speed} {kind}")
            if hasattr(method, "roam"):
                method.roam.reset()
            cameras = path_frames(heightmap, kind, speed, frames)
            measured = measure([method], heightmap, cameras, taus, profile, exact_vertices=True)
            for tau in taus:
                r = [x for x in measured if x["tau"] == tau]
                rows.append({
                    "method": method.name, "path": f"{kind} {speed}", "tau": float(tau),
                    "frames": len(r),
                    "triangles": float(np.median([x["triangles"] for x in r])),
                    "full_triangles": float(np.median([x["full_triangles"] for x in r])),
                    "lod_ms": float(np.median([x["lod_ms"] for x in r])),
                    "render_ms": float(np.median([x["render_ms"] for x in r])),
                    "psnr_min": float(min(x["psnr"] for x in r)),
                    "psnr_median": float(np.median([x["psnr"] for x in r])),
                    "differing_median": float(np.median([x["differing"] for x in r])),
                    "pixel_height_max": float(max(x["pixel_height_max"] for x in r)),
                    "pixel_height_p99": float(np.median([x["pixel_height_p99"] for x in r])),
                    "sample_error_max": float(max(x["vertex_error_max"] for x in r)),
                    "vertical_error_max": float(max(x["vertical_error_max"] for x in r)),
                })
    return rows

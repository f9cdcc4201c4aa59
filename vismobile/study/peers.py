"""The PyPI peers of the terrain methods: pymartini (RTIN, Evans et al. 1997 as Mapbox's
Martini) and pydelatin (greedy Delaunay refinement, Garland and Heckbert 1995), measured like
the engine's methods (optional extra `peers`; imported lazily).

Both build one view-independent mesh for a largest vertical error E (world units) over the
whole map; the engine's methods refine per frame for a screen error in pixels. Two ways to
put them side by side along the same cameras:

- equal triangles: E is bisected until the peer's mesh, frustum-culled, has as many triangles
  as the method drew (median over the frames); then compare PSNR and screen error;
- equal error: E = the largest vertical gap (world units) the method left at a sample in the
  frustum; then compare triangles.
"""
from __future__ import annotations

import time

import numpy as np

PEERS = ("martini", "delatin")
MODULES = {"martini": "pymartini", "delatin": "pydelatin"}


def missing(name: str) -> str | None:
    """Why the peer cannot run here (None when it can)."""
    import importlib

    if name not in MODULES:
        return f"unknown peer {name!r} (one of {', '.join(PEERS)})"
    try:
        importlib.import_module(MODULES[name])
    except ImportError as exc:
        return f"{MODULES[name]} is not installed ({exc}); pip install 'vismobile[peers]'"
    return None


def peer_mesh(heightmap, name: str, max_error: float, cache: dict | None = None) -> np.ndarray:
    """(T, 3) int64 sample ids (row * N + col), counter-clockwise from +y, of the peer's mesh
    whose vertical error over the samples is at most max_error (world units)."""
    h = heightmap.heights.astype(np.float32)
    n = heightmap.size
    if name == "martini":
        from pymartini import Martini

        if cache is not None and "martini" in cache:
            tile = cache["martini"]
        else:
            tile = Martini(n).create_tile(h)
            if cache is not None:
                cache["martini"] = tile
        vertices, triangles = tile.get_mesh(float(max_error))
        xy = np.asarray(vertices).reshape(-1, 2).astype(np.int64)
        ids = xy[:, 1] * n + xy[:, 0]  # x = column, y = row
    elif name == "delatin":
        from pydelatin import Delatin

        tin = Delatin(h, max_error=float(max_error))
        xy = np.rint(tin.vertices[:, :2]).astype(np.int64)
        ids = (n - 1 - xy[:, 1]) * n + xy[:, 0]  # y counts rows from the last one
        triangles = tin.triangles
    else:
        raise ValueError(f"unknown peer {name!r}")
    t = ids[np.asarray(triangles, dtype=np.int64).reshape(-1, 3)]
    r, c = np.divmod(t, n)
    cross = (r[:, 1] - r[:, 0]) * (c[:, 2] - c[:, 0]) - (c[:, 1] - c[:, 0]) * (r[:, 2] - r[:, 0])
    t = t[cross != 0]
    flip = cross[cross != 0] < 0
    t[flip] = t[flip][:, [0, 2, 1]]
    return t


def in_frustum(heightmap, triangles, camera) -> np.ndarray:
    """Triangles whose box is not outside the frustum (errs visible)."""
    from ..geometry.planes import classify_boxes

    r, c = np.divmod(triangles, heightmap.size)
    y = heightmap.heights.ravel()[triangles]
    s = heightmap.spacing
    boxes = np.stack([np.stack([c.min(1) * s, y.min(1), r.min(1) * s], -1),
                      np.stack([c.max(1) * s, y.max(1), r.max(1) * s], -1)], axis=1)
    return triangles[~classify_boxes(boxes, camera.frustum_planes())[0]]


class PeerMethod:
    """A peer as a measurable method (study.terrain.measure): its knob is max_error in world
    units (set it with .max_error); tau is ignored. Compared with the grid's full mesh."""

    alternating = False

    def __init__(self, heightmap, name: str, max_error: float = 1.0):
        reason = missing(name)
        if reason:
            raise RuntimeError(reason)
        self.heightmap = heightmap
        self.name = name
        self.max_error = float(max_error)
        self._cache = {}
        self._meshes = {}

    def mesh(self, max_error: float | None = None) -> np.ndarray:
        e = self.max_error if max_error is None else float(max_error)
        if e not in self._meshes:
            if len(self._meshes) > 32:
                self._meshes.clear()
            self._meshes[e] = peer_mesh(self.heightmap, self.name, e, self._cache)
        return self._meshes[e]

    def reference(self, renderer, camera):
        from ..terrain.mesh import grid_triangles

        n = self.heightmap.size
        full = in_frustum(self.heightmap, grid_triangles(n - 1).astype(np.int64), camera)
        renderer.draw_samples(full, camera)
        return len(full)

    def frame(self, camera, resolution, tau) -> tuple:
        cpu = time.thread_time()
        start = time.perf_counter()
        triangles = in_frustum(self.heightmap, self.mesh(), camera)
        wall = (time.perf_counter() - start) * 1000.0
        self.cpu_ms = (time.thread_time() - cpu) * 1000.0
        return triangles, wall, len(triangles)

    def draw(self, renderer, triangles, camera):
        return renderer.draw_samples(triangles, camera)

    def heights(self, triangles) -> np.ndarray:
        from ..terrain.raster import triangle_heights

        return triangle_heights(self.heightmap.heights.astype(np.float64), triangles)

    def error_for_triangles(self, cameras, target: float, steps: int = 14) -> float:
        """max_error whose frustum-culled mesh has about `target` triangles (median over the
        cameras): bisection on log E between 1e-4 and the map's relief."""
        low, high = 1e-4, float(np.ptp(self.heightmap.heights)) + 1e-3

        def count(e):
            mesh = self.mesh(e)
            return float(np.median([len(in_frustum(self.heightmap, mesh, c)) for c in cameras]))

        for _ in range(steps):
            mid = float(np.sqrt(low * high))
            if count(mid) > target:
                low = mid
            else:
                high = mid
        return high


def compare(methods, heightmap, cameras, taus, profile, peers=PEERS) -> list:
    """Rows of triangles, largest errors and PSNR for each method at each tau, and for each
    installed peer at equal triangles and at equal (world) error to each of those.

    Row keys: method, tau, match ("" for the engine's methods, "triangles" or "error" for a
    peer), max_error (world units: the peer's E, or the method's largest gap), triangles
    (median over the cameras), sample_error_px (largest exact screen gap), psnr_min,
    psnr_median, differing_median.
    """
    from .terrain import measure

    def summary(rows, name, tau, match, max_error=None):
        if max_error is None:
            max_error = float(max(r["vertical_error_max"] for r in rows))
        return {"method": name, "tau": tau, "match": match, "max_error": max_error,
                "triangles": float(np.median([r["triangles"] for r in rows])),
                "sample_error_px": float(max(r["vertex_error_max"] for r in rows)),
                "psnr_min": float(min(r["psnr"] for r in rows)),
                "psnr_median": float(np.median([r["psnr"] for r in rows])),
                "differing_median": float(np.median([r["differing"] for r in rows]))}

    runnable = [PeerMethod(heightmap, name) for name in peers if missing(name) is None]
    out = []
    for method in methods:
        rows = measure([method], heightmap, cameras, taus, profile, exact_vertices=True)
        for tau in taus:
            own = summary([r for r in rows if r["tau"] == tau], method.name, tau, "")
            out.append(own)
            for peer in runnable:
                for match, e in (("triangles", peer.error_for_triangles(cameras,
                                                                        own["triangles"])),
                                 ("error", own["max_error"])):
                    peer.max_error = max(e, 1e-6)
                    peer_rows = measure([peer], heightmap, cameras, [tau], profile,
                                        exact_vertices=True)
                    out.append(summary(peer_rows, f"{peer.name} vs {method.name}", tau, match,
                                       peer.max_error))
    return out

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


def pixel_height_errors(depth, camera, heightmap, resolution) -> np.ndarray:
    """(M,) float64 pixel gaps at every pixel covered by terrain in a depth image (H, W)."""
    from ..render.terrain import unproject

    points = unproject(depth, camera)
    covered = np.isfinite(points[..., 0])
    p = points[covered]
    inside = (p[:, 0] >= 0) & (p[:, 0] <= heightmap.extent) & (p[:, 2] >= 0) & \
        (p[:, 2] <= heightmap.extent)
    p = p[inside]
    gap = vertical_gap_pixels(p[:, 0], p[:, 1], heightmap.height_at(p[:, 0], p[:, 2]), p[:, 2],
                              camera, resolution)
    return gap[np.isfinite(gap)]


def image_error(reference, image) -> dict:
    """psnr (dB, inf when equal) and differing (fraction of pixels) of two (H, W, 3) uint8."""
    diff = reference.astype(np.float64) - image.astype(np.float64)
    mse = float((diff ** 2).mean())
    psnr = float("inf") if mse == 0 else 10.0 * np.log10(255.0 ** 2 / mse)
    return {"psnr": psnr, "differing": float((diff != 0).any(axis=-1).mean())}


def measure_tiles(pyramid, cameras, taus, profile, exact_vertices: bool = False) -> list:
    """One row per (camera, tau): the tile quadtree against the full render.

    Row keys: frame, tau, triangles, full_triangles, tiles, lod_ms, render_ms, psnr, differing,
    pixel_height_max, pixel_height_p99 (and vertex_error_max when exact_vertices).
    """
    from ..render.terrain import TerrainRenderer
    from ..terrain.tiles import full_selection, select_tiles, selection_heights, selection_mesh

    heightmap = pyramid.heightmap
    renderer = TerrainRenderer(heightmap, profile)
    resolution = profile.resolution
    rows = []
    for frame, camera in enumerate(cameras):
        full = full_selection(pyramid, camera)
        renderer.draw(*selection_mesh(pyramid, full), camera)
        reference = renderer.read_rgb()
        for tau in taus:
            start = time.perf_counter()
            selection = select_tiles(pyramid, camera, resolution, tau)
            lod_ms = (time.perf_counter() - start) * 1000.0
            stats = renderer.draw(*selection_mesh(pyramid, selection), camera)
            image = renderer.read_rgb()
            gaps = pixel_height_errors(renderer.read_depth(), camera, heightmap, resolution)
            row = {"frame": frame, "tau": tau, "triangles": selection.triangles,
                   "full_triangles": full.triangles, "tiles": len(selection.level),
                   "lod_ms": lod_ms, "render_ms": stats.render_ms,
                   **image_error(reference, image),
                   "pixel_height_max": float(gaps.max()) if len(gaps) else 0.0,
                   "pixel_height_p99": float(np.percentile(gaps, 99)) if len(gaps) else 0.0}
            if exact_vertices:
                errors = vertex_errors(heightmap, selection_heights(pyramid, selection),
                                       camera, resolution)
                row["vertex_error_max"] = float(errors.max()) if len(errors) else 0.0
            rows.append(row)
    return rows

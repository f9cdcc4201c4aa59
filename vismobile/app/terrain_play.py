"""`vismobile play t.vmt`: a terrain world played with its LOD method and tau (terrain_scene.py).

frames.csv columns (one row per played frame):
- lod_ms: the method's selection; cull_ms: the objects' Culler; render_ms: ground and objects
  drawn (uploads included) and glFinish; frame_ms = lod_ms + cull_ms + render_ms;
- ground_triangles, object_triangles, triangles_sent (their sum);
- error_px: the method's error bound over the drawn pieces (pixels; tau bounds it);
  error_world: the drawn pieces' largest nested vertical error (world units), which the
  horizon sinks the ground by;
- horizon_nodes, horizon_triangles: object-partition nodes, then object triangles of the
  kept nodes, that the horizon stage hid;
- page_misses, page_prefetched, page_bytes: for a .vmtiles terrain paged in by tiles, the
  tiles read at once this frame, those the loader thread read ahead since the last frame, and
  the bytes held (records plus statistics; 0 for a .vmt);
- sample_error_px: with --measure-error, the exact largest screen error over the samples in
  the frustum (untimed, O(N^2)), the measured counterpart of error_px; nan without; waypoint.
summary.json: the run's settings and mean / median / p95 of each column. Numba's first-use
compile is in no figure: the first played camera is run once, untimed, and the method's
frame-to-frame state reset before the measured frames.
"""
from __future__ import annotations

import io
import json
import time
from pathlib import Path

import numpy as np

from ..files.atomic import atomic_write_bytes, staged_directory
from ..stats import summarize

COLUMNS = ("frame", "lod_ms", "cull_ms", "render_ms", "frame_ms", "ground_triangles",
           "object_triangles", "triangles_sent", "error_px", "error_world", "horizon_nodes",
           "horizon_triangles", "page_misses", "page_prefetched", "page_bytes", "sample_error_px", "waypoint")
NUMERIC = COLUMNS[1:-1]


def _paging(scene) -> tuple:
    """(misses, prefetched, bytes held) of a paged terrain's last frame, zeros otherwise."""
    paged = getattr(scene.lod, "paged", None)
    if paged is None:
        return (0, 0, 0)
    return (paged.misses, paged.prefetched, paged.memory_bytes())


def terrain_camera_options(heightmap) -> dict:
    """Trajectory camera settings for a terrain: 60 degrees across a 240x320 screen, far 1.5
    widths, near as terrain/paths.py's cameras."""
    far = 1.5 * heightmap.extent
    fov = float(np.degrees(2 * np.arctan(np.tan(np.radians(30.0)) / (240 / 320))))
    return {"fov": fov, "near": max(0.05 * heightmap.spacing, far * 1e-5), "far": far}


def play_terrain(scene, cameras, labels=None, out=None, frames_every=0, progress=False,
                 played=None, measure=False) -> dict:
    """Play cameras (a list) through a TerrainScene; write OUT/frames.csv, summary.json and
    every frames_every-th frame as a PNG (staged, summary.json last). Returns the summary."""
    from ..progress import Progress
    from ..render.images import png_bytes

    played = list(range(len(cameras))) if played is None else list(played)
    labels = labels or {}
    count = len(cameras)
    warm = time.perf_counter()
    if count:
        scene.frame(cameras[0])  # numba's first-use compiles, first uploads
        scene.lod.reset()
    warmup_ms = (time.perf_counter() - warm) * 1000.0
    table = {name: np.zeros(count) for name in NUMERIC}
    saved = {}
    bar = Progress(f"play {Path(scene.path).name}", enabled=None if progress else False)
    for index, camera in enumerate(cameras):
        f = scene.frame(camera)
        row = (f.lod_ms, f.cull_ms, f.render_ms, f.lod_ms + f.cull_ms + f.render_ms,
               f.ground_triangles, f.object_triangles, f.triangles, f.error_px, f.error_world,
               f.nodes_hidden, f.triangles_hidden) + _paging(scene) + \
            ((scene.sample_error_px(camera) if measure else np.nan),)
        for name, value in zip(NUMERIC, row):
            table[name][index] = value
        if out is not None and frames_every and index % frames_every == 0:
            saved[played[index]] = png_bytes(scene.read_rgb(), optimize=False)
        bar(index + 1, count)
    bar.close()
    summary = {"frames": count, "world": Path(scene.path).stem, "method": scene.method,
               "tau": scene.tau, "structure": scene.structure, "stages": list(scene.stages),
               "profile": scene.profile.name, "resolution": list(scene.profile.resolution),
               "terrain_samples": scene.heightmap.size, "objects": len(scene.placement),
               "warmup_ms": warmup_ms}
    for name in NUMERIC:
        summary[name] = summarize(table[name]) if count else None
    summary["error_px_max"] = float(table["error_px"].max()) if count else None
    summary["sample_error_px_max"] = float(table["sample_error_px"].max()) \
        if count and measure else None
    if out is not None:
        text = io.StringIO()
        text.write(",".join(COLUMNS) + "\n")
        for i in range(count):
            text.write(f"{played[i]},{table['lod_ms'][i]:.4f},{table['cull_ms'][i]:.4f},"
                       f"{table['render_ms'][i]:.4f},{table['frame_ms'][i]:.4f},"
                       f"{int(table['ground_triangles'][i])},{int(table['object_triangles'][i])},"
                       f"{int(table['triangles_sent'][i])},{table['error_px'][i]:.4f},"
                       f"{table['error_world'][i]:.6g},{int(table['horizon_nodes'][i])},"
                       f"{int(table['horizon_triangles'][i])},"
                       f"{int(table['page_misses'][i])},{int(table['page_prefetched'][i])},"
                       f"{int(table['page_bytes'][i])},{table['sample_error_px'][i]:.4f},"
                       f"{labels.get(played[i], '')}\n")
        with staged_directory(out, marker="summary.json") as stage:
            for frame, data in saved.items():
                atomic_write_bytes(stage / "frames" / f"frame_{frame:05d}.png", data)
            atomic_write_bytes(stage / "frames.csv", text.getvalue().encode("ascii"))
            atomic_write_bytes(stage / "summary.json",
                               (json.dumps(summary, indent=2, sort_keys=True) + "\n").encode())
    return summary

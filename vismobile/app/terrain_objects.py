"""The terrain sweep's objects (`compare --terrain` on a .vmt with placed objects).

Per (method, path, tau) the objects standing on the terrain go through the engine as `play`
runs them (app/terrain_scene.py): culled by `stages` over their partition (the horizon casts
over the drawn LOD ground, sunk by the frame's pixel error), drawn at their coarsest level of
detail within the same tau (lod/; chains built once per objects world and kept in cache_dir).
Each frame is also checked against the item buffer of its drawn LOD ground plus every object
at full detail: a visible object triangle the culling dropped is counted (0 when
conservative). Figures are medians over the path's frames, dropped is the sum.
"""
from __future__ import annotations

import numpy as np

OBJECT_KEYS = ("object_triangles", "object_triangles_full", "object_triangles_hidden",
               "cull_ms", "frame_ms", "objects_dropped")


def object_figures(path, names, paths, taus, profile, frames: str, stages=("vfc", "horizon"),
                   structure: str = "octree:4", cache_dir=None, progress=None) -> dict:
    """{(method, "kind speed", tau): {OBJECT_KEYS}} for the .vmt at path (module doc).

    object_triangles      : sent to the renderer, at their level of detail (median)
    object_triangles_full : the same objects' triangles at full detail (median)
    object_triangles_hidden : removed by the horizon's triangle test (median)
    cull_ms, frame_ms     : the objects' culling; LOD + cull + render of the frame (medians)
    objects_dropped       : visible object triangles dropped, summed over the frames
    """
    from ..render.terrain import TerrainRenderer
    from ..study.terrain import path_frames
    from .terrain_scene import TerrainScene

    out = {}
    for name in (n for n in names if n in ("tiles", "roettger", "roam")):  # no roam/BUDGET
        scene = TerrainScene(path, name, taus[0], stages, structure, profile.name,
                             object_lod=True, cache_dir=cache_dir)
        renderer = TerrainRenderer(scene.heightmap, scene.profile)
        for kind, speed in paths:
            if progress:
                progress(f"{name}'s objects on the {speed} {kind}")
            cameras = path_frames(scene.heightmap, kind, speed, frames)
            for tau in taus:
                scene.tau = float(tau)
                scene.lod.reset()
                scene.frame(cameras[0])  # numba's first use and first uploads: untimed
                scene.lod.reset()
                rows = []
                for camera in cameras:
                    f = scene.frame(camera)
                    rows.append((f.object_triangles, len(scene.culled.triangles),
                                 f.triangles_hidden, f.cull_ms,
                                 f.lod_ms + f.cull_ms + f.render_ms,
                                 scene.visible_dropped(camera, renderer)))
                rows = np.array(rows, dtype=np.float64)
                figures = dict(zip(OBJECT_KEYS[:5], np.median(rows[:, :5], axis=0).tolist()))
                figures["objects_dropped"] = int(rows[:, 5].sum())
                out[(name, f"{kind} {speed}", float(tau))] = figures
    return out

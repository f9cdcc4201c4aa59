"""`vismobile tune t.vmt`: pick a terrain's LOD method and tau (and show the objects' culling).

Each candidate (method, tau) with tau <= the largest error allowed plays the same probe frames
(TerrainScene.frame, after one untimed warm-up frame) and is priced per frame:
- device cost (a profile with a device model): the model's render and cull ms of the frame's
  counters (ground plus object triangles sent, draw calls: one per tile, per chunk, or per
  65,535-vertex batch, plus the objects' nodes drawn; the objects' Culler counters) plus the
  LOD's selection wall time measured on this machine (the device model prices no terrain LOD:
  it is 1-3 ms here against hundreds of modelled ms of triangles);
- measured cost: this machine's frame time (LOD + cull + render), median over the probes.
The choice is the cheapest median; its error bound (the method's own, in pixels) stays within
the allowed error on every probe frame by construction, and is reported.
"""
from __future__ import annotations

import numpy as np

from ..errors import VisMobileError
from .terrain_scene import METHODS, TerrainScene

TAUS = (0.5, 1.0, 2.0, 4.0)


def tune_terrain(path, cameras, profile="ipaq-hx2490b", methods=METHODS, taus=TAUS,
                 max_error_px: float = 1.0, stages=("vfc", "horizon"), structure="octree:4",
                 cost="device", progress=None, object_lod: bool = False,
                 cache_dir=None) -> dict:
    """{"rows": one dict per candidate, "choice": the cheapest row, "cost": its kind}.

    object_lod: each candidate draws the objects at their coarsest level of detail within its
    own tau (TerrainScene's object_lod; chains built once and kept in cache_dir), so the
    objects' triangles are priced at the LOD the candidate would play them with."""
    from ..device.costmodel import DEVICES, device_model

    candidates = [float(t) for t in taus if float(t) <= max_error_px]
    if not candidates:
        raise VisMobileError(f"--max-error-px {max_error_px:g}: no tau of "
                             f"{', '.join(f'{t:g}' for t in taus)} is within it")
    rows, scene = [], None
    for method in methods:
        for tau in candidates:
            if scene is None:
                scene = TerrainScene(path, method, tau, stages, structure, profile,
                                     object_lod=object_lod, cache_dir=cache_dir)
            else:
                scene.set_method(method)
                scene.tau = tau
            model = device_model(scene.profile.name) if cost == "device" and \
                scene.profile.name in DEVICES else None
            scene.frame(cameras[0])  # numba's first-use compile and first uploads: untimed
            scene.lod.reset()
            costs, figures = [], []
            for camera in cameras:
                f = scene.frame(camera)
                counters = {k: v for k, v in f.stats.items()
                            if isinstance(v, (int, float)) and not isinstance(v, bool)}
                counters["triangles_sent"] = f.triangles
                counters["nodes_drawn"] = counters.get("nodes_drawn", 0) + f.ground_calls
                costs.append(model.frame_ms(counters) + max(f.lod_ms, 0.0) if model else
                             f.lod_ms + f.cull_ms + f.render_ms)
                figures.append((f.ground_triangles, f.object_triangles, f.error_px))
            figures = np.array(figures)
            rows.append({"method": method, "tau": tau, "frames": len(cameras),
                         "cost_ms": float(np.median(costs)),
                         "ground_triangles": float(np.median(figures[:, 0])),
                         "object_triangles": float(np.median(figures[:, 1])),
                         "error_px_max": float(figures[:, 2].max())})
            if progress:
                progress(f"{method} at {tau:g} px: {rows[-1]['cost_ms']:.1f} ms")
    choice = min(rows, key=lambda r: r["cost_ms"])
    kind = "device model" if cost == "device" and scene.profile.name in DEVICES else "measured"
    return {"rows": rows, "choice": choice, "cost": kind, "profile": scene.profile.name,
            "max_error_px": max_error_px, "stages": list(stages), "structure": structure,
            "object_lod": scene.object_lod is not None}


def report(result) -> str:
    """The candidates' table and the choice, as text lines."""
    lines = [f"terrain tune ({result['profile']}, cost: {result['cost']} frame ms, median; "
             f"error within {result['max_error_px']:g} px)",
             f"{'method':>9} {'tau':>5} {'cost ms':>9} {'ground':>9} {'objects':>8} "
             f"{'bound px':>8}"]
    for r in result["rows"]:
        lines.append(f"{r['method']:>9} {r['tau']:>5g} {r['cost_ms']:>9.2f} "
                     f"{r['ground_triangles']:>9,.0f} {r['object_triangles']:>8,.0f} "
                     f"{r['error_px_max']:>8.3f}")
    c = result["choice"]
    detail = "at their LOD within tau" if result.get("object_lod") else "at full detail"
    lines.append(f"choice: --terrain-method {c['method']} --lod {c['tau']:g} "
                 f"(objects {detail}: {'+'.join(result['stages'])} over {result['structure']}): "
                 f"{c['cost_ms']:.2f} ms a frame")
    return "\n".join(lines)

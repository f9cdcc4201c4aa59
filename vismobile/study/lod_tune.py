"""tune --max-error-px: the level-of-detail tolerance for the chosen configuration.

tau bounds the projected geometric error of every object in pixels (lod/select.py), so any
tau up to the budget keeps that promise; a larger tau sends fewer triangles. Over the probe
frames this plays the chosen structure and culling with each tau of TAUS up to the budget
(and the budget itself): triangles sent, the frame time (the profile's device model, or this
machine's wall time for a profile without one), and the image error against the full-detail
frames of the same culling; it picks the fastest.
"""
from __future__ import annotations

import time

import numpy as np

from ..device.costmodel import DEVICES, device_counters, device_model
from . import engine

TAUS = (0.25, 0.5, 1.0, 2.0, 4.0, 8.0)


def taus_under(budget: float) -> list:
    """Tolerances tried under a budget of `budget` pixels: TAUS up to it, and the budget."""
    return sorted({t for t in TAUS if t <= budget} | {float(budget)})


def pick_tau(world, trajectory, profile, structure, cull, frames, budget, cache_dir=None) -> dict:
    """{"max_error_px", "tau" (the pick), "rows": [{tau, triangles, frame_ms, psnr_db_min,
    psnr_db_mean, ...}], "full": the same figures without LOD, "cost"}."""
    from ..lod.image_error import error_summary
    from ..render.lod_view import LodView

    partition, _ = engine.load_structure(world, structure, cache_dir)
    chains = engine.load_chains(world, cache_dir)
    stages = [] if cull == "none" else cull.split("+")
    culler = engine.make_culler(partition, stages, profile)
    model = device_model(profile.name) if profile.name in DEVICES else None
    cameras = [trajectory.camera(f, profile.aspect) for f in frames]
    culled = [culler.cull(camera) for camera in cameras]
    views = {tau: LodView(world, chains, profile, tau) for tau in taus_under(budget)}
    rows = []
    full = None
    for tau, view in [(None, None)] + list(views.items()):
        sent, ms, psnr, diff, changed = [], [], [], [], []
        for camera, result in zip(cameras, culled):
            back = bool(result.cull_back)
            if view is None:
                start = time.perf_counter()
                drawn = engine.renderer(world, profile).draw(result.triangles, camera, back)
                wall = (time.perf_counter() - start) * 1000.0
            else:
                frame = view.draw(result.triangles, camera, back)
                drawn, wall = frame.drawn, frame.drawn.render_ms + frame.lod_ms
                psnr.append(frame.error["psnr_db"])
                diff.append(frame.error["max_diff"])
                changed.append(frame.error["changed"])
            stats = device_counters(result, culler.tree)
            stats["triangles_sent"] = drawn.triangles
            sent.append(drawn.triangles)
            ms.append(model.frame_ms(stats, back) if model else wall)
        row = {"triangles": float(np.mean(sent)), "frame_ms": float(np.mean(ms))}
        if view is None:
            full = row
            continue
        row.update(error_summary(psnr, diff, changed, tau))
        row["tau"] = tau
        rows.append(row)
    pick = min(rows, key=lambda r: (r["frame_ms"], -r["tau"]))
    return {"max_error_px": float(budget), "tau": pick["tau"], "rows": rows, "full": full,
            "cost": "device" if model else "measured", "structure": structure, "cull": cull}


def report_lines(lod: dict) -> list:
    """Text lines of pick_tau's result for tune's printout."""
    full = lod["full"]
    lines = [f"level of detail under {lod['max_error_px']:g} px of error "
             f"({lod['structure']}, {lod['cull']}; {lod['cost']} ms): tau {lod['tau']:g} px"]
    lines.append(f"  full detail: {full['triangles']:,.0f} triangles, "
                 f"{full['frame_ms']:.2f} ms/frame")
    for row in lod["rows"]:
        low = row["psnr_db_min"]
        lines.append(f"  tau {row['tau']:>5g} px: {row['triangles']:,.0f} triangles, "
                     f"{row['frame_ms']:.2f} ms/frame, PSNR "
                     + ("identical" if low is None else f"min {low:.1f} dB") +
                     (" <- pick" if row["tau"] == lod["tau"] else ""))
    return lines

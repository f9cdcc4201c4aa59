"""One self-contained HTML report of a comparison: tables and base64-embedded matplotlib PNGs.

Per world: ms per frame along the trajectory (waypoints marked) per culling combination, per
octree depth and per structure; fps along the path; triangles sent; time-against-triangles
correlation; our numbers beside the thesis's (SPEC §6); a run-time-against-error scatter with
its Pareto front. Also the raster-against-ray-cast agreement and tune's choices, when given.
"""
from __future__ import annotations

import base64
import html
import io
import math
from pathlib import Path

import numpy as np

from ..costmodel import DEVICES, label
from ..world import atomic_write_bytes
from . import thesis
from .matrix import THESIS_CULLS
from .metrics import pareto_front

STYLE = """body{font-family:sans-serif;max-width:1100px;margin:2em auto;color:#222}
table{border-collapse:collapse;margin:1em 0;font-size:90%}td,th{border:1px solid #bbb;
padding:3px 7px;text-align:right}th{background:#eee}td.l,th.l{text-align:left}
img{max-width:100%}pre{background:#f6f6f6;padding:8px;overflow-x:auto;font-size:85%}
.note{color:#555;font-size:90%}"""


def _png(fig) -> str:
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=90, bbox_inches="tight")
    import matplotlib.pyplot as plt

    plt.close(fig)
    return ("<img alt='figure' src='data:image/png;base64,"
            + base64.b64encode(buffer.getvalue()).decode("ascii") + "'>")


def _fmt(value, digits=1) -> str:
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return "–"
    if isinstance(value, float):
        return f"{value:,.{digits}f}"
    return html.escape(str(value))


def _table(header, rows, left=1) -> str:
    head = "".join(f"<th class='{'l' if i < left else ''}'>{html.escape(h)}</th>"
                   for i, h in enumerate(header))
    body = "".join("<tr>" + "".join(f"<td class='{'l' if i < left else ''}'>{cell}</td>"
                                    for i, cell in enumerate(row)) + "</tr>" for row in rows)
    return f"<table><tr>{head}</tr>{body}</table>"


def ok_records(records) -> list:
    """The records that have a summary (failed runs left out)."""
    return [r for r in records if "summary" in r]


def run_ms(record, device=None) -> float:
    """Mean ms per frame of a run: measured here (device None) or that device's model."""
    summary = record["summary"]
    if device is None:
        return summary["mean_ms"]
    return summary["model"][device]["frame_ms"]["mean"]


def device_pool(records, world, device=None) -> list:
    """The successful runs of a world to judge on a device: those run with that device's
    profile when there are any (same screen and arithmetic), else every run of the world."""
    runs = [r for r in ok_records(records) if r["spec"]["world"] == world]
    own = [r for r in runs if r["spec"]["profile"] == device]
    return own or runs


def best_run(records, world, profile=None, conservative=True, device=None):
    """The record with the lowest mean frame time for a world (zero false negatives if asked):
    measured here, or by a device's model when device is given."""
    pool = [r for r in ok_records(records) if r["spec"]["world"] == world
            and (profile is None or r["spec"]["profile"] == profile)
            and (r["summary"]["conservative"] or not conservative)]
    return min(pool, key=lambda r: run_ms(r, device)) if pool else None


def find_run(records, world, structure, cull, profile=None):
    """The successful record of this exact configuration (any profile when None), or None."""
    for r in ok_records(records):
        s = r["spec"]
        if (s["world"], s["structure"], s["cull"]) == (world, structure, cull) and \
                (profile is None or s["profile"] == profile):
            return r
    return None


def _along(ax, runs, labels, column, waypoints, ylabel):
    for run, label in zip(runs, labels):
        frames = run["frames"]
        if column == "fps":
            y = 1000.0 / np.maximum(np.asarray(frames["frame_ms"], float), 1e-9)
        else:
            y = np.asarray(frames[column], float)
        ax.plot(frames["frame"], y, lw=0.9, marker="." if len(y) < 200 else None,
                ms=3, label=label)
    for label, frame in waypoints.items():
        ax.axvline(frame, color="#999", lw=0.7, ls="--")
        ax.text(frame, 1.0, label, transform=ax.get_xaxis_transform(), ha="center",
                va="bottom", fontsize=8)
    ax.set_xlabel("frame")
    ax.set_ylabel(ylabel)
    ax.legend(fontsize=7, ncol=2)


def world_section(records, world, profile) -> str:
    """HTML for one world: tables and figures."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import matplotlib.ticker

    runs = [r for r in ok_records(records) if r["spec"]["world"] == world
            and r["spec"]["profile"] == profile]
    if not runs:
        return ""
    ref = thesis.IPAQ_BEST[world] if world in thesis.IPAQ_BEST else None
    best = best_run(runs, world)
    parts = [f"<h2>{world.upper()} ({profile})</h2>"]
    waypoints = runs[0]["summary"]["waypoints"]
    # Fix a structure for the culling figure and a culling for the structure figures.
    structures = sorted({r["spec"]["structure"] for r in runs})
    culls = sorted({r["spec"]["cull"] for r in runs})
    fixed_structure = ref["structure"] if ref and ref["structure"] in structures else \
        (best or runs[0])["spec"]["structure"]
    fixed_cull = ref["cull"] if ref and ref["cull"] in culls else (best or runs[0])["spec"]["cull"]
    by_cull = [r for r in runs if r["spec"]["structure"] == fixed_structure]
    by_cull.sort(key=lambda r: (r["spec"]["cull"] not in THESIS_CULLS, r["spec"]["cull"]))
    by_structure = sorted((r for r in runs if r["spec"]["cull"] == fixed_cull),
                          key=lambda r: r["spec"]["structure"])
    by_depth = [r for r in by_structure if r["spec"]["structure"].startswith("octree")]

    figures = []
    if by_cull:
        fig, axes = plt.subplots(2, 1, figsize=(10, 7), sharex=True)
        _along(axes[0], by_cull, [r["spec"]["cull"] for r in by_cull], "frame_ms", waypoints,
               "ms per frame")
        axes[0].set_title(f"per culling combination, structure {fixed_structure}")
        _along(axes[1], by_cull, [r["spec"]["cull"] for r in by_cull], "triangles_sent",
               waypoints, "triangles sent")
        figures.append(_png(fig))
    if len(by_depth) > 1:
        fig, ax = plt.subplots(figsize=(10, 3.5))
        _along(ax, by_depth, [r["spec"]["structure"] for r in by_depth], "frame_ms", waypoints,
               "ms per frame")
        ax.set_title(f"per octree depth, culling {fixed_cull}")
        figures.append(_png(fig))
    if len(by_structure) > 1:
        fig, ax = plt.subplots(figsize=(10, 3.5))
        _along(ax, by_structure, [r["spec"]["structure"] for r in by_structure], "frame_ms",
               waypoints, "ms per frame")
        ax.set_title(f"per structure, culling {fixed_cull}")
        figures.append(_png(fig))
    if best:
        shown = [best]
        thesis_run = find_run(runs, world, ref["structure"], ref["cull"], profile) if ref else None
        if thesis_run is not None and thesis_run is not best:
            shown.append(thesis_run)
        fig, axes = plt.subplots(1, 2, figsize=(10, 3.5), gridspec_kw={"width_ratios": [2, 1]})
        _along(axes[0], shown, [f"{r['spec']['structure']} {r['spec']['cull']}" for r in shown],
               "fps", waypoints, "frames per second")
        axes[0].set_title("fps along the path")
        for r in shown:
            axes[1].scatter(r["frames"]["triangles_sent"], r["frames"]["frame_ms"], s=6,
                            label=f"r = {_fmt(r['summary']['correlation'], 2)}")
        axes[1].set_xlabel("triangles sent")
        axes[1].set_ylabel("ms per frame")
        axes[1].legend(fontsize=7)
        axes[1].set_title("time against triangles")
        figures.append(_png(fig))
    # Run time against error, Pareto fronts: missed pixels (aggressive error) and sent/visible
    # (the over-estimate every conservative method pays).
    cost = np.array([r["summary"]["mean_ms"] for r in runs])
    safe = np.array([r["summary"]["conservative"] for r in runs])
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.5))
    for ax, key, label in ((axes[0], "fn_pixels_mean", "mean false-negative pixels per frame"),
                           (axes[1], "tightness", "triangles sent / visible (means)")):
        error = np.array([r["summary"]["fn_pixels_mean"] if key == "fn_pixels_mean" else
                          r["summary"]["triangles_sent"]["mean"]
                          / max(r["summary"]["visible_mean"], 1.0) for r in runs])
        front = pareto_front(cost, error)
        ax.scatter(cost[safe], error[safe], s=16, c="tab:green", label="zero false negatives")
        ax.scatter(cost[~safe], error[~safe], s=22, c="tab:red", marker="x",
                   label="misses visible triangles")
        order = np.argsort(cost[front])
        ax.step(cost[front][order], error[front][order], where="post", c="k", lw=1,
                label="Pareto front")
        for r, c, e, f in zip(runs, cost, error, front):
            if f:
                ax.annotate(f"{r['spec']['structure']} {r['spec']['cull']}", (c, e), fontsize=6,
                            rotation=15, xytext=(3, 3), textcoords="offset points")
        if key == "fn_pixels_mean":
            ax.set_yscale("symlog", linthresh=1.0)
            ax.set_ylim(-0.5, max(10.0, float(error.max()) * 2))
        else:
            ax.set_yscale("log")
        ax.set_xscale("log")
        ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
        ax.xaxis.set_major_formatter(matplotlib.ticker.ScalarFormatter())
        ax.set_xlabel("mean ms per frame (this machine, log)")
        ax.set_ylabel(label)
        ax.legend(fontsize=7)
    axes[0].set_title(f"run time against missed pixels, {len(runs)} configurations")
    axes[1].set_title("run time against over-estimation")
    figures.append(_png(fig))
    parts += figures
    # Table of every run of this world.
    rows = []
    for r in sorted(runs, key=lambda r: r["summary"]["mean_ms"]):
        s = r["summary"]
        rows.append([html.escape(r["spec"]["structure"]), html.escape(r["spec"]["cull"]),
                     _fmt(s["mean_ms"], 2), _fmt(s["cull_ms"]["mean"], 3),
                     _fmt(s["render_ms"]["mean"], 2), _fmt(s["mean_fps"], 1),
                     _fmt(s["triangles_sent"]["mean"], 0),
                     _fmt(s["triangles_sent"]["mean"] / max(s["visible_mean"], 1.0), 2),
                     _fmt(s["correlation"], 2), str(s["false_negatives_total"]),
                     _fmt(s["fn_pixels_mean"], 2)])
    parts.append("<details><summary>every run of this world</summary>" + _table(
        ["structure", "culling", "ms/frame", "cull ms", "render ms", "fps", "triangles",
         "sent/visible", "r(ms,tris)", "false neg.", "FN pixels/frame"], rows, left=2)
        + "</details>")
    return "\n".join(parts)


def _config(record) -> str:
    return f"{html.escape(record['spec']['structure'])} {html.escape(record['spec']['cull'])}"


def summary_table(records) -> str:
    """Per world and device: our best configuration by that device's model beside the
    thesis's best as measured on that device, and the model at the thesis's configuration;
    then our best measured here. Every time says how it was obtained."""
    worlds = sorted({r["spec"]["world"] for r in ok_records(records)})
    rows = []
    for world in worlds:
        for device in DEVICES + (None,):
            pool = device_pool(records, world, device)
            best = best_run(pool, world, device=device)
            if best is None:
                continue
            ref = thesis.device_best(world, device) if device else None
            at_ref = find_run(pool, world, ref["structure"], ref["cull"]) if ref else None
            ms = run_ms(best, device)
            ref_cells = ["–", "–", "–", "–"]
            if ref:
                model_there = run_ms(at_ref, device) if at_ref else None
                ref_cells = [
                    f"{html.escape(ref['structure'])} {html.escape(ref['cull'])}"
                    + (" *" if ref["note"] else ""),
                    _fmt(ref["mean_ms"], 1), _fmt(model_there, 1),
                    _fmt(model_there / ref["mean_ms"] - 1.0, 2) if model_there else "–"]
            rows.append([world.upper(), html.escape(label(device)), _config(best),
                         _fmt(ms, 1 if device else 2), _fmt(1000.0 / ms, 1),
                         _fmt(best["summary"]["triangles_sent"]["mean"], 0)] + ref_cells)
    text = _table(["world", "time from", "our best (zero false negatives)", "ms/frame", "fps",
                   "triangles sent", "thesis best on this device", "thesis ms (measured)",
                   "model ms at the thesis's config", "model error there"], rows, left=3)
    return text + ("<p class='note'>Device rows use that device's cost model "
                   "(vismobile/costmodel.py: render figures fitted to the thesis's own device "
                   "timings, cull priced from counters); \"measured here\" rows are wall time on "
                   "this machine (Mesa llvmpipe), not comparable with the devices. Thesis "
                   "figures are the thesis's measurements on the device named. * The thesis "
                   "gives only the N82's fps: its configuration is assumed to be the iPaq's "
                   "best and its ms is 1000 / fps. Model error there = model ms / thesis ms - 1."
                   "</p>")


def agreement_section(agreement) -> str:
    if not agreement:
        return ""
    rows = []
    for item in agreement:
        rows.append([html.escape(f"{item['world']} frame {item['frame']}"),
                     "on" if item["cull_back"] else "off", f"{item['pixel_agreement']:.4%}",
                     str(item["pixels"] - item["agree"]), str(item["silhouette"]),
                     str(item["shared_edge"]), str(item["coplanar"]), str(item["depth_tie"]),
                     str(item["other"]), f"{item['raster_ids']} / {item['raycast_ids']}",
                     str(item["missed_by_rays"]), str(item["missed_by_raster"])])
    return ("<h2>Ground truth: raster item buffer against open3d ray casting</h2>"
            "<p class='note'>One ray per pixel centre, same camera; disagreeing pixels by cause "
            "(silhouette: one side hits background; shared edge: the two triangles share a "
            "corner; coplanar: overlapping faces in one plane; depth tie: depths within 1e-4)."
            "</p>" + _table(["view", "back faces culled", "agreement", "differing px",
                             "silhouette", "shared edge", "coplanar", "depth tie", "other",
                             "ids raster / rays", "seen only by raster",
                             "seen only by rays"], rows))


def tune_section(tunes) -> str:
    if not tunes:
        return ""
    parts = ["<h2>Automatic configuration (vismobile tune)</h2>"]
    for item in tunes:
        parts.append(f"<h3>{html.escape(item['world'].upper())}</h3><pre>"
                     f"{html.escape(item['text'])}</pre>")
    return "\n".join(parts)


def write_report(records, path, agreement=None, tunes=None, title="vismobile comparison",
                 notes="") -> Path:
    """Write the HTML report; returns its path. records: runner records (with frames)."""
    profiles = list(dict.fromkeys(r["spec"]["profile"] for r in ok_records(records)))
    worlds = sorted({r["spec"]["world"] for r in ok_records(records)})
    failed = [r for r in records if "error" in r]
    body = [f"<h1>{html.escape(title)}</h1>",
            "<p class='note'>Measured here on a desktop CPU with Mesa llvmpipe (software "
            "OpenGL), not on the thesis's iPaq or N82: times measured here are labelled "
            "\"measured here\"; device times come from each device's cost model and are "
            "labelled with the device. "
            f"{html.escape(notes)}</p>"]
    body.append("<h2>Best configuration per world and device</h2>")
    body.append(summary_table(records))
    body.append(tune_section(tunes))
    body.append(agreement_section(agreement))
    for world in worlds:
        body.append(world_section(records, world, profiles[0]))
    if failed:
        body.append("<h2>Failed runs</h2><pre>" + html.escape("\n".join(
            f"{r['spec']['world']} {r['spec']['structure']} {r['spec']['cull']}: {r['error']}"
            for r in failed)) + "</pre>")
    page = (f"<!DOCTYPE html><html><head><meta charset='utf-8'><title>{html.escape(title)}"
            f"</title><style>{STYLE}</style></head><body>{''.join(body)}</body></html>")
    path = Path(path)
    atomic_write_bytes(path, page.encode("utf-8"))
    return path


def pareto_png(records, world, profile, path) -> None:
    """Write only the Pareto scatter of one world as a PNG (for the README)."""
    section = world_section(records, world, profile)
    images = section.split("data:image/png;base64,")
    if len(images) > 1:
        data = images[-1].split("'")[0]
        atomic_write_bytes(path, base64.b64decode(data))

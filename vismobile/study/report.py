"""One self-contained HTML report of a comparison: tables and inline matplotlib PNGs.

The page answers "what should I use for this world on this device?" first: per world and
device, the recommendation (tune's pick when given, else the best compared run), its predicted
frame time and fps, the thesis's best on that device, and the error. Then, per world: ms per
frame along the path with the waypoints and the thesis's mean as a reference line, triangles
sent, and the run-time-against-error front; the thesis's figures (per culling combination, per
octree depth, per structure) and every run follow, folded. Times are labelled "measured here"
or "<device> model" (vismobile/costmodel.py), thesis figures with the device they were measured
on.
"""
from __future__ import annotations

import base64
import html
import math
from pathlib import Path

import numpy as np

from ..costmodel import DEVICES, device_name, label
from ..world import atomic_write_bytes
from . import thesis
from .matrix import THESIS_CULLS
from .metrics import pareto_front
from .plots import figure_png, legend_outside, log_axis, pyplot, style, waypoints

STYLE = """body{font-family:sans-serif;max-width:1150px;margin:1.5em auto;color:#222}
table{border-collapse:collapse;margin:.6em 0;font-size:90%}td,th{border:1px solid #bbb;
padding:3px 7px;text-align:right;vertical-align:top}th{background:#eee}
td.l,th.l{text-align:left}img{max-width:100%}
pre{background:#f6f6f6;padding:8px;white-space:pre-wrap;overflow-wrap:anywhere;font-size:85%}
.note{color:#555;font-size:90%}tr.here td{color:#555}nav a{margin-right:1em}
h2{margin-top:1.6em;border-bottom:2px solid #ccc}"""


def _fmt(value, digits=1) -> str:
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return "–"
    if isinstance(value, float):
        return f"{value:,.{digits}f}"
    return html.escape(str(value))


def _table(header, rows, left=1, row_class=None) -> str:
    head = "".join(f"<th class='{'l' if i < left else ''}'>{html.escape(h)}</th>"
                   for i, h in enumerate(header))
    body = "".join(
        f"<tr class='{(row_class or [''] * len(rows))[k]}'>"
        + "".join(f"<td class='{'l' if i < left else ''}'>{cell}</td>"
                  for i, cell in enumerate(row)) + "</tr>" for k, row in enumerate(rows))
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


def frame_series(record, device=None) -> np.ndarray:
    """(F,) ms per frame of a run: measured here, or that device's model."""
    frames = record["frames"]
    return np.asarray(frames["frame_ms"] if device is None else frames[f"model_ms:{device}"],
                      float)


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


def world_title(world: str) -> str:
    """"W2" for a thesis world, the file's stem for an OBJ path."""
    return Path(world).stem.upper() if world.endswith(".obj") else world.upper()


def _config(structure, cull) -> str:
    return f"{html.escape(structure)} {html.escape(cull)}"


def _tune_for(tunes, world, device):
    """The tune result dict for a world and device (device None: a measured tune), or None."""
    for item in tunes or ():
        result = item.get("result")
        if not result or result["world"] != world:
            continue
        if device is None and result["cost"] == "measured":
            return result
        if device is not None and result["cost"] == "device" and result["profile"] == device:
            return result
    return None


def recommendation(records, world, device, tunes=None) -> dict | None:
    """What to use for a world on a device (None: this machine): tune's pick when a tune of
    that device is given, else the compared run with the lowest time and zero false negatives.

    Returns {"structure", "cull", "source", "ms", "low", "high", "tied", "run"}: ms predicted
    (the device's model of the compared frames when the configuration was run, else tune's
    prediction), low/high tune's 95% interval (None without tune), tied: configurations tune
    could not tell apart from its pick.
    """
    pool = device_pool(records, world, device)
    tuned = _tune_for(tunes, world, device)
    if tuned:
        choice = tuned["choice"]
        run = find_run(pool, world, choice["structure"], choice["cull"])
        ms = run_ms(run, device) if run else choice["predicted_ms"]
        return {"structure": choice["structure"], "cull": choice["cull"], "run": run, "ms": ms,
                "low": choice.get("low_ms"), "high": choice.get("high_ms"),
                "tied": tuned.get("tied", []),
                "source": f"tune, {len(tuned['probe_frames'])} probe frames"}
    best = best_run(pool, world, device=device)
    if best is None:
        return None
    return {"structure": best["spec"]["structure"], "cull": best["spec"]["cull"], "run": best,
            "ms": run_ms(best, device), "low": None, "high": None, "tied": [],
            "source": f"best of {len(pool)} compared runs"}


def _error_text(rec) -> str:
    run = rec["run"]
    if run is None:
        return "0 missed on tune's probe frames"
    s = run["summary"]
    if s["conservative"]:
        return "0 (conservative)"
    return (f"{s['false_negatives_total']:,} visible triangles missed, "
            f"{s['fn_pixels_mean']:.1f} px/frame{_visible_share(s)}")


def _visible_share(summary) -> str:
    """" (x% of visible pixels)" for a run's lost pixels; "" for results without the count."""
    share = summary.get("fn_visible_fraction")
    return "" if share is None else f" ({share:.1%} of visible pixels)"


def _losses(runs) -> str:
    """The lossy runs among one world's runs: what each loses of the visible pixels along the path."""
    lossy = [r for r in runs if not r["summary"]["conservative"]]
    path = Path(runs[0]["spec"]["trajectory"]).name if runs else ""
    if not lossy:
        return (f"<p class='note'>Path {html.escape(path)}: no run lost a visible pixel.</p>")
    rows = []
    for r in sorted(lossy, key=lambda r: -r["summary"].get("fn_visible_fraction", 0.0)):
        s = r["summary"]
        share, worst = s.get("fn_visible_fraction"), s.get("fn_visible_fraction_max")
        rows.append([_config(r["spec"]["structure"], r["spec"]["cull"]),
                     f"{s['frames_with_fn']} of {s['frames']}",
                     f"{s['false_negatives_total']:,}", _fmt(s["fn_pixels_mean"], 1),
                     "n/a" if share is None else f"{share:.1%}",
                     "n/a" if worst is None else f"{worst:.1%}"])
    return (f"<h3>Lost visible pixels along {html.escape(path)}</h3>"
            + _table(["configuration", "frames losing", "triangles missed", "px/frame",
                      "of visible pixels", "worst frame"], rows))


def answer_rows(records, world, tunes=None) -> tuple:
    """(rows, row classes) of the answer table of one world: one row per device, then this
    machine."""
    rows, classes = [], []
    for device in DEVICES + (None,):
        rec = recommendation(records, world, device, tunes)
        if rec is None:
            continue
        ms = rec["ms"]
        predicted = _fmt(ms, 1 if device else 2)
        if rec["low"] is not None:
            predicted += f" <span class='note'>[{rec['low']:,.1f}–{rec['high']:,.1f}]</span>"
        use = f"<b>{_config(rec['structure'], rec['cull'])}</b>"
        if rec["tied"]:
            use += ("<br><span class='note'>statistically tied: "
                    + "; ".join(_config(t["structure"], t["cull"]) for t in rec["tied"][:3])
                    + ("; …" if len(rec["tied"]) > 3 else "") + "</span>")
        ref = thesis.device_best(world, device) if device else None
        if ref:
            thesis_cell = (f"{_config(ref['structure'], ref['cull'])}"
                           + (" *" if ref["note"] else "")
                           + f"<br>{ref['mean_ms']:,.1f} ms, {ref['fps']:.2f} fps")
            versus = f"{ref['mean_ms'] / ms:.2f}× faster" if ms < ref["mean_ms"] else \
                f"{ms / ref['mean_ms']:.2f}× slower"
        else:
            thesis_cell, versus = "–", "–"
        rows.append([world_title(world), html.escape(label(device)), use,
                     html.escape(rec["source"]), predicted, _fmt(1000.0 / ms, 1), thesis_cell,
                     versus, html.escape(_error_text(rec))])
        classes.append("" if device else "here")
    return rows, classes


ANSWER_HEADER = ["world", "time from", "use", "chosen by", "ms per frame [95% interval]", "fps",
                 "thesis best on this device (measured by the thesis)", "ours vs thesis",
                 "error"]
ANSWER_NOTE = ("<p class='note'>Device rows: predicted by that device's cost model "
               "(vismobile/costmodel.py; render figures fitted to the thesis's own timings on "
               "that device, cull priced from counters; leave-one-out error about 27%). The "
               "\"measured here\" row is wall time on this machine (Mesa llvmpipe), not "
               "comparable with the devices. * The thesis gives only the N82's fps: its "
               "configuration is assumed to be the iPaq's best, and its ms is 1000 / fps. "
               "Error: visible triangles the configuration did not send (0 for conservative "
               "configurations).</p>")


def summary_table(records, tunes=None) -> str:
    """Every world's answer rows in one table (the page's first screen)."""
    rows, classes = [], []
    for world in sorted({r["spec"]["world"] for r in ok_records(records)}):
        more, kinds = answer_rows(records, world, tunes)
        rows += more
        classes += kinds
    return _table(ANSWER_HEADER, rows, left=4, row_class=classes) + ANSWER_NOTE


# ---- figures --------------------------------------------------------------------------------


def _along_path(world, records, tunes, marks) -> str:
    """ms per frame along the path: one panel per device model and one measured here; the
    recommendation and the thesis's configuration, the thesis's measured mean as a line."""
    plt = pyplot()
    sources = DEVICES + (None,)
    fig, axes = plt.subplots(len(sources), 1, figsize=(10, 2.6 * len(sources)), sharex=True)
    for ax, device in zip(np.atleast_1d(axes), sources):
        pool = device_pool(records, world, device)
        rec = recommendation(records, world, device, tunes)
        ref = thesis.device_best(world, device) if device else None
        shown = []
        if rec and rec["run"]:
            shown.append((f"use: {rec['structure']} {rec['cull']}", rec["run"]))
        base = thesis.IPAQ_BEST.get(world)
        at_ref = find_run(pool, world, base["structure"], base["cull"]) if base else None
        if at_ref is not None and (not shown or at_ref is not shown[0][1]):
            shown.append((f"thesis's config: {base['structure']} {base['cull']}", at_ref))
        for i, (name, run) in enumerate(shown):
            ax.plot(run["frames"]["frame"], frame_series(run, device), lw=1.1, ms=3,
                    label=name, **style(i))
        if ref:
            ax.axhline(ref["mean_ms"], color="k", lw=1.2, ls=(0, (6, 3)),
                       label=f"thesis's mean on the {device_name(device)} (measured): "
                             f"{ref['mean_ms']:,.1f} ms")
        waypoints(ax, marks)
        ax.set_ylabel(f"ms per frame\n({label(device)})")
        ax.set_ylim(bottom=0)
        legend_outside(ax)
    np.atleast_1d(axes)[-1].set_xlabel("frame along the path")
    np.atleast_1d(axes)[0].set_title(f"{world_title(world)}: ms per frame along the path "
                                     "(waypoints lettered)", pad=8)
    return figure_png(fig, f"{world_title(world)} ms per frame along the path")


def _triangles_along(world, records, tunes, marks) -> str:
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(10, 3.2))
    shown = {}
    for device in DEVICES + (None,):
        rec = recommendation(records, world, device, tunes)
        if rec and rec["run"]:
            key = (rec["structure"], rec["cull"])
            shown.setdefault(key, (rec["run"], []))[1].append(label(device))
    base = thesis.IPAQ_BEST.get(world)
    at_ref = find_run(ok_records(records), world, base["structure"], base["cull"]) \
        if base else None
    if at_ref is not None:
        shown.setdefault((base["structure"], base["cull"]), (at_ref, []))[1].append(
            "thesis's best config")
    total = None
    for i, ((structure, cull), (run, who)) in enumerate(shown.items()):
        sent = np.maximum(np.asarray(run["frames"]["triangles_sent"], float), 1.0)
        ax.plot(run["frames"]["frame"], sent, lw=1.1, ms=3,
                label=f"{structure} {cull} ({', '.join(who)})", **style(i))
        total = run["summary"]["world_triangles"]
    if total:
        ax.axhline(total, color="k", lw=1.0, ls=(0, (6, 3)),
                   label=f"whole world: {total:,} triangles")
    visible = next(iter(shown.values()))[0]["frames"]["visible"] if shown else None
    if visible is not None:
        ax.plot(next(iter(shown.values()))[0]["frames"]["frame"],
                np.maximum(np.asarray(visible, float), 1.0), color="#555", lw=0.9,
                ls=":", label="visible (item buffer)")
    if total:
        ax.set_ylim(top=total * 4)  # headroom: the waypoint letters sit above the whole world
    log_axis(ax, "y")
    waypoints(ax, marks)
    ax.set_xlabel("frame along the path")
    ax.set_ylabel("triangles per frame (log)")
    ax.set_title(f"{world_title(world)}: triangles sent to the pipeline", pad=8)
    legend_outside(ax)
    return figure_png(fig, f"{world_title(world)} triangles sent")


def _label_groups(xs, ys, threshold=0.05) -> list:
    """Groups of point indices close together in axes fraction (log-log), to label once."""
    if not len(xs):
        return []
    lx, ly = np.log10(xs), np.log10(ys)
    span = lambda v: max(float(v.max() - v.min()), 1e-9)  # noqa: E731
    fx, fy = (lx - lx.min()) / span(lx), (ly - ly.min()) / span(ly)
    groups = []
    for i in range(len(xs)):
        for group in groups:
            j = group[0]
            if abs(fx[i] - fx[j]) < threshold and abs(fy[i] - fy[j]) < threshold * 1.6:
                group.append(i)
                break
        else:
            groups.append([i])
    return groups


def _front(world, records) -> str:
    """Run time (the first device's model) against over-estimation, with the Pareto front's
    points numbered (close ones share one label) and listed below; lossy runs' missed pixels
    in a second panel only when some run missed any (else a sentence)."""
    plt = pyplot()
    device = DEVICES[0]
    runs = device_pool(records, world, device)
    cost = np.array([run_ms(r, device) for r in runs])
    over = np.array([max(r["summary"]["triangles_sent"]["mean"], 1.0)
                     / max(r["summary"]["visible_mean"], 1.0) for r in runs])
    safe = np.array([r["summary"]["conservative"] for r in runs])
    missed = np.array([r["summary"]["fn_pixels_mean"] for r in runs])
    lossy_pixels = bool((missed > 0).any())
    fig, axes = plt.subplots(1, 2 if lossy_pixels else 1, figsize=(11 if lossy_pixels else 9,
                                                                    4.6), squeeze=False)
    ax = axes[0, 0]
    ax.scatter(cost[safe], over[safe], s=18, c=style(2)["color"], marker="o",
               label="zero false negatives")
    if (~safe).any():
        ax.scatter(cost[~safe], over[~safe], s=30, c=style(3)["color"], marker="x",
                   label="misses visible triangles")
    front = np.flatnonzero(pareto_front(cost, over) & safe) if safe.any() else np.array([], int)
    front = front[np.argsort(cost[front])]
    ax.step(cost[front], over[front], where="post", c="k", lw=1, label="Pareto front")
    listed = []
    for group in _label_groups(cost[front], over[front]):
        numbers = [len(listed) + k + 1 for k in range(len(group))]
        listed += [front[g] for g in group]
        text = str(numbers[0]) if len(numbers) == 1 else f"{numbers[0]}–{numbers[-1]}"
        ax.annotate(text, (cost[front[group[0]]], over[front[group[0]]]), fontsize=8,
                    xytext=(4, 4), textcoords="offset points", color="k",
                    bbox={"boxstyle": "round,pad=0.1", "fc": "white", "ec": "none",
                          "alpha": 0.8})
    log_axis(ax, "x")
    log_axis(ax, "y")
    ax.set_xlabel(f"mean ms per frame ({label(device)}, log)")
    ax.set_ylabel("triangles sent / visible (log)")
    ax.set_title(f"{world_title(world)}: run time against over-estimation, {len(runs)} runs", pad=8)
    if lossy_pixels:
        bx = axes[0, 1]
        bx.scatter(cost[missed > 0], missed[missed > 0], s=30, c=style(3)["color"], marker="x",
                   label="runs that missed pixels")
        log_axis(bx, "x")
        log_axis(bx, "y")
        bx.set_xlabel(f"mean ms per frame ({label(device)}, log)")
        bx.set_ylabel("missed pixels per frame (log)")
        bx.set_title("aggressive runs: missed pixels", pad=8)
        legend_outside(bx)
    else:
        legend_outside(ax)
    parts = [figure_png(fig, f"{world_title(world)} run time against error")]
    rows = [[str(n + 1), _config(runs[i]["spec"]["structure"], runs[i]["spec"]["cull"]),
             _fmt(cost[i], 1), _fmt(run_ms(runs[i]), 2), _fmt(over[i], 2)]
            for n, i in enumerate(listed)]
    parts.append("<details><summary>the Pareto front's configurations</summary>" + _table(
        ["#", "configuration", f"ms ({label(device)})", "ms (measured here)",
         "sent / visible"], rows, left=2) + "</details>")
    if not lossy_pixels:
        parts.append("<p class='note'>No run missed a visible pixel (false-negative pixels "
                     "are 0 in every run), so there is no missed-pixel plot.</p>")
    return "\n".join(parts)


def _family_figure(title, runs, names, device, marks, reference=None) -> str:
    """ms per frame along the path of several runs (the thesis's figure style)."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(10, 3.6))
    for i, (run, name) in enumerate(zip(runs, names)):
        y = frame_series(run, device)
        ax.plot(run["frames"]["frame"], y, lw=0.9, ms=2.5, label=name, **style(i))
    if reference:
        ax.axhline(reference[1], color="k", lw=1.2, ls=(0, (6, 3)), label=reference[0])
    waypoints(ax, marks)
    ax.set_xlabel("frame along the path")
    ax.set_ylabel(f"ms per frame ({label(device)})")
    ax.set_ylim(bottom=0)
    ax.set_title(title, pad=8)
    legend_outside(ax)
    return figure_png(fig, title)


def _scatter(world, shown) -> str:
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(7, 3.6))
    for i, run in enumerate(shown):
        r = run["summary"]["correlation"]
        ax.scatter(run["frames"]["triangles_sent"], run["frames"]["frame_ms"], s=8,
                   color=style(i)["color"], marker=style(i)["marker"],
                   label=f"{run['spec']['structure']} {run['spec']['cull']}: "
                         f"r = {_fmt(r, 2)}")
    ax.set_xlabel("triangles sent per frame")
    ax.set_ylabel("ms per frame (measured here)")
    ax.set_title(f"{world_title(world)}: time against triangles sent", pad=8)
    legend_outside(ax, "Pearson r")
    return figure_png(fig, f"{world_title(world)} time against triangles")


def thesis_figures(records, world, tunes=None) -> str:
    """The thesis's figures (per culling combination, per octree depth, per structure) under
    the first device's model, and time against triangles measured here."""
    device = DEVICES[0]
    runs = device_pool(records, world, device)
    if not runs:
        return ""
    marks = runs[0]["summary"]["waypoints"]
    ref = thesis.IPAQ_BEST.get(world)
    best = best_run(runs, world, device=device)
    structures = sorted({r["spec"]["structure"] for r in runs})
    culls = sorted({r["spec"]["cull"] for r in runs})
    fixed_structure = ref["structure"] if ref and ref["structure"] in structures else \
        best["spec"]["structure"]
    fixed_cull = ref["cull"] if ref and ref["cull"] in culls else best["spec"]["cull"]
    reference = (f"thesis's best, {device_name(device)} (measured): {ref['mean_ms']:,.1f} ms",
                 ref["mean_ms"]) if ref and device == "ipaq-hx2490b" else None
    by_cull = sorted((r for r in runs if r["spec"]["structure"] == fixed_structure),
                     key=lambda r: (r["spec"]["cull"] not in THESIS_CULLS, r["spec"]["cull"]))
    by_structure = sorted((r for r in runs if r["spec"]["cull"] == fixed_cull),
                          key=lambda r: r["spec"]["structure"])
    by_depth = [r for r in by_structure if r["spec"]["structure"].startswith("octree")]
    parts = []
    if by_cull:
        parts.append(_family_figure(f"{world_title(world)}: per culling combination, structure "
                                    f"{fixed_structure}", by_cull,
                                    [r["spec"]["cull"] for r in by_cull], device, marks,
                                    reference))
    if len(by_depth) > 1:
        parts.append(_family_figure(f"{world_title(world)}: per octree depth, culling {fixed_cull}",
                                    by_depth, [r["spec"]["structure"] for r in by_depth],
                                    device, marks, reference))
    if len(by_structure) > 1:
        parts.append(_family_figure(f"{world_title(world)}: per structure, culling {fixed_cull}",
                                    by_structure, [r["spec"]["structure"] for r in by_structure],
                                    device, marks, reference))
    shown = [best]
    at_ref = find_run(runs, world, ref["structure"], ref["cull"]) if ref else None
    if at_ref is not None and at_ref is not best:
        shown.append(at_ref)
    parts.append(_scatter(world, shown))
    return "\n".join(parts)


def runs_table(records, world) -> str:
    runs = device_pool(records, world, DEVICES[0])
    rows = []
    for r in sorted(runs, key=lambda r: run_ms(r, DEVICES[0])):
        s = r["summary"]
        rows.append([_config(r["spec"]["structure"], r["spec"]["cull"])]
                    + [_fmt(run_ms(r, d), 1) for d in DEVICES]
                    + [_fmt(s["mean_ms"], 2), _fmt(s["cull_ms"]["mean"], 3),
                       _fmt(s["render_ms"]["mean"], 2),
                       _fmt(s["triangles_sent"]["mean"], 0),
                       _fmt(s["triangles_sent"]["mean"] / max(s["visible_mean"], 1.0), 2),
                       _fmt(s["correlation"], 2), str(s["false_negatives_total"]),
                       _fmt(s["fn_pixels_mean"], 2),
                       "n/a" if s.get("fn_visible_fraction") is None
                       else f"{s['fn_visible_fraction']:.2%}"])
    header = (["configuration"] + [f"ms ({label(d)})" for d in DEVICES]
              + ["ms (measured here)", "cull ms (here)", "render ms (here)", "triangles",
                 "sent / visible", "r(ms, tris) here", "false neg.", "FN px/frame",
                 "FN of visible px"])
    return _table(header, rows)


def world_section(records, world, tunes=None) -> str:
    """HTML for one world: the answer first, then the path, triangles and the front."""
    runs = [r for r in ok_records(records) if r["spec"]["world"] == world]
    if not runs:
        return ""
    marks = runs[0]["summary"]["waypoints"]
    rows, classes = answer_rows(records, world, tunes)
    parts = [f"<h2 id='{world_title(world).lower()}'>{world_title(world)}: what to use</h2>",
             _table(ANSWER_HEADER, rows, left=4, row_class=classes),
             _along_path(world, records, tunes, marks),
             _triangles_along(world, records, tunes, marks),
             _front(world, records),
             _losses(runs),
             "<details><summary>the thesis's figures: per culling combination, octree depth "
             "and structure</summary>" + thesis_figures(records, world, tunes) + "</details>",
             "<details><summary>every run of this world</summary>" + runs_table(records, world)
             + "</details>"]
    return "\n".join(parts)


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
        parts.append(f"<h3>{html.escape(world_title(item['world']))}</h3><pre>"
                     f"{html.escape(item['text'])}</pre>")
    return "\n".join(parts)


def write_report(records, path, agreement=None, tunes=None, title="vismobile comparison",
                 notes="") -> Path:
    """Write the HTML report; returns its path.

    records : runner records (with frames)
    tunes   : optional [{"world", "text", "result": TuneResult.to_dict()}]; a result's pick is
              the recommendation for its world and device
    """
    worlds = sorted({r["spec"]["world"] for r in ok_records(records)})
    failed = [r for r in records if "error" in r]
    nav = "".join(f"<a href='#{world_title(w).lower()}'>{world_title(w)}</a>" for w in worlds)
    body = [f"<h1>{html.escape(title)}</h1>",
            "<p class='note'>What to use for each world on each device. Device times come "
            "from each device's cost model and are labelled with the device; \"measured "
            "here\" is wall time on this machine (software OpenGL), not the devices. "
            f"{html.escape(notes)}</p>",
            summary_table(records, tunes), f"<nav>worlds: {nav}</nav>"]
    for world in worlds:
        body.append(world_section(records, world, tunes))
    body.append(tune_section(tunes))
    body.append(agreement_section(agreement))
    if failed:
        body.append("<h2>Failed runs</h2><pre>" + html.escape("\n".join(
            f"{r['spec']['world']} {r['spec']['structure']} {r['spec']['cull']}: {r['error']}"
            for r in failed)) + "</pre>")
    page = (f"<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'>"
            f"<title>{html.escape(title)}</title><style>{STYLE}</style></head><body>"
            f"{''.join(body)}</body></html>")
    path = Path(path)
    atomic_write_bytes(path, page.encode("utf-8"))
    return path


def pareto_png(records, world, profile, path) -> None:
    """Write only the run-time-against-error figure of one world as a PNG (for the README)."""
    section = _front(world, [r for r in ok_records(records) if r["spec"]["profile"] == profile]
                     or records)
    data = section.split("data:image/png;base64,")[1].split("'")[0]
    atomic_write_bytes(path, base64.b64decode(data))


def terrain_section(rows, peers=None, heading="Terrain: the pixel knob against image error") -> str:
    """The terrain sweep (study.terrain.sweep rows): triangles and PSNR against tau per method
    and path, the exact sample error against the knob, the table, and the peers' rows
    (study.peers.compare) when given."""
    plt = pyplot()
    parts = [f"<h2>{html.escape(heading)}</h2>",
             "<p class='note'>Each method against the full-resolution render of its own finest "
             "mesh (same renderer, normals and colours). Sample error: the exact vertical gap at "
             "every full-resolution sample in the frustum, projected, in pixels: tau bounds it "
             "for tiles and ROAM; Röttger's d2 is a roughness, not a bound. LOD ms are "
             "measured here (medians over the path's frames).</p>"]
    methods = sorted({r["method"] for r in rows}, key=[r["method"] for r in rows].index)
    paths = sorted({r["path"] for r in rows}, key=[r["path"] for r in rows].index)
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
    for k, method in enumerate(methods):
        for p, path in enumerate(paths):
            r = sorted((x for x in rows if x["method"] == method and x["path"] == path),
                       key=lambda x: x["tau"])
            kw = dict(style(k), marker="o", ms=3)
            kw["linestyle"] = "-" if p == 0 else "--"
            label_ = f"{method}, {path}"
            psnr = [min(x["psnr_min"], 90.0) for x in r]
            axes[0].plot([x["triangles"] for x in r], psnr, label=label_, **kw)
            axes[1].plot([x["tau"] for x in r], [max(x["sample_error_max"], 0.01) for x in r],
                         label=label_, **kw)
    taus = sorted({r["tau"] for r in rows})
    axes[1].plot(taus, taus, c="k", lw=0.8, label="sample error = tau")
    log_axis(axes[0], "x")
    axes[0].set_xlabel("triangles drawn (median, log)")
    axes[0].set_ylabel("PSNR min over frames, dB (inf shown at 90)")
    axes[0].axhline(40, c="grey", lw=0.8)
    log_axis(axes[1], "x")
    log_axis(axes[1], "y")
    axes[1].set_xlabel("tau, pixels (log)")
    axes[1].set_ylabel("largest sample error, pixels (log; 0 shown at 0.01)")
    legend_outside(axes[1])
    parts.append(figure_png(fig, "terrain: triangles against PSNR, error against tau"))
    table = [[html.escape(r["method"]), html.escape(r["path"]), _fmt(r["tau"], 2),
              _fmt(r["triangles"], 0), _fmt(100 * r["triangles"] / max(r["full_triangles"], 1), 0),
              _fmt(r["lod_ms"], 2), _fmt(r["render_ms"], 0), _fmt(r["psnr_min"], 1),
              _fmt(r["psnr_median"], 1), _fmt(100 * r["differing_median"], 2),
              _fmt(r["pixel_height_max"], 2), _fmt(r["sample_error_max"], 2)] for r in rows]
    parts.append(_table(["method", "path", "tau px", "triangles", "% of full", "LOD ms",
                         "render ms", "PSNR min", "PSNR median", "% pixels differing",
                         "pixel-height max", "sample error max px"], table, left=2))
    if peers:
        parts.append("<h3>PyPI peers (pymartini, pydelatin)</h3><p class='note'>Static meshes "
                     "at a largest vertical error E (world units), frustum-culled, matched to "
                     "each method at equal triangles (E bisected) or at equal error (E = the "
                     "method's largest vertical gap in the frustum).</p>")
        parts.append(_table(
            ["method", "tau px", "matched on", "E (world)", "triangles", "sample error max px",
             "PSNR min", "PSNR median", "% pixels differing"],
            [[html.escape(r["method"]), _fmt(r["tau"], 2), html.escape(r["match"] or "–"),
              _fmt(r["max_error"], 3), _fmt(r["triangles"], 0), _fmt(r["sample_error_px"], 2),
              _fmt(r["psnr_min"], 1), _fmt(r["psnr_median"], 1),
              _fmt(100 * r["differing_median"], 2)] for r in peers], left=3))
    return "\n".join(parts)


def write_terrain_report(rows, path, title="vismobile terrain comparison", notes="",
                         peers=None) -> Path:
    """Write the terrain sweep's HTML report; returns its path."""
    page = (f"<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'>"
            f"<title>{html.escape(title)}</title><style>{STYLE}</style></head><body>"
            f"<h1>{html.escape(title)}</h1><p class='note'>{html.escape(notes)}</p>"
            f"{terrain_section(rows, peers)}</body></html>")
    path = Path(path)
    atomic_write_bytes(path, page.encode("utf-8"))
    return path

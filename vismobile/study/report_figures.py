"""The report's figures per world: ms per frame and triangles sent along the path, the
run-time-against-error front, the thesis's figures (per culling combination, octree depth and
structure) and the Pareto PNG; each returns an <img> tag with the PNG inline (plots.py)."""
from __future__ import annotations

import base64

import numpy as np

from ..device.costmodel import DEVICES, device_name, label
from ..world.world import atomic_write_bytes
from . import thesis
from .matrix import THESIS_CULLS
from .metrics import pareto_front
from .page import _fmt, _table
from .plots import figure_png, legend_outside, log_axis, pyplot, style, waypoints
from .records import (_config, best_run, device_pool, find_run, frame_series, ok_records,
                      recommendation, run_ms, world_title)


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
        # Headroom: the waypoint letters sit above the whole world. The bottom follows the data:
        # left to the linear autoscale it went below zero, which squashed every line into the
        # top of a log axis reaching down to 1e-300, its tick labels printed over each other.
        floor = min(float(np.min(line.get_ydata())) for line in ax.get_lines()
                    if line.get_transform() == ax.transData)
        ax.set_ylim(floor / 1.5, total * 4)
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


# Offsets (points) tried in turn for a point's label: beside it first, then further out.
LABEL_OFFSETS = [(4, 4), (4, -13), (-6, 4), (-6, -13), (4, 17), (4, -26), (-6, 17), (-6, -26),
                 (16, 4), (16, -13), (-18, 4), (-18, -13), (4, 30), (4, -39), (28, 4), (-30, 4)]


def place_labels(xs, ys, texts, size_pt) -> list:
    """(dx, dy) offsets in points of each label so that no two label boxes overlap (greedy,
    in order; a label that finds no free place keeps the last offset tried). xs, ys: anchors
    as axes fractions; size_pt: (width, height) of the axes in points. A box is about 5.5 pt
    per character plus 4 wide and 11 pt high, drawn right of and above its offset
    (negative x offsets are counted from the box's right edge)."""
    placed, out = [], []
    for x, y, text in zip(xs, ys, texts):
        width, height = 5.5 * len(text) + 4.0, 11.0
        px, py = x * size_pt[0], y * size_pt[1]
        for dx, dy in LABEL_OFFSETS:
            left = px + dx if dx >= 0 else px + dx - width
            box = (left, py + dy, left + width, py + dy + height)
            if all(box[2] <= b[0] or b[2] <= box[0] or box[3] <= b[1] or b[3] <= box[1]
                   for b in placed):
                break
        placed.append(box)
        out.append((dx, dy) if dx >= 0 else (dx - width, dy))
    return out


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
    listed, labels = [], []
    for group in _label_groups(cost[front], over[front]):
        numbers = [len(listed) + k + 1 for k in range(len(group))]
        listed += [front[g] for g in group]
        labels.append((front[group[0]], str(numbers[0]) if len(numbers) == 1
                       else f"{numbers[0]}–{numbers[-1]}"))
    log_axis(ax, "x")
    log_axis(ax, "y")
    if labels:  # placed after the axes' limits are final, so no two labels overlap
        fig.canvas.draw()
        to_axes = ax.transData + ax.transAxes.inverted()
        anchors = to_axes.transform([(cost[i], over[i]) for i, _ in labels])
        box = ax.get_window_extent()
        size = (box.width * 72.0 / fig.dpi, box.height * 72.0 / fig.dpi)
        for (i, text), offset in zip(labels, place_labels(anchors[:, 0], anchors[:, 1],
                                                          [t for _, t in labels], size)):
            far = abs(offset[0]) > 10 or abs(offset[1]) > 14
            ax.annotate(text, (cost[i], over[i]), fontsize=8, xytext=offset,
                        textcoords="offset points", color="k",
                        bbox={"boxstyle": "round,pad=0.1", "fc": "white", "ec": "none",
                              "alpha": 0.8},
                        arrowprops={"arrowstyle": "-", "lw": 0.5, "color": "grey"}
                        if far else None)
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


def pareto_png(records, world, profile, path) -> None:
    """Write only the run-time-against-error figure of one world as a PNG (for the README)."""
    section = _front(world, [r for r in ok_records(records) if r["spec"]["profile"] == profile]
                     or records)
    data = section.split("data:image/png;base64,")[1].split("'")[0]
    atomic_write_bytes(path, base64.b64decode(data))

"""One self-contained HTML report of a comparison: tables and inline matplotlib PNGs.

The page answers "what should I use for this world on this device?" first: per world and
device, the recommendation (tune's pick when given, else the best compared run), its predicted
frame time and fps, the thesis's best on that device, and the error. Then, per world: ms per
frame along the path with the waypoints and the thesis's mean as a reference line, triangles
sent, and the run-time-against-error front; the thesis's figures (per culling combination, per
octree depth, per structure) and every run follow, folded. Times are labelled "measured here"
or "<device> model" (vismobile/device/costmodel.py), thesis figures with the device they were
measured on. The pieces: records.py (what is read from the runs), report_figures.py (the
figures), page.py (style, numbers, tables); terrain_report.py is the terrain comparison's page.
"""
from __future__ import annotations

import html
from pathlib import Path

from ..device.costmodel import DEVICES, label
from ..world.world import atomic_write_bytes
from . import thesis
from .page import STYLE, _fmt, _table
from .records import (_config, best_run, device_pool, find_run,  # noqa: F401  (re-exported)
                      ok_records, pick_figure, recommendation, run_ms, world_title)
from .report_figures import (_along_path, _front, _triangles_along,  # noqa: F401
                             pareto_png, thesis_figures)
from .terrain_report import write_terrain_report  # noqa: F401  (re-exported)
from .pvs_report import glance, pvs_section
from .tune_report import tune_section


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
        predicted = pick_figure(rec, world, device)
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
               "(vismobile/device/costmodel.py; render figures fitted to the thesis's own timings on "
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
             pvs_section(records, world),
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


def pick_mismatches(page: str) -> list:
    """The report check: every figure tagged data-pick (the answer tables' and the tune
    section's) must read the same for one world and device; returns "key: a != b" for each
    that does not (empty: consistent)."""
    seen, wrong = {}, []
    for key, text in _picks(page):
        first = seen.setdefault(key, text)
        if text != first:
            wrong.append(f"{key}: {first} != {text}")
    return wrong


def _picks(page: str) -> list:
    """(key, figure text) of every data-pick span, in page order."""
    import re

    out = []
    for match in re.finditer(r"<span class='pick' data-pick='([^']*)'>", page):
        start = match.end()
        depth, i = 1, start
        while depth:  # the figure may hold a nested span (its interval)
            opening = page.find("<span", i)
            closing = page.find("</span>", i)
            if opening != -1 and opening < closing:
                depth, i = depth + 1, opening + 5
            else:
                depth, i = depth - 1, closing + 7
        out.append((html.unescape(match.group(1)), page[start:i - 7]))
    return out


def write_report(records, path, agreement=None, tunes=None, title="vismobile comparison",
                 notes="") -> Path:
    """Write the HTML report; returns its path.

    records : runner records (with frames)
    tunes   : optional [{"world", "text", "result": TuneResult.to_dict()}]; a result's pick is
              the recommendation for its world and device
    """
    from .lod_report import lod_section, split_lod

    records, lod_records = split_lod(records)  # LOD runs get their own section
    worlds = sorted({r["spec"]["world"] for r in ok_records(records)})
    failed = [r for r in records + lod_records if "error" in r]
    nav = "".join(f"<a href='#{world_title(w).lower()}'>{world_title(w)}</a>" for w in worlds)
    body = [f"<h1>{html.escape(title)}</h1>",
            "<p class='note'>What to use for each world on each device. Device times come "
            "from each device's cost model and are labelled with the device; \"measured "
            "here\" is wall time on this machine (software OpenGL), not the devices. "
            f"{html.escape(notes)}</p>",
            summary_table(records, tunes), glance(records, worlds),
            f"<nav>worlds: {nav}</nav>"]
    for world in worlds:
        body.append(world_section(records, world, tunes))
    body.append(lod_section(records, lod_records))
    body.append(tune_section(tunes, records))
    body.append(agreement_section(agreement))
    if failed:
        body.append("<h2>Failed runs</h2><pre>" + html.escape("\n".join(
            f"{r['spec']['world']} {r['spec']['structure']} {r['spec']['cull']}: {r['error']}"
            for r in failed)) + "</pre>")
    page = (f"<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'>"
            f"<title>{html.escape(title)}</title><style>{STYLE}</style></head><body>"
            f"{''.join(body)}</body></html>")
    wrong = pick_mismatches(page)
    if wrong:  # one pick, one figure: a page contradicting itself is a bug, said at once
        raise AssertionError("report shows two figures for one pick: " + "; ".join(wrong))
    path = Path(path)
    atomic_write_bytes(path, page.encode("utf-8"))
    return path


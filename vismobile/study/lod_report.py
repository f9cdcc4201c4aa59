"""The report's level-of-detail section (compare --lod): run time against image error.

Each (world, structure, culling, profile) swept with several tolerances is one line: the
device model's mean ms per frame against the image error of its LOD runs (the worst frame's
PSNR against the full-detail frames of the same culling; the full-detail run itself is
plotted at the right edge, "identical"), one point per tau. The other sections of the report
see only runs without LOD (write_report splits them off), so LOD never counts as culling.
"""
from __future__ import annotations

import html

import numpy as np

from ..device.costmodel import DEVICES
from .page import _table
from .plots import figure_png, legend_outside, pyplot, style
from .records import ok_records, run_ms

IDENTICAL_DB = 80.0  # where frames identical to the full-detail ones are drawn


def split_lod(records) -> tuple:
    """(records without LOD, records with LOD) of a comparison."""
    lod = [r for r in records if r.get("spec", {}).get("lod_tau") is not None]
    return [r for r in records if r.get("spec", {}).get("lod_tau") is None], lod


def lod_section(records, lod_records) -> str:
    """HTML: the figure and a table of every LOD run, or "" when there is none."""
    lod = ok_records(lod_records)
    if not lod:
        return ""
    device = DEVICES[0]
    base = {_series(r): r for r in ok_records(records)}
    groups = {}
    for r in lod:
        groups.setdefault(_series(r), []).append(r)
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(9, 4.6))
    rows = []
    for index, (key, runs) in enumerate(sorted(groups.items())):
        runs = sorted(runs, key=lambda r: r["spec"]["lod_tau"])
        points = [(run_ms(r, device), _psnr(r["summary"]["psnr_db_min"])) for r in runs]
        if key in base:
            points = [(run_ms(base[key], device), IDENTICAL_DB)] + points
        x, y = np.array(points).T
        ax.plot(x, y, label=" ".join(key[:4]), **style(index))
        for r in runs:
            s = r["summary"]
            ax.annotate(f"{s['lod_tau']:g}", (run_ms(r, device), _psnr(s["psnr_db_min"])),
                        textcoords="offset points", xytext=(4, 4), fontsize=7)
            rows.append([*key[:4], f"{s['lod_tau']:g}", f"{run_ms(r, device):.1f}",
                         f"{s['triangles_sent']['mean']:,.0f}",
                         f"{s['triangles_full']['mean']:,.0f}",
                         _db(s["psnr_db_min"]), _db(s["psnr_db_mean"]), str(s["max_diff"]),
                         f"{100 * s['changed_mean']:.2f}%", f"{s['lod_ms']['median']:.3f}"])
    ax.set_xlabel(f"ms per frame ({device} model)")
    ax.set_ylabel("worst frame's PSNR (dB) against full detail")
    ax.axhline(40.0, color="#888", lw=0.7, ls="--")
    ax.set_title("level of detail: run time against image error (labels: tau in px; "
                 f"{IDENTICAL_DB:g} dB = identical)", fontsize=9)
    legend_outside(ax, "world structure cull profile")
    header = ["world", "structure", "cull", "profile", "tau px", f"ms ({device} model)",
              "triangles", "at full detail", "PSNR min", "PSNR mean", "max diff",
              "pixels changed", "selection ms (median)"]
    return ("<h2 id='lod'>Level of detail</h2><p class='note'>Each LOD run draws its objects "
            "at the coarsest level whose error projects below tau pixels and is measured "
            "against the full-detail frames of the same culling (docs/lod.md).</p>"
            + figure_png(fig, "run time against image error with level of detail")
            + _table(header, [[html.escape(str(c)) for c in row] for row in rows], left=4))


def _series(record) -> tuple:
    spec = record["spec"]
    return (str(spec["world"]), spec["structure"], spec["cull"], spec["profile"],
            spec.get("frames", "all"))


def _psnr(value) -> float:
    return IDENTICAL_DB if value is None else min(float(value), IDENTICAL_DB)


def _db(value) -> str:
    return "identical" if value is None else f"{value:.1f} dB"

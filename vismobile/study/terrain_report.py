"""The terrain comparison's report: the pixel knob against image error per method (and the PyPI
peers at equal triangles and equal error), as one self-contained HTML page."""
from __future__ import annotations

import html
from pathlib import Path

import numpy as np

from ..world.world import atomic_write_bytes
from .page import STYLE, _fmt, _table
from .plots import figure_png, legend_outside, log_axis, pyplot, style


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
    objects = [r for r in rows if r.get("object_triangles") is not None]
    if objects:
        parts.append("<h3>The objects on the terrain</h3><p class='note'>Culled by the engine's "
                     "stages over their partition (the horizon over the drawn LOD ground) and "
                     "drawn at their level of detail within the same tau, as play runs them; "
                     "medians over the path's frames. Dropped: visible object triangles the "
                     "culling removed, summed over the frames, against the item buffer of the "
                     "drawn ground and every object (0 when conservative).</p>")
        parts.append(_table(
            ["method", "path", "tau px", "object triangles sent", "at full detail",
             "horizon removed", "cull ms", "frame ms", "dropped"],
            [[html.escape(r["method"]), html.escape(r["path"]), _fmt(r["tau"], 2),
              _fmt(r["object_triangles"], 0), _fmt(r["object_triangles_full"], 0),
              _fmt(r["object_triangles_hidden"], 0), _fmt(r["cull_ms"], 2),
              _fmt(r["frame_ms"], 1), str(int(r["objects_dropped"]))] for r in objects],
            left=2))
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


# The recommendation's error target: the largest exact sample error, in pixels, a pick may show.
TARGET_PIXELS = 1.0


def recommend(rows, target: float = TARGET_PIXELS) -> list:
    """Per path, the sweep row to use: among rows whose largest exact sample error is at most
    target pixels on every frame, the lowest LOD + render ms (median), then fewer triangles;
    when none meets it, the row with the smallest sample error. Returns [(path, row, met)]."""
    out = []
    for path in sorted({r["path"] for r in rows}, key=[r["path"] for r in rows].index):
        mine = [r for r in rows if r["path"] == path]
        good = [r for r in mine if r["sample_error_max"] <= target]
        if good:
            best = min(good, key=lambda r: (r["lod_ms"] + r["render_ms"], r["triangles"]))
        else:
            best = min(mine, key=lambda r: (r["sample_error_max"], r["triangles"]))
        out.append((path, best, bool(good)))
    return out


def recommendation_section(rows, target: float = TARGET_PIXELS) -> str:
    """The page's first screen: what to use on each path, and the rule that chose it."""
    table = [[html.escape(path), f"<b>{html.escape(r['method'])}, tau {_fmt(r['tau'], 2)} px</b>",
              _fmt(r["lod_ms"] + r["render_ms"], 2), _fmt(r["triangles"], 0),
              _fmt(100 * r["triangles"] / max(r["full_triangles"], 1), 1),
              _fmt(r["sample_error_max"], 2), _fmt(r["psnr_min"], 1),
              "yes" if met else "no: the smallest error instead"]
             for path, r, met in recommend(rows, target)]
    return ("<h2>What to use</h2>" + _table(
        ["path", "use", "LOD + render ms (median, here)", "triangles", "% of full",
         "sample error max px", "PSNR min", f"within {target:g} px"], table, left=2)
        + f"<p class='note'>Rule: among the runs whose exact sample error stays within "
        f"{target:g} pixel on every frame, the fastest (LOD plus render time measured here), "
        "then the fewest triangles.</p>")


def terrain_picture(heightmap, paths) -> str:
    """<img> of the terrain from above (heights coloured) with each path's camera positions:
    what was swept, where. paths: [(label, cameras)]."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(5.5, 5.0))
    extent = heightmap.extent
    shown = ax.imshow(heightmap.heights, cmap="terrain", extent=(0, extent, extent, 0))
    fig.colorbar(shown, ax=ax, label="height (world units)", shrink=0.8)
    for k, (name, cameras) in enumerate(paths):
        eyes = np.array([c.eye for c in cameras]) if cameras else np.zeros((0, 3))
        ax.plot(eyes[:, 0], eyes[:, 2], **{**style(k + 3), "marker": "o", "ms": 3, "lw": 1},
                label=name)
    ax.set_xlabel("x")
    ax.set_ylabel("z")
    ax.set_title(f"{heightmap.name}: {heightmap.size}^2 samples, the swept paths")
    if paths:
        ax.legend(loc="upper right", fontsize=8)
    return figure_png(fig, "the terrain from above with the camera paths")


def write_terrain_report(rows, path, title="vismobile terrain comparison", notes="",
                         peers=None, picture="") -> Path:
    """Write the terrain sweep's HTML report (recommendation first; picture: an <img> from
    terrain_picture, optional); returns its path."""
    page = (f"<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'>"
            f"<title>{html.escape(title)}</title><style>{STYLE}</style></head><body>"
            f"<h1>{html.escape(title)}</h1><p class='note'>{html.escape(notes)}</p>"
            f"{recommendation_section(rows) if rows else ''}{picture}"
            f"{terrain_section(rows, peers)}</body></html>")
    path = Path(path)
    atomic_write_bytes(path, page.encode("utf-8"))
    return path

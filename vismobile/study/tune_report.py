"""The report's tune section: each `vismobile tune` result as tables (the pick with the same
figure as the answer table, tune's own probe estimate labelled as such, ties, the runner-up, the
best candidate per structure, each stage kept or dropped and why), the console text folded."""
from __future__ import annotations

import html

from ..device.costmodel import label
from .page import _fmt, _table
from .records import _config, pick_figure, recommendation, world_title


def _estimate(row) -> str:
    """"103.64 [100.2–107.5]" of a candidate dict of TuneResult.to_dict()."""
    if row is None:
        return "–"
    text = _fmt(row["predicted_ms"], 2)
    if row.get("low_ms") is not None:
        text += f" <span class='note'>[{row['low_ms']:,.2f}–{row['high_ms']:,.2f}]</span>"
    return text


def _stage_rows(explanations) -> tuple:
    """([stage, kept or dropped, why] rows, other notes) from TuneResult.explain's lines."""
    rows, notes = [], []
    for line in explanations:
        stage, _, rest = line.partition(" ")
        verdict, colon, why = rest.strip().partition(":")
        if colon and verdict in ("kept", "dropped"):
            rows.append([html.escape(stage), verdict, html.escape(why.strip())])
        else:
            notes.append(line)
    return rows, notes


def tune_block(item, records, tunes) -> str:
    """HTML of one tune result (item: {"world", "text", "result"})."""
    result = item.get("result")
    title = f"<h3>{html.escape(world_title(item['world']))}</h3>"
    if not result:
        return title + f"<pre>{html.escape(item.get('text', ''))}</pre>"
    world = result["world"]
    device = result["profile"] if result["cost"] == "device" else None
    rec = recommendation(records, world, device, tunes)
    choice = result["choice"]
    frames = len(result["probe_frames"])
    rows = [["pick", f"<b>{_config(choice['structure'], choice['cull'])}</b>"],
            [f"ms per frame [95% interval] ({html.escape(label(device))})",
             pick_figure(rec, world, device) + (
                 f" <span class='note'>({html.escape(rec['source'])}; the answer table's "
                 "figure)</span>")]]
    if rec["run"] is not None:
        rows.append([f"tune's estimate from its {frames} probe frames (what it chose by)",
                     _estimate(choice)])
    tied = result.get("tied") or []
    rows.append(["statistically tied", "; ".join(
        f"{_config(t['structure'], t['cull'])} {_fmt(t.get('predicted_ms'), 2)}"
        for t in tied[:6])
        + ("; …" if len(tied) > 6 else "") if tied else "none"])
    second = result.get("runner_up")
    if second:
        gap = second["predicted_ms"] / choice["predicted_ms"] - 1.0
        rows.append(["runner-up (best other structure)",
                     f"{_config(second['structure'], second['cull'])} {_estimate(second)} "
                     f"<span class='note'>({gap:+.1%})</span>"])
    candidates = result.get("candidates") or []
    rows.append(["searched", f"{len(candidates)} candidates probed, "
                             f"{len(result.get('pruned') or [])} abandoned or rejected, "
                             f"{result.get('seconds', 0.0):.1f} s"])
    if result.get("warning"):
        rows.append(["warning", html.escape(result["warning"])])
    best = {}
    for cand in candidates:
        if cand["false_negatives"] == 0:
            best.setdefault(cand["structure"], cand)
    per_structure = [[html.escape(c["structure"]), html.escape(c["cull"]), _estimate(c),
                      _fmt(c["triangles_sent"], 0),
                      _fmt((result.get("build_seconds") or {}).get(c["structure"], 0.0), 2)]
                     for c in best.values()]
    stages, notes = _stage_rows(result.get("explanations", []))
    parts = [title, _table(["", ""], rows, left=2),
             "<p class='note'>Best candidate per structure (tune's estimates from the probe "
             "frames, zero false negatives):</p>",
             _table(["structure", "stages", "ms per frame (probe)", "triangles sent",
                     "build s"], per_structure, left=2)]
    if stages:
        parts += [f"<p class='note'>Stages on {html.escape(choice['structure'])}:</p>",
                  _table(["stage", "", "why"], stages, left=3)]
    if notes:
        parts.append("<ul class='note'>" + "".join(f"<li>{html.escape(n)}</li>" for n in notes)
                     + "</ul>")
    parts.append("<details><summary>tune's full output</summary><pre>"
                 f"{html.escape(item.get('text', ''))}</pre></details>")
    return "\n".join(parts)


def tune_section(tunes, records) -> str:
    """Every tune result, after the worlds."""
    if not tunes:
        return ""
    return "\n".join(["<h2>Automatic configuration (vismobile tune)</h2>"]
                     + [tune_block(item, records, tunes) for item in tunes])

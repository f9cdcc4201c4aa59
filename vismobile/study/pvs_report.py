"""The report's "bake or cull at run time?" table: per world and device, each baked PVS
(structures labelled "+pvs", matrix.parse_structures) beside the best runtime-only run, with
the bake's offline cost (seconds on this machine, bytes in the .vmp, view cells, mean set) and
the frame's (triangles sent, the device model's ms), and a one-line verdict.

The verdict compares the best conservative run with a PVS against the best conservative run
without one, on the device model: "bake" when the PVS is faster by more than MARGIN of the
runtime frame, "cull at run time" when it is slower by more than that, "either" in between
(the model's 27% leave-one-out error shifts both alike; a smaller difference decides nothing).
A sampled PVS is aggressive: it never wins a verdict; its lost pixels are shown beside it.
"""
from __future__ import annotations

import html

from ..device.costmodel import DEVICES, device_name
from .matrix import pvs_of
from .page import _fmt, _table
from .records import device_pool, run_ms, world_title

MARGIN = 0.01  # as tune's PRACTICAL_MARGIN: differences below 1% of a frame decide nothing


def _best(runs, device, conservative=True):
    pool = [r for r in runs if r["summary"]["conservative"] or not conservative]
    return min(pool, key=lambda r: run_ms(r, device)) if pool else None


def contenders(runs, device) -> tuple:
    """(best conservative run with a conservative PVS, best conservative run without a PVS)
    of one world's runs on a device; either may be None."""
    baked = [r for r in runs if pvs_of(r["spec"]["structure"]) == "conservative"]
    runtime = [r for r in runs if pvs_of(r["spec"]["structure"]) is None]
    return _best(baked, device), _best(runtime, device)


def verdict(baked, runtime, device) -> str:
    """'bake', 'cull at run time' or 'either' (module docstring); baked/runtime are records
    (either may be None)."""
    if baked is None:
        return "cull at run time"
    if runtime is None:
        return "bake"
    b, r = run_ms(baked, device), run_ms(runtime, device)
    if b < r * (1.0 - MARGIN):
        return "bake"
    if b > r * (1.0 + MARGIN):
        return "cull at run time"
    return "either"


def _row(record, device, kind) -> list:
    s = record["summary"]
    bake = s.get("pvs") or {}
    lost = ("0" if s["conservative"] else
            f"{s['false_negatives_total']:,} triangles ({s.get('fn_visible_fraction', 0):.2%} "
            "of visible px)")
    return [kind, f"{html.escape(record['spec']['structure'])} {html.escape(record['spec']['cull'])}",
            _fmt(bake.get("seconds"), 1) if bake else "–",
            _fmt(bake["bytes"] / 1024.0, 1) if bake else "–",
            f"{bake['cells']:,}" if bake else "–",
            f"{bake['mean_set']:.1%}" if bake else "–",
            _fmt(s["triangles_sent"]["mean"], 0), _fmt(run_ms(record, device), 2),
            _fmt(s["cull_ms"]["mean"], 3), lost]


HEADER = ["", "configuration", "bake s (here)", "PVS KB", "view cells", "mean set",
          "triangles sent", "model ms", "cull ms (here)", "lost"]


def pvs_section(records, world) -> str:
    """HTML: per device, the baked PVS runs of a world against its best runtime-only run, and
    the verdict; "" when no run of the world has a PVS."""
    parts = []
    for device in DEVICES:
        runs = device_pool(records, world, device)
        baked = [r for r in runs if pvs_of(r["spec"]["structure"]) is not None]
        if not baked:
            continue
        best_baked, runtime = contenders(runs, device)
        answer = verdict(best_baked, runtime, device)
        gap = ""
        if best_baked is not None and runtime is not None:
            ratio = run_ms(best_baked, device) / run_ms(runtime, device)
            gap = (f": the best bake takes {ratio:.3f}x the best runtime-only frame "
                   f"({run_ms(best_baked, device):,.1f} against {run_ms(runtime, device):,.1f} "
                   "ms)")
        rows, seen = [], set()
        for r in sorted(baked, key=lambda r: run_ms(r, device)):
            label = r["spec"]["structure"]
            if label in seen:  # each bake once: its best combination on this device
                continue
            seen.add(label)
            kind = "bake (aggressive)" if str(pvs_of(label)).startswith("sampled") else "bake"
            rows.append(_row(r, device, kind))
        if runtime is not None:
            rows.append(_row(runtime, device, "run time"))
        parts.append(f"<h3>{html.escape(device_name(device))}: <b class='verdict'>"
                     f"{html.escape(answer)}</b>{html.escape(gap)}</h3>"
                     + _table(HEADER, rows, left=2))
    if not parts:
        return ""
    return ("<h3>Bake or cull at run time?</h3><p class='note'>Each baked PVS (its best "
            "combination on the device) beside the best conservative configuration without "
            "one. Bake seconds and bytes are offline costs (this machine; the PVS's sections "
            "of the .vmp); the frame is priced by the device model, which counts the lookup "
            "(cells tested, runs decoded, triangles looked up: costmodel.CULL_OPERATIONS). "
            f"Verdict: bake or cull when one is faster by more than {MARGIN:.0%} of the "
            "frame, else either; a sampled PVS is aggressive and never wins it.</p>"
            + "".join(parts))


def glance(records, worlds) -> str:
    """HTML: one line per world with a baked PVS, the verdict on each device ("" when none)."""
    rows = []
    for world in worlds:
        cells = []
        for device in DEVICES:
            runs = device_pool(records, world, device)
            if not any(pvs_of(r["spec"]["structure"]) for r in runs):
                continue
            baked, runtime = contenders(runs, device)
            cells.append(f"{html.escape(device_name(device))}: <b>"
                         f"{html.escape(verdict(baked, runtime, device))}</b>")
        if cells:
            rows.append([world_title(world), "; ".join(cells)])
    if not rows:
        return ""
    return ("<h3>Bake a PVS or cull at run time?</h3>"
            + _table(["world", "on each device (device model; each world's section has the "
                      "figures)"], rows, left=2))

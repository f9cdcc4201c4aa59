"""What the report reads from run records: the successful runs, a run's ms per frame (measured
or a device's model), the best run of a world, a given run, and the recommendation per world and
device (tune's pick when given, else the best compared run)."""
from __future__ import annotations

import html
from pathlib import Path

import numpy as np


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


# Bootstrap resamples of a run's frames for the 95% interval of its mean frame time.
BOOTSTRAP_SAMPLES = 1000


def mean_interval(series, samples: int = BOOTSTRAP_SAMPLES, seed: int = 0) -> tuple:
    """(low, high): 95% bootstrap interval of the mean of a (F,) series (the frames of a run);
    (nan, nan) for an empty one. Seeded: the same runs give the same page."""
    values = np.asarray(series, dtype=np.float64)
    if not len(values):
        return float("nan"), float("nan")
    picks = np.random.default_rng(seed).integers(0, len(values), (samples, len(values)))
    low, high = np.percentile(values[picks].mean(axis=1), [2.5, 97.5])
    return float(low), float(high)


def recommendation(records, world, device, tunes=None) -> dict | None:
    """What to use for a world on a device (None: this machine): tune's pick when a tune of
    that device is given, else the compared run with the lowest time and zero false negatives.

    Returns {"structure", "cull", "source", "ms", "low", "high", "tied", "run", "tune"}. One
    figure per pick: when the configuration was compared, ms is its mean over the compared
    frames (the device's model of them, or measured here) and low/high that mean's 95%
    bootstrap interval, on every row; tune's own estimate from its probe frames is only used
    when the pick was not compared, and is kept apart in "tune" ({"ms", "low", "high",
    "frames"}) for the tune section to label as such. tied: tune's ties, or the other
    conservative compared runs whose mean lies inside the best's interval.
    """
    pool = device_pool(records, world, device)
    tuned = _tune_for(tunes, world, device)
    if tuned:
        choice = tuned["choice"]
        run = find_run(pool, world, choice["structure"], choice["cull"])
        estimate = {"ms": choice["predicted_ms"], "low": choice.get("low_ms"),
                    "high": choice.get("high_ms"), "frames": len(tuned["probe_frames"])}
        if run is not None:
            ms = run_ms(run, device)
            low, high = mean_interval(frame_series(run, device))
            source = (f"tune, {estimate['frames']} probe frames; timed over "
                      f"{len(frame_series(run, device))} compared frames")
        else:
            ms, low, high = estimate["ms"], estimate["low"], estimate["high"]
            source = f"tune, {estimate['frames']} probe frames (not compared)"
        return {"structure": choice["structure"], "cull": choice["cull"], "run": run, "ms": ms,
                "low": low, "high": high, "tied": tuned.get("tied", []), "source": source,
                "tune": estimate}
    best = best_run(pool, world, device=device)
    if best is None:
        return None
    low, high = mean_interval(frame_series(best, device))
    tied = sorted((r for r in pool if r is not best and r["summary"]["conservative"]
                   and run_ms(r, device) <= high), key=lambda r: run_ms(r, device))
    return {"structure": best["spec"]["structure"], "cull": best["spec"]["cull"], "run": best,
            "ms": run_ms(best, device), "low": low, "high": high,
            "tied": [{"structure": r["spec"]["structure"], "cull": r["spec"]["cull"]}
                     for r in tied],
            "source": f"best of {len(pool)} compared runs", "tune": None}


def pick_key(world, device) -> str:
    """The data-pick key of a recommendation's figure (the report check matches them)."""
    return f"{world}|{device or 'here'}"


def pick_figure(rec, world, device) -> str:
    """HTML of a recommendation's one figure: ms and its 95% interval, tagged with pick_key so
    that every place showing this pick can be checked to show the same number."""
    digits = 1 if device else 2
    text = f"{rec['ms']:,.{digits}f}"
    if rec["low"] is not None and np.isfinite(rec["low"]):
        text += (f" <span class='note'>[{rec['low']:,.{digits}f}–"
                 f"{rec['high']:,.{digits}f}]</span>")
    return f"<span class='pick' data-pick='{html.escape(pick_key(world, device))}'>{text}</span>"

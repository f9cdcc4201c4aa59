"""Summary statistics shared by playback and the study: mean/median/p95 and Pearson's r."""
from __future__ import annotations

import numpy as np


def summarize(values) -> dict:
    """mean, median, p95 of an (N,) array (nan when empty)."""
    values = np.asarray(values, dtype=np.float64)
    if len(values) == 0:
        return {"mean": float("nan"), "median": float("nan"), "p95": float("nan")}
    return {"mean": float(values.mean()), "median": float(np.median(values)),
            "p95": float(np.percentile(values, 95))}


def pearson(x, y):
    """Pearson correlation of two (N,) arrays, None when either is constant or N < 2."""
    x, y = np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64)
    if len(x) < 2 or np.ptp(x) == 0 or np.ptp(y) == 0:
        return None
    return float(np.corrcoef(x, y)[0, 1])

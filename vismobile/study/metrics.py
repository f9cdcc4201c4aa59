"""Per-frame error of a culled frame against the ground truth: false negatives, pixels, tightness.

The ground truth of a frame is its VisibleSet: the ids in the full world's item buffer and how
many pixels each covers. A culled render draws a subset S of the world with the same depth test,
so a pixel differs from the full render exactly when the full render's triangle there is not in
S (up to exact depth ties); false-negative pixels are therefore the pixel counts of the visible
triangles missing from S, no second render needed (tests check this against a real render).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import stats
from ..render import SENTINEL



@dataclass(eq=False)
class VisibleSet:
    """Triangles seen in one item buffer.

    ids    : (K,) int64 sorted unique triangle ids
    pixels : (K,) int64 pixels covered by each
    total  : int, pixels in the buffer
    """

    ids: np.ndarray
    pixels: np.ndarray
    total: int

    @classmethod
    def from_buffer(cls, buffer: np.ndarray) -> "VisibleSet":
        """From an (H, W) uint32 item buffer whose background is SENTINEL."""
        flat = np.asarray(buffer).ravel()
        ids, pixels = np.unique(flat[flat != SENTINEL], return_counts=True)
        return cls(ids.astype(np.int64), pixels.astype(np.int64), int(flat.size))


def frame_errors(visible: VisibleSet, sent: np.ndarray) -> dict:
    """Error of sending `sent` ((S,) sorted unique int) when `visible` is the truth.

    false_negatives  : visible triangles not sent
    fn_pixels        : pixels the culled render gets wrong (see module docstring)
    tightness        : sent / visible (1 = exact, larger = looser; inf when nothing is visible)
    visible          : visible triangle count
    """
    sent = np.asarray(sent, dtype=np.int64)
    missing = ~np.isin(visible.ids, sent, assume_unique=True)
    count = len(visible.ids)
    return {
        "false_negatives": int(missing.sum()),
        "fn_pixels": int(visible.pixels[missing].sum()),
        "visible": count,
        "tightness": len(sent) / count if count else (0.0 if len(sent) == 0 else float("inf")),
    }


def buffer_difference(full: np.ndarray, culled: np.ndarray) -> int:
    """Pixels that differ between two (H, W) uint32 item buffers."""
    return int(np.count_nonzero(np.asarray(full) != np.asarray(culled)))


def pearson(x: np.ndarray, y: np.ndarray) -> float:
    """Pearson correlation of two (N,) arrays; nan (not None) when undefined, for tables."""
    r = stats.pearson(x, y)
    return float("nan") if r is None else r


def pareto_front(cost: np.ndarray, error: np.ndarray) -> np.ndarray:
    """(N,) bool: points no other point beats on both cost and error (ties kept)."""
    cost, error = np.asarray(cost, float), np.asarray(error, float)
    order = np.lexsort((error, cost))
    best = np.minimum.accumulate(error[order])
    # A point is on the front when its error is below every cheaper point's error.
    previous = np.concatenate([[np.inf], best[:-1]])
    front = np.zeros(len(cost), dtype=bool)
    front[order] = error[order] < previous
    # Exact duplicates of a front point are on the front too.
    key = np.stack([cost, error], axis=1)
    on = key[front]
    if len(on):
        front |= (key[:, None, :] == on[None, :, :]).all(axis=2).any(axis=1)
    return front



"""A linear frame-cost model fitted from stage counters (hardware-independent) to measured ms.

cull_ms   ~ c0 + a * nodes_visited + b * plane_tests + c * triangles_tested
render_ms ~ r0 + d * triangles_sent + e * draw_batches   (fitted apart with GL_CULL_FACE on)
Coefficients are non-negative (Lawson-Hanson NNLS) and fitted in the same process that uses
them, so they describe this machine; the model prices configurations from counters alone.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

CULL_FEATURES = ("nodes_visited", "plane_tests", "triangles_tested")
RENDER_FEATURES = ("triangles_sent", "draw_batches")


def nnls(matrix: np.ndarray, target: np.ndarray, iterations: int = 200) -> np.ndarray:
    """(K,) float64 x >= 0 minimising |matrix @ x - target| (Lawson and Hanson 1974)."""
    a = np.asarray(matrix, float)
    b = np.asarray(target, float)
    k = a.shape[1]
    x = np.zeros(k)
    passive = np.zeros(k, dtype=bool)
    for _ in range(iterations):
        gradient = a.T @ (b - a @ x)
        candidates = ~passive & (gradient > 1e-12 * (np.abs(gradient).max() + 1e-300))
        if not candidates.any():
            break
        passive[np.argmax(np.where(candidates, gradient, -np.inf))] = True
        for _ in range(k + 1):
            z = np.zeros(k)
            z[passive] = np.linalg.lstsq(a[:, passive], b, rcond=None)[0]
            if (z[passive] > 0).all():
                x = z
                break
            # Step back toward x until the first passive coefficient reaches zero.
            falling = passive & (z <= 0)
            alpha = np.min(x[falling] / np.maximum(x[falling] - z[falling], 1e-300))
            x = x + alpha * (z - x)
            passive &= x > 1e-15
            x[~passive] = 0.0
    return x


def design(rows, names) -> np.ndarray:
    """(N, 1 + len(names)) float64: a constant column, then each counter of each row dict."""
    table = np.array([[float(row.get(name, 0.0)) for name in names] for row in rows],
                     dtype=float).reshape(len(rows), len(names))
    return np.column_stack([np.ones(len(rows)), table])


def fit_linear(rows, ms, names) -> tuple:
    """({"constant": .., name: ..}, rms residual ms) of a non-negative fit ms ~ design(rows)."""
    ms = np.asarray(ms, float)
    if len(rows) == 0:
        return dict.fromkeys(("constant",) + tuple(names), 0.0), float("nan")
    matrix = design(rows, names)
    scale = np.maximum(np.abs(matrix).max(axis=0), 1e-12)  # comparable column magnitudes
    coefficients = nnls(matrix / scale, ms) / scale
    residual = float(np.sqrt(np.mean((matrix @ coefficients - ms) ** 2)))
    return dict(zip(("constant",) + tuple(names), map(float, coefficients))), residual


@dataclass
class CostModel:
    """Fitted ms per unit of each counter: `cull`, `render` (no GL_CULL_FACE), `render_back`."""

    cull: dict = field(default_factory=dict)
    render: dict = field(default_factory=dict)
    render_back: dict = field(default_factory=dict)
    residual: dict = field(default_factory=dict)

    @classmethod
    def fit(cls, cull_rows, cull_ms, render_rows, render_ms, render_back=None) -> "CostModel":
        """Fit from counter dicts and (N,) measured ms; render rows with a true "cull_back" key
        go to the GL_CULL_FACE model (which falls back to the other when it has no rows)."""
        model = cls()
        model.cull, model.residual["cull"] = fit_linear(cull_rows, cull_ms, CULL_FEATURES)
        render_ms = np.asarray(render_ms, float)
        back = np.array([bool(row.get("cull_back", False)) for row in render_rows], dtype=bool)
        rows = list(render_rows)
        model.render, model.residual["render"] = fit_linear(
            [r for r, b in zip(rows, back) if not b], render_ms[~back], RENDER_FEATURES)
        if back.any():
            model.render_back, model.residual["render_back"] = fit_linear(
                [r for r, b in zip(rows, back) if b], render_ms[back], RENDER_FEATURES)
        else:
            model.render_back = dict(model.render)
        if not (~back).any():
            model.render = dict(model.render_back)
        return model

    def cull_ms(self, stats: dict) -> float:
        return _apply(self.cull, stats, CULL_FEATURES)

    def render_ms(self, stats: dict, cull_back: bool = False) -> float:
        return _apply(self.render_back if cull_back else self.render, stats, RENDER_FEATURES)

    def render_saving_ms(self, removed_triangles: float, removed_batches: float = 0.0,
                         cull_back: bool = False) -> float:
        """Render time saved by not sending this many triangles and batches."""
        coefficients = self.render_back if cull_back else self.render
        return (coefficients.get("triangles_sent", 0.0) * removed_triangles
                + coefficients.get("draw_batches", 0.0) * removed_batches)

    def describe(self) -> str:
        def text(coefficients):
            return ", ".join(f"{k} {v * (1e3 if k != 'constant' else 1):.3g}"
                             + (" us" if k != "constant" else " ms")
                             for k, v in coefficients.items())
        return (f"cull: {text(self.cull)}\nrender: {text(self.render)}\n"
                f"render with GL_CULL_FACE: {text(self.render_back)}")

    def to_dict(self) -> dict:
        return {"cull": self.cull, "render": self.render, "render_back": self.render_back,
                "residual_ms": self.residual}


def _apply(coefficients: dict, stats: dict, names) -> float:
    return coefficients.get("constant", 0.0) + sum(
        coefficients.get(name, 0.0) * float(stats.get(name, 0)) for name in names)

"""Adaptive culling: switch a stage off while it costs more than it saves, probe it, switch back.

A stage pays on a frame when the render time it saves (the triangles and draw batches it
removes, priced by a linear render-cost model) exceeds the cull time it adds. Every
`probe_every` frames each optional stage is measured both ways (one extra cull per stage: the
frame's own cull is one side of the pair); a stage is switched off when its mean net saving over
the last `window` probes is negative, and back on when it turns positive. Switching a stage off
only sends more triangles, so a conservative combination stays conservative.

The render-cost model comes from the caller (`ms_per_triangle`, `ms_per_batch`) or is learnt
online from `observe_render(render_ms, stats)`; until it is known, nothing is switched.
"""
from __future__ import annotations

import time

import numpy as np

# Render-time flags, not triangle filters: never switched here (the driver does the work).
FIXED_STAGES = ("bfc",)


class AdaptiveCuller:
    """Culler-compatible wrapper: `cull(camera)` -> the active Culler's result; `.events` list.

    partition      : Partition to cull
    stages         : requested stage names (the most that will ever be active)
    window         : probes averaged per decision
    probe_every    : frames between probes
    ms_per_triangle, ms_per_batch : render cost model, or None to learn it with observe_render
    culler_factory : callable(partition, stages) -> Culler (tests pass a fake)
    clock          : callable() -> seconds (tests pass a fake)
    events         : list of {"frame", "stage", "action" ("off"/"on"), "saving_ms", "cost_ms"}
    """

    def __init__(self, partition, stages, window: int = 4, probe_every: int = 10,
                 ms_per_triangle: float | None = None, ms_per_batch: float = 0.0,
                 culler_factory=None, clock=time.perf_counter):
        if culler_factory is None:
            from . import Culler as culler_factory
        self.partition = partition
        self.requested = tuple(stages)
        self.optional = tuple(s for s in self.requested if s not in FIXED_STAGES)
        self.active = set(self.requested)
        self.window = max(int(window), 1)
        self.probe_every = max(int(probe_every), 1)
        self.ms_per_triangle = ms_per_triangle
        self._learns_render = ms_per_triangle is None  # a caller's model is kept as given
        self.ms_per_batch = float(ms_per_batch)
        self._factory = culler_factory
        self._clock = clock
        self._cullers = {}
        self._net = {stage: [] for stage in self.optional}
        self._render = np.zeros((3, 3))  # normal equations of render_ms ~ r0 + d * triangles
        self._render_rhs = np.zeros(3)
        self.frame = 0
        self.events = []

    @property
    def stages(self) -> tuple:
        """Active stages, in the requested order."""
        return tuple(s for s in self.requested if s in self.active)

    @property
    def cull_back(self) -> bool:
        return "bfc" in self.requested

    def _culler(self, stages) -> object:
        key = tuple(s for s in self.requested if s in stages)
        if key not in self._cullers:
            self._cullers[key] = self._factory(self.partition, list(key))
        return self._cullers[key]

    def _timed(self, stages, camera, time=None):
        start = self._clock()
        culler = self._culler(stages)
        result = culler.cull(camera) if time is None else culler.cull(camera, time=time)
        return result, (self._clock() - start) * 1e3

    def observe_render(self, render_ms: float, stats: dict) -> None:
        """Feed one measured render time; refits render_ms ~ r0 + d*triangles + e*batches
        (only when the caller gave no render-cost model)."""
        if not self._learns_render:
            return
        row = np.array([1.0, float(stats.get("triangles_sent", 0)),
                        float(stats.get("draw_batches", 0))])
        self._render += np.outer(row, row)
        self._render_rhs += row * float(render_ms)
        if self._render[0, 0] >= 8:
            solution = np.linalg.lstsq(self._render, self._render_rhs, rcond=None)[0]
            self.ms_per_triangle = max(float(solution[1]), 0.0)
            self.ms_per_batch = max(float(solution[2]), 0.0)

    def _saving_ms(self, without, with_) -> float:
        removed = without.stats.get("triangles_sent", len(without.triangles)) - \
            with_.stats.get("triangles_sent", len(with_.triangles))
        batches = without.stats.get("draw_batches", 0) - with_.stats.get("draw_batches", 0)
        return self.ms_per_triangle * removed + self.ms_per_batch * batches

    def cull(self, camera, time=None):
        """Cull with the active stages (an animated partition at `time`); on probe frames
        measure every optional stage both ways."""
        frame, self.frame = self.frame, self.frame + 1
        result, elapsed = self._timed(self.active, camera, time)
        if self.ms_per_triangle is not None and frame % self.probe_every == 0:
            for stage in self.optional:
                self._probe(stage, camera, frame, result, elapsed, time)
        result.stats["active_stages"] = "+".join(self.stages) or "none"
        return result

    def _probe(self, stage, camera, frame, result, elapsed, time=None) -> None:
        if stage in self.active:
            with_, with_ms = result, elapsed
            without, without_ms = self._timed(self.active - {stage}, camera, time)
        else:
            without, without_ms = result, elapsed
            with_, with_ms = self._timed(self.active | {stage}, camera, time)
        saving, cost = self._saving_ms(without, with_), with_ms - without_ms
        history = self._net[stage]
        history.append((saving, cost))
        del history[:-self.window]
        if len(history) < self.window:
            return
        mean_saving = float(np.mean([s for s, _ in history]))
        mean_cost = float(np.mean([c for _, c in history]))
        pays = mean_saving > mean_cost
        if pays != (stage in self.active):
            (self.active.add if pays else self.active.discard)(stage)
            self.events.append({"frame": frame, "stage": stage, "action": "on" if pays else "off",
                                "saving_ms": mean_saving, "cost_ms": mean_cost})
            history.clear()

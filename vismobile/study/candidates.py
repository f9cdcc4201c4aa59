"""What tune probes and returns: the candidate combinations of a structure, one probed
Candidate (its per-frame means and how simple it is), and the TuneResult with its printout."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .matrix import LOOSE_STAGES, OUR_CULLS, THESIS_CULLS, cull_stages, runs_on, with_pvs


DEFAULT_STRUCTURES = "grid,octree:3-6,portal:1-3,bsp,kdtree"
# tune --pvs adds these: a baked conservative PVS on the structures that hand its sets on best
PVS_STRUCTURES = "portal:2+pvs,bsp+pvs"
PROBE_FRAMES = 24  # evenly spaced probe frames; `vismobile tune --probe` has the same default
COSTS = ("device", "measured")


def candidate_culls(structure: str, loose: bool = False) -> list:
    """Combinations of the matrix usable on a structure (with `pvs` added on a structure with
    a baked PVS, matrix.with_pvs); loose stages left out unless asked."""
    culls = []
    for cull in THESIS_CULLS + OUR_CULLS:
        cull = with_pvs(cull, structure)
        stages = cull_stages(cull)
        if not loose and any(stage in LOOSE_STAGES for stage in stages):
            continue
        if runs_on(cull, structure) and cull not in culls:
            culls.append(cull)
    return culls


@dataclass
class Candidate:
    """One probed configuration; per-frame means over the probe frames.

    cull_ms, render_ms : predicted ms under the tune's cost model (device or this machine)
    host_cull_ms       : cull wall time measured on this machine (numpy)
    stats              : mean Culler counters, plus refs_gathered and leaves_drawn
    per_frame_ms       : (F,) predicted ms of each probe frame (cull + render)
    low_ms, high_ms    : 95% bootstrap interval of the mean over the probe frames (set by
                         uncertainty() for the choice and the tied candidates)
    """

    structure: str
    cull: str
    cull_ms: float
    render_ms: float
    triangles_sent: float
    draw_batches: float
    false_negatives: int
    stats: dict
    host_cull_ms: float = 0.0
    frame_rows: list = field(default_factory=list, repr=False)
    per_frame_ms: np.ndarray = field(default=None, repr=False)
    low_ms: float = float("nan")
    high_ms: float = float("nan")

    @property
    def frame_ms(self) -> float:
        return self.cull_ms + self.render_ms

    @property
    def fps(self) -> float:
        return 1000.0 / max(self.frame_ms, 1e-12)

    @property
    def cull_back(self) -> bool:
        return "bfc" in cull_stages(self.cull)

    @property
    def rank(self) -> tuple:
        """Sort key: unsafe last, then predicted ms, then fewer stages (ties: do less)."""
        return (self.false_negatives > 0, round(self.frame_ms, 9), len(cull_stages(self.cull)))

    @property
    def simplicity(self) -> tuple:
        """Sort key among statistically tied candidates: fewer stages, then no bake over a
        baked PVS, then the simpler structure (SIMPLE_STRUCTURES order, shallower first),
        then predicted ms."""
        base, _, pvs = self.structure.partition("+")
        kind, _, depth = base.partition(":")
        return (len(cull_stages(self.cull)), bool(pvs), SIMPLE_STRUCTURES.index(kind),
                int(depth or 0), self.frame_ms)


@dataclass
class TuneResult:
    world: str
    profile: str
    frames: list
    choice: Candidate
    candidates: list
    model: object
    build_seconds: dict
    seconds: float
    explanations: list = field(default_factory=list)
    pruned: list = field(default_factory=list)
    notes: list = field(default_factory=list)
    cost: str = "measured"
    fastest: Candidate | None = None
    tied: list = field(default_factory=list)
    warning: str | None = None   # set when back-face culling hides what the unculled image shows
    behind: tuple = (0, 0, 0, 0)  # seen_from_behind() over the probe frames
    bakes: dict = field(default_factory=dict)  # structure label -> PVS bake statistics

    def ranked(self) -> list:
        return sorted(self.candidates, key=lambda c: c.rank)

    def runner_up(self):
        """The best zero-false-negative candidate on another structure (None when alone)."""
        for cand in self.ranked():
            if cand.false_negatives == 0 and cand.structure != self.choice.structure:
                return cand
        return None

    def where(self) -> str:
        return (f"on the {self.profile} (device model)" if self.cost == "device"
                else "on this machine (measured)")

    def to_dict(self) -> dict:
        def row(c):
            return None if c is None else {
                "structure": c.structure, "cull": c.cull, "predicted_ms": c.frame_ms,
                "low_ms": _number(c.low_ms), "high_ms": _number(c.high_ms),
                "fps": c.fps, "cull_ms": c.cull_ms, "render_ms": c.render_ms,
                "host_cull_ms": c.host_cull_ms, "triangles_sent": c.triangles_sent,
                "false_negatives": c.false_negatives}
        return {"world": self.world, "profile": self.profile, "cost": self.cost,
                "probe_frames": self.frames, "choice": row(self.choice),
                "fastest": row(self.fastest), "tied": [row(c) for c in self.tied],
                "runner_up": row(self.runner_up()),
                "candidates": [row(c) for c in self.ranked()],
                "model": self.model.to_dict(), "build_seconds": self.build_seconds,
                "seconds": self.seconds, "explanations": self.explanations,
                "seen_from_behind": dict(zip(("triangles", "visible", "pixels",
                                              "covered_pixels"), self.behind)),
                "backface_exact": self.warning is None, "warning": self.warning,
                "pruned": [list(p) for p in self.pruned], "pvs_bakes": self.bakes}

    def _describe(self, label, c) -> list:
        calls = ""
        if self.cost == "device" and self.model.cost.render_call_us:
            counter = self.model.cost.call_counter
            calls = f", {c.stats.get(counter, 0):,.0f} draw calls ({counter})"
        return [f"{label}: --structure {c.structure} --cull {c.cull}",
                f"  predicted {self.where()}: {c.frame_ms:.2f} ms/frame ({c.fps:.2f} fps) = "
                f"cull {c.cull_ms:.2f} + render {c.render_ms:.2f}; sends "
                f"{c.triangles_sent:,.0f} triangles{calls}; 0 false negatives on the probe"
                + (f"; cull here {c.host_cull_ms:.2f} ms" if self.cost == "device" else "")]

    def report(self) -> str:
        """Human-readable summary: choice and runner-up, best per structure, stage reasons."""
        lines = [f"world {self.world}, profile {self.profile}, cost model {self.cost}, "
                 f"{len(self.frames)} probe frames, {len(self.candidates)} candidates, "
                 f"{self.seconds:.1f} s"]
        if self.warning:
            lines.append("WARNING: " + self.warning)
        lines += self._describe("choice", self.choice)
        if np.isfinite(self.choice.low_ms):
            lines.append(f"  95% interval of its mean over the {len(self.frames)} probe frames "
                         f"(bootstrap): {self.choice.low_ms:.2f}-{self.choice.high_ms:.2f} ms")
        if self.fastest is not None and self.fastest is not self.choice:
            lines.append(f"  chosen as the simplest of {len(self.tied) + 1} statistically tied "
                         f"candidates; the fastest point estimate was {self.fastest.structure} "
                         f"{self.fastest.cull} at {self.fastest.frame_ms:.2f} ms "
                         f"[{self.fastest.low_ms:.2f}-{self.fastest.high_ms:.2f}]")
        if self.tied:
            lines.append("  tied with the fastest (not shown > 1% slower): " + "; ".join(
                f"{c.structure} {c.cull} {c.frame_ms:.2f} ms" for c in self.tied[:6])
                + ("; ..." if len(self.tied) > 6 else ""))
        if self.cost == "device":
            lines.append("  (the interval is the probe's sampling error; the device model's "
                         "own error, about 27% leave-one-out, shifts every candidate alike)")
        second = self.runner_up()
        if second is not None:
            gap = second.frame_ms / self.choice.frame_ms - 1.0
            lines += self._describe(f"runner-up (best other structure, {gap:+.1%})", second)
        lines.append("best per structure (predicted ms/frame, zero false negatives):")
        best = {}
        for cand in self.ranked():
            if cand.false_negatives == 0:
                best.setdefault(cand.structure, cand)
        for cand in sorted(best.values(), key=lambda x: x.rank):
            build = self.build_seconds.get(cand.structure, 0.0)
            bake = self.bakes.get(cand.structure)
            cost = (f"build {build:.2f} s" if bake is None else
                    f"PVS bake {bake['seconds']:.1f} s, {bake['bytes'] / 1024:,.1f} KB, "
                    f"{bake['cells']} cells")
            width = max(9, max(len(c.structure) for c in best.values()))
            lines.append(f"  {cand.structure:{width}s} {cand.frame_ms:9.2f}  {cand.cull:32s} "
                         f"{cand.triangles_sent:10,.0f} tris  ({cost})")
        lossy = [p for p in self.pruned if p[2].startswith("missed")]
        slow = [p for p in self.pruned if not p[2].startswith("missed")]
        if lossy:
            lines.append(f"rejected for false negatives on the probe: {len(lossy)} candidates "
                         f"(e.g. {lossy[0][0]} {lossy[0][1]}: {lossy[0][2]})")
        if slow:
            lines.append(f"abandoned early (branch and bound): {len(slow)} candidates "
                         f"(e.g. {slow[0][0]} {slow[0][1]}: {slow[0][2]})")
        lines.append(f"stages on the chosen structure ({self.where()}):")
        lines += [f"  {text}" for text in self.explanations]
        how = ("device model (figures in the profile; cull priced from counters, "
               "not from this machine's time):" if self.cost == "device" else
               "cost model (fitted in this run; cull times of the choice are measured, "
               "not modelled):")
        lines.append(how + "\n  " + self.model.describe().replace("\n", "\n  "))
        return "\n".join(lines)


# Simplest first: one level of slabs, a regular subdivision, planes from the world, cells and
# portals (ties between structures go to the one with less to build and explain).
SIMPLE_STRUCTURES = ("grid", "octree", "bsp", "kdtree", "portal")


def _number(value):
    """float, or None for nan (JSON has no nan)."""
    return None if value is None or not np.isfinite(value) else float(value)

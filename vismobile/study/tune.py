"""Automatic configuration: pick structure, parameters and culling stages from a cheap probe.

The probe plays a sample of the trajectory's frames (evenly spaced, plus the waypoints) through
every candidate (structure x culling combination), culling on this machine to get each cull's
counters and sent set, and checks the sent set against the ground truth (full-world item
buffers of the probe frames). No candidate is rendered. Its predicted frame time comes from one
of two cost models:
- device (the default when the profile has DeviceCost figures, i.e. the iPaq and the N82): the
  frame time on that device, from counters alone (costmodel.DeviceModel: render figures fitted
  to the thesis's own device measurements, cull cycles per operation at the device's clock);
- measured (`--cost measured`, and always for `desktop`): this machine's wall time, i.e. the
  measured mean cull time plus render time from a model fitted to a few timed renders of the
  probe's triangle sets (costmodel.CostModel).
The choice is made among the candidates with zero false negatives on the probe frames (loose
stages are never candidates), with the probe's uncertainty: a paired bootstrap over the probe
frames gives each candidate a 95% interval of its mean frame time and of its difference from
the fastest; every candidate whose mean lies inside the fastest's interval and which the probe
does not show to be more than 1% slower than the fastest is tied with it, and the simplest of the tied (fewest stages, then the simplest structure) is
the choice, so the pick does not flip with the probe size on differences the probe cannot
resolve or that are too small to matter. For each stage the choice leaves out,
`explain` prices it on the chosen structure: cull time it would add against render time it
would save.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..culling import BACKFACE_STAGES
from . import engine
from .costmodel import CULL_FEATURES, CostModel, DeviceModel, device_counters, fit_linear
from .groundtruth import trajectory_truth
from .matrix import (LOOSE_STAGES, OUR_CULLS, THESIS_CULLS, canonical_cull, cull_stages,
                     frame_indices, parse_structures)
from .metrics import frame_errors

DEFAULT_STRUCTURES = "grid,octree:3-6,portal:1-3,bsp,kdtree"
PROBE_FRAMES = 24  # evenly spaced probe frames; `vismobile tune --probe` has the same default
COSTS = ("device", "measured")


def candidate_culls(structure: str, loose: bool = False) -> list:
    """Combinations of the matrix usable on a structure; loose stages left out unless asked."""
    culls = []
    for cull in THESIS_CULLS + OUR_CULLS:
        stages = cull_stages(cull)
        if not loose and any(stage in LOOSE_STAGES for stage in stages):
            continue
        if "portals" in stages and not structure.startswith("portal"):
            continue
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
        """Sort key among statistically tied candidates: fewer stages, then the simpler
        structure (SIMPLE_STRUCTURES order, shallower first), then predicted ms."""
        kind, _, depth = self.structure.partition(":")
        return (len(cull_stages(self.cull)), SIMPLE_STRUCTURES.index(kind), int(depth or 0),
                self.frame_ms)


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
                "pruned": [list(p) for p in self.pruned]}

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
            lines.append(f"  {cand.structure:9s} {cand.frame_ms:9.2f}  {cand.cull:32s} "
                         f"{cand.triangles_sent:10,.0f} tris  (build {build:.2f} s)")
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


def probe_frames(trajectory, count: int) -> list:
    """Frame indices the probe plays: `count` evenly spaced plus the waypoints."""
    return frame_indices(f"sample:{count}", len(trajectory), trajectory.waypoints)


def _stage_cost_rank(cull: str) -> int:
    """Probe order within a structure: cheap combinations first, so the bound tightens early."""
    stages = cull_stages(cull)
    return 4 * ("occlusion" in stages) + 2 * ("portals" in stages) + len(stages)


class _Probe:
    """Probes candidates on the probe frames. With `bound`, branch and bound: a candidate is
    abandoned once its mean predicted cull time plus the model's fixed render cost exceeds the
    best predicted frame time so far (after MIN_FRAMES frames), or at its first false negative.
    Without it (the sweep), every frame of every candidate is played and false negatives counted.
    """

    MIN_FRAMES = 3

    def __init__(self, world, profile, cameras, truths, model, cache_dir, progress,
                 bound=True):
        self.world, self.profile, self.cameras, self.truths = world, profile, cameras, truths
        self.model, self.cache_dir, self.progress = model, cache_dir, progress
        self.device = isinstance(model, DeviceModel)
        self.renderer = None if self.device else engine.renderer(world, profile)
        self.bound = bound
        self.partitions, self.builds = {}, {}
        self.candidates, self.pruned = [], []
        self.model_rows, self.model_ms = [], []
        self.best = None
        self.warning, self.behind = None, (0, 0, 0, 0)

    def structure(self, label):
        if label not in self.partitions:
            self.partitions[label], self.builds[label] = engine.load_structure(
                self.world, label, self.cache_dir)
        return self.partitions[label]

    def run(self, label, cull):
        """Probe one candidate; returns the Candidate, or None when abandoned (see pruned)."""
        stages = cull_stages(cull)
        truth = self.truths[any(s in BACKFACE_STAGES for s in stages)]
        partition = self.structure(label)
        engine.make_culler(partition, stages).cull(self.cameras[0])  # warm-up: lazy tables
        culler = engine.make_culler(partition, stages)
        back = "bfc" in stages
        floor = self.model.render_ms({}, back)
        host, costs, render, rows, missed = [], [], [], [], 0
        for camera, visible in zip(self.cameras, truth):
            result, ms = engine.timed_cull(culler, camera)
            sent = engine.sent_triangles(result)
            stats = device_counters(result, culler.tree)
            drawn = sent
            if back and self.warning:  # judged against the unculled image: GL_CULL_FACE drops
                drawn = sent[~_facing_away(self.world, sent, camera)]  # what faces away
            missed += frame_errors(visible, drawn)["false_negatives"]
            host.append(ms)
            rows.append(stats)
            if self.device:
                costs.append(self.model.cull_ms(stats))
                render.append(self.model.render_ms(stats, back))
            else:
                costs.append(ms)
                render.append(self.model.render_ms(
                    {"triangles_sent": len(sent),
                     "draw_batches": _batches(self.renderer, sent)}, back))
            if not self.bound:
                continue
            if missed:
                self.pruned.append((label, cull, f"missed {missed} visible triangles"))
                return None
            if (self.best is not None and len(costs) >= self.MIN_FRAMES
                    and np.mean(costs) + floor > self.best.frame_ms):
                self.pruned.append((label, cull, f"cull {np.mean(costs):.2f} ms + fixed render "
                                                 f"{floor:.2f} ms > best "
                                                 f"{self.best.frame_ms:.2f} ms"))
                return None
        stats = _mean_stats(rows)
        cand = Candidate(label, cull, float(np.mean(costs)), float(np.mean(render)),
                         float(np.mean([r["triangles_sent"] for r in rows])),
                         stats.get("draw_batches", 0.0), missed, stats, float(np.mean(host)),
                         rows, np.add(costs, render))
        self.model_rows.extend(rows)
        self.model_ms.extend(host)
        self.candidates.append(cand)
        if missed == 0 and (self.best is None or cand.rank < self.best.rank):
            self.best = cand
        return cand

    def structure_best(self, label, loose=False):
        """Probe every candidate combination on a structure; its best safe Candidate or None."""
        found = [self.run(label, cull) for cull in sorted(candidate_culls(label, loose),
                                                          key=_stage_cost_rank)]
        found = [c for c in found if c is not None and c.false_negatives == 0]
        if self.progress:
            self.progress(len(self.partitions), None)
        return min(found, key=lambda c: c.rank) if found else None


def _search_order(labels) -> list:
    """Structures without a depth first, then each depth family as (family, sorted depths)."""
    flat = [label for label in labels if ":" not in label]
    families = {}
    for label in labels:
        if ":" in label:
            kind, depth = label.split(":")
            families.setdefault(kind, []).append(int(depth))
    return flat, {kind: sorted(depths) for kind, depths in families.items()}


def cost_model_for(profile, cost: str) -> str:
    """"device" when asked for and the profile has device figures, else "measured"."""
    if cost not in COSTS:
        from ..errors import VisMobileError

        raise VisMobileError(f"unknown cost model {cost!r}; known: {', '.join(COSTS)}")
    return "device" if cost == "device" and profile.cost is not None else "measured"


def _setup(world, trajectory, profile, frames, cost, cache_dir, progress, bound):
    cameras = [trajectory.camera(f, profile.aspect) for f in frames]
    truths = {back: trajectory_truth(world, cameras, frames,
                                     engine.item_buffer_fn(world, profile, back),
                                     profile.resolution, trajectory.poses, back,
                                     None if cache_dir is None else Path(cache_dir) / "truth")
              for back in (False, True)}
    model = DeviceModel(profile) if cost == "device" else \
        calibrate(world, profile, cameras, truths[False])
    search = _Probe(world, profile, cameras, truths, model, cache_dir, progress, bound)
    seen = seen_from_behind(world, cameras, truths[False])
    search.behind = seen
    behind, visible, behind_pixels, pixels = seen
    if behind > BEHIND_LIMIT * visible and behind_pixels > BEHIND_LIMIT * pixels:
        # Back-face culling would hide what the unculled image shows: judge back-face stages
        # against the unculled truth, so none of them passes as exact.
        search.truths = {False: truths[False], True: truths[False]}
        search.warning = (
            f"back-face culling removes {behind:,} of the {visible:,} visible triangles of the "
            f"probe frames ({behind / visible:.1%}, {behind_pixels / pixels:.1%} of the covered "
            "pixels: seen from behind in the unculled item buffer), so no configuration with "
            "bfc, cbfc, cone or tbfc is exact here; they were judged against the unculled "
            "image. Fix the winding (`vismobile info` reports it; --fix-winding) to use them")
    return search


# tune refuses to call back-face culling exact when more than this share of the triangles
# visible in the unculled item buffer, and of the pixels they cover, are seen from behind (the
# pixel share keeps one-pixel depth ties along a solid's silhouette, where its far side shows
# through, from counting: the tiny study world has 1 such triangle among 68).
BEHIND_LIMIT = 0.01


def seen_from_behind(world, cameras, visible_sets) -> tuple:
    """(triangles seen from behind, triangles visible, their pixels, covered pixels), summed
    over frames: visible in the unculled item buffer and facing away from the eye."""
    behind = total = behind_pixels = pixels = 0
    for camera, visible in zip(cameras, visible_sets):
        away = _facing_away(world, visible.ids, camera)
        behind += int(away.sum())
        total += len(visible.ids)
        behind_pixels += int(visible.pixels[away].sum())
        pixels += int(visible.pixels.sum())
    return behind, total, behind_pixels, pixels


def _facing_away(world, ids, camera) -> np.ndarray:
    """(K,) bool: triangle ids whose front faces away from the eye, n.(p - e) > 0 in float64
    with no margin (edge-on and degenerate triangles count as facing the eye; one within
    float64 rounding of edge-on may go either way, which only moves tune's judging, not a
    cull)."""
    ids = np.asarray(ids, dtype=np.int64)
    return np.einsum("ij,ij->i", world.normals[ids], world.corners[ids, 0] - camera.eye) > 0


def tune(world, trajectory, profile, probe: int = PROBE_FRAMES, structures: str = DEFAULT_STRUCTURES,
         cache_dir=None, exhaustive: bool = False, progress=None,
         cost: str = "device") -> TuneResult:
    """Choose the configuration minimising predicted mean frame time with zero false negatives.

    world      : World;  trajectory : Trajectory;  profile : Profile
    probe      : evenly spaced probe frames (the waypoints are added)
    cache_dir  : optional folder for partition files and ground truths (a second tune reuses them)
    exhaustive : probe every depth listed; otherwise each depth family (octree, portal) is
                 searched from its start depth in the improving direction and stops at the
                 first depth that is slower than its neighbour (unimodal search)
    progress   : optional callable(structures_done, None)
    cost       : "device" (the profile's device model; `desktop` has none, so measured) or
                 "measured" (this machine's wall time)
    """
    start = time.perf_counter()
    cost = cost_model_for(profile, cost)
    frames = probe_frames(trajectory, probe)
    search = _setup(world, trajectory, profile, frames, cost, cache_dir, progress, True)
    model = search.model
    notes = []
    flat, families = _search_order(parse_structures(structures))
    for label in flat:
        search.structure_best(label)
    for kind, depths in families.items():
        if exhaustive or len(depths) <= 2:
            for depth in depths:
                search.structure_best(f"{kind}:{depth}")
            continue
        # Unimodal search from the start depth toward the better neighbour.
        begin = min(depths, key=lambda d: abs(d - START_DEPTH.get(kind, depths[0])))
        score = {}

        def value(depth, kind=kind, score=score):
            if depth not in score:
                best = search.structure_best(f"{kind}:{depth}")
                score[depth] = best.frame_ms if best else float("inf")
            return score[depth]

        best_depth = begin
        value(begin)
        for step in (-1, 1):
            j = depths.index(begin) + step
            while 0 <= j < len(depths) and value(depths[j]) < value(best_depth):
                best_depth = depths[j]
                j += step
            if best_depth != begin:
                break  # it improved this way, so (unimodal) the other way only gets worse
        skipped = [d for d in depths if d not in score]
        if skipped:
            notes.append(f"{kind} depths {', '.join(map(str, skipped))} not built: the unimodal "
                         f"depth search stopped where frame time rose ("
                         + ", ".join(f"{kind}:{d} {score[d]:.2f} ms" for d in sorted(score))
                         + ")")
    if search.best is None:
        from ..errors import VisMobileError

        raise VisMobileError("tune: no candidate had zero false negatives on the probe frames")
    # Local search: toggle each stage of the choice on its structure until nothing improves.
    seen = {(c.structure, c.cull) for c in search.candidates} | \
        {(label, cull) for label, cull, _ in search.pruned}
    improved = True
    while improved:
        improved = False
        choice = search.best
        for stage in _toggle_stages(choice.structure):
            cull = canonical_cull("+".join(set(cull_stages(choice.cull)) ^ {stage}))
            if (choice.structure, cull) in seen:
                continue
            seen.add((choice.structure, cull))
            if search.run(choice.structure, cull) is search.best:
                improved = True
                break
    if cost == "measured":
        model.cull, model.residual["cull"] = fit_linear(search.model_rows, search.model_ms,
                                                        CULL_FEATURES)
    result = TuneResult(world.name, profile.name, frames, search.best, search.candidates,
                        model, search.builds, 0.0, pruned=search.pruned, notes=notes, cost=cost,
                        warning=search.warning, behind=search.behind)
    # Choose under the probe's uncertainty; probe the choice's stage toggles in full (no
    # bound) so explain() can price each, and choose again if one of them is tied and simpler.
    search.bound = False
    for _ in range(3):
        uncertainty(result)
        fresh = [(result.choice.structure, canonical_cull("+".join(
                     set(cull_stages(result.choice.cull)) ^ {stage})))
                 for stage in _toggle_stages(result.choice.structure)]
        fresh = [key for key in fresh if key not in seen]
        if not fresh:
            break
        for key in fresh:
            seen.add(key)
            search.run(*key)
    else:
        uncertainty(result)  # the last round's toggles are candidates too
    result.explanations = explain(result)
    result.seconds = time.perf_counter() - start
    return result


def sweep(world, trajectory, profile, frames: str = "sample:48",
          structures: str = DEFAULT_STRUCTURES, cost: str = "device", cache_dir=None,
          loose: bool = True, every_subset: bool = True, progress=None) -> TuneResult:
    """Every structure x combination (loose ones too, for their error) on a frame selection,
    no search and no branch and bound: the reference tune is checked against. With
    every_subset, also every subset of the stages tune may toggle (its local search reaches
    combinations outside the matrix). Returns a TuneResult whose choice is the sweep's best
    zero-false-negative candidate."""
    start = time.perf_counter()
    cost = cost_model_for(profile, cost)
    picked = frame_indices(frames, len(trajectory), trajectory.waypoints)
    search = _setup(world, trajectory, profile, picked, cost, cache_dir, progress, False)
    for label in parse_structures(structures):
        search.structure_best(label, loose)
        if every_subset:
            for cull in stage_subsets(label):
                if (label, cull) not in {(c.structure, c.cull) for c in search.candidates}:
                    search.run(label, cull)
    if search.best is None:
        from ..errors import VisMobileError

        raise VisMobileError("sweep: no candidate had zero false negatives")
    result = TuneResult(world.name, profile.name, picked, search.best, search.candidates,
                        search.model, search.builds, 0.0, cost=cost,
                        warning=search.warning, behind=search.behind)
    uncertainty(result)
    result.explanations = explain(result)
    result.seconds = time.perf_counter() - start
    return result


START_DEPTH = {"octree": 4, "portal": 1}
# Simplest first: one level of slabs, a regular subdivision, planes from the world, cells and
# portals (ties between structures go to the one with less to build and explain).
SIMPLE_STRUCTURES = ("grid", "octree", "bsp", "kdtree", "portal")
BOOTSTRAP_SAMPLES = 2000
# Differences below this fraction of the frame time are not worth a more complex configuration:
# the device model's own error (27% leave-one-out) is far larger.
PRACTICAL_MARGIN = 0.01


def uncertainty(result: TuneResult, samples: int = BOOTSTRAP_SAMPLES, seed: int = 0,
                margin: float = PRACTICAL_MARGIN) -> None:
    """Set the choice by the probe's uncertainty (in place).

    Paired bootstrap over the probe frames: the same resampled frames price every fully
    probed safe candidate, giving each one's 95% interval of its mean and of its difference
    from the fastest mean. A candidate is tied with the fastest when its mean lies inside the
    fastest's interval and its difference's interval does not lie wholly above `margin` of the
    fastest's mean (the probe does not show it slower by more than that); the simplest tied
    candidate (Candidate.simplicity) becomes
    result.choice; result.fastest is the fastest mean, result.tied the others tied by mean.
    """
    safe = [c for c in result.candidates
            if c.false_negatives == 0 and c.per_frame_ms is not None
            and len(c.per_frame_ms) == len(result.frames)]
    if not safe:
        return
    table = np.stack([c.per_frame_ms for c in safe])            # (C, F)
    rng = np.random.default_rng(seed)
    picks = rng.integers(0, table.shape[1], (samples, table.shape[1]))
    means = table[:, picks].mean(axis=2)                         # (C, samples)
    low, high = np.percentile(means, [2.5, 97.5], axis=1)
    for cand, lo, hi in zip(safe, low, high):
        cand.low_ms, cand.high_ms = float(lo), float(hi)
    best = min(range(len(safe)), key=lambda i: safe[i].rank)
    fastest = safe[best]
    # Paired: frame-to-frame variation common to both candidates cancels in the difference.
    # The mean must also lie inside the fastest's interval: one catastrophic frame among few
    # leaves the paired interval reaching zero, yet that candidate is not a tie.
    slower_by = np.percentile(means - means[best], 2.5, axis=1)
    tied = [c for c, lo in zip(safe, slower_by)
            if lo <= margin * fastest.frame_ms and c.frame_ms <= fastest.high_ms]
    choice = min(tied, key=lambda c: c.simplicity)
    result.fastest, result.choice = fastest, choice
    result.tied = sorted((c for c in tied if c is not choice), key=lambda c: c.rank)


def _number(value):
    """float, or None for nan (JSON has no nan)."""
    return None if value is None or not np.isfinite(value) else float(value)


def stage_subsets(structure: str) -> list:
    """Every combination of the stages tune may toggle on a structure, canonical, "none" too."""
    stages = _toggle_stages(structure)
    return [canonical_cull("+".join(s for i, s in enumerate(stages) if mask >> i & 1))
            for mask in range(1 << len(stages))]


def _toggle_stages(structure: str) -> list:
    """Conservative stages tune may switch on a structure."""
    return ["vfc", "bfc", "cbfc", "cone", "tbfc", "occlusion"] + \
        (["portals"] if structure.startswith("portal") else [])


def _mean_stats(rows) -> dict:
    keys = {k for row in rows for k, v in row.items() if isinstance(v, (int, float))}
    return {k: float(np.mean([row.get(k, 0) for row in rows])) for k in sorted(keys)}


def _batches(renderer, sent) -> int:
    """Draw batches a set needs: the uint16 batches it touches."""
    per = renderer.buffers.batch_triangles
    return int(len(np.unique(np.asarray(sent) // per))) if len(sent) else 0


def calibrate(world, profile, cameras, visible_sets, seed: int = 0) -> CostModel:
    """Fit the render-cost model before any candidate is probed: per probe frame, time the
    renderer (glFinish) on three sets spanning the range every candidate falls in (all
    triangles, the visible ones plus a random quarter, the visible ones), with and without
    GL_CULL_FACE."""
    renderer = engine.renderer(world, profile)
    rng = np.random.default_rng(seed)
    everything = np.arange(world.triangle_count)
    renderer.draw(everything, cameras[0], False)  # warm-up
    rows, times = [], []
    for camera, visible in zip(cameras, visible_sets):
        quarter = np.union1d(visible.ids, rng.choice(everything, len(everything) // 4,
                                                     replace=False))
        for triangles in (everything, quarter, visible.ids):
            for back in (False, True):
                drawn = renderer.draw(triangles, camera, back)
                rows.append({"triangles_sent": len(triangles),
                             "draw_batches": drawn.draw_batches, "cull_back": back})
                times.append(drawn.render_ms)
    return CostModel.fit([], [], rows, times)


def explain(result: TuneResult) -> list:
    """One line per stage on the chosen structure: kept or dropped, with its cost and saving."""
    choice = result.choice
    model = result.model
    device = result.cost == "device"
    counter = model.cost.call_counter if device and model.cost.render_call_us else None
    chosen = set(cull_stages(choice.cull))
    table = {(c.structure, frozenset(cull_stages(c.cull))): c for c in result.candidates}
    pruned = {(label, frozenset(cull_stages(cull))): why
              for label, cull, why in result.pruned}
    lines = []
    for stage in _toggle_stages(choice.structure):
        kept = stage in chosen
        key = (choice.structure, frozenset(chosen ^ {stage}))
        other = table.get(key)
        if other is None:
            why = pruned.get(key, "not probed")
            lines.append(f"{stage:9s} {'kept' if kept else 'dropped'}: with it toggled the "
                         f"probe was abandoned ({why})")
            continue
        with_, without = (choice, other) if kept else (other, choice)
        if other.false_negatives:
            lines.append(f"{stage:9s} kept: without it {other.false_negatives} visible "
                         "triangles were missed")
            continue
        if stage == "bfc":
            delta = without.render_ms - with_.render_ms
            lines.append(f"{stage:9s} {'kept' if kept else 'dropped'}: GL_CULL_FACE changes "
                         f"modelled render time by {-delta:+.3f} ms/frame (a render flag: the "
                         "same triangles are sent"
                         + ("; the device model prices it as neutral, so it is left off"
                            if device and not kept and delta == 0 else "") + ")")
            continue
        added = with_.cull_ms - without.cull_ms
        removed = without.triangles_sent - with_.triangles_sent
        saved = without.render_ms - with_.render_ms
        net = saved - added
        reason = f"it pays {net:+.3f} ms/frame" if kept else \
            f"it costs {-net:.3f} ms/frame more than it saves"
        calls = ""
        if counter:
            fewer = without.stats.get(counter, 0) - with_.stats.get(counter, 0)
            calls = f" and {fewer:,.0f} draw calls"
        lines.append(f"{stage:9s} {'kept' if kept else 'dropped'}: {reason} (cull {added:+.3f} "
                     f"ms, removes {removed:,.0f} triangles{calls} = {saved:.3f} ms of "
                     f"rendering at {model.render_saving_ms(1, 0, with_.cull_back) * 1e3:.3g} "
                     "us/triangle)")
    return lines + list(result.notes)

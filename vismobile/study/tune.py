"""Automatic configuration: pick structure, parameters and culling stages from a cheap probe.

The probe plays a sample of the trajectory's frames (evenly spaced, plus the waypoints) through
every candidate (structure x culling combination), measuring each cull's time and counters and
checking its sent set against the ground truth (full-world item buffers of the probe frames).
A few renders of the probe's triangle sets fit the render-cost model (study.costmodel), so no
candidate has to be rendered: its predicted frame time is its measured mean cull time plus the
modelled render time of what it sends. The choice is the cheapest candidate with zero false
negatives on the probe frames. For each stage the choice leaves out, `explain` prices it on
the chosen structure: cull time it would add against render time it would save.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from . import engine
from .costmodel import CULL_FEATURES, CostModel, fit_linear
from .groundtruth import trajectory_truth
from .matrix import (LOOSE_STAGES, OUR_CULLS, THESIS_CULLS, canonical_cull, cull_stages,
                     frame_indices, parse_structures)
from .metrics import frame_errors

DEFAULT_STRUCTURES = "grid,octree:3-6,portal:1-3,bsp"


def candidate_culls(structure: str) -> list:
    """Conservative combinations of the matrix usable on a structure (loose stages left out)."""
    culls = []
    for cull in THESIS_CULLS + OUR_CULLS:
        stages = cull_stages(cull)
        if any(stage in LOOSE_STAGES for stage in stages):
            continue
        if "portals" in stages and not structure.startswith("portal"):
            continue
        culls.append(cull)
    return culls


@dataclass
class Candidate:
    """One probed configuration; per-frame means over the probe frames."""

    structure: str
    cull: str
    cull_ms: float
    render_ms: float
    triangles_sent: float
    draw_batches: float
    false_negatives: int
    stats: dict

    @property
    def frame_ms(self) -> float:
        return self.cull_ms + self.render_ms

    @property
    def cull_back(self) -> bool:
        return "bfc" in cull_stages(self.cull)


@dataclass
class TuneResult:
    world: str
    profile: str
    frames: list
    choice: Candidate
    candidates: list
    model: CostModel
    build_seconds: dict
    seconds: float
    explanations: list = field(default_factory=list)
    pruned: list = field(default_factory=list)
    notes: list = field(default_factory=list)

    def ranked(self) -> list:
        return sorted(self.candidates, key=lambda c: (c.false_negatives > 0, c.frame_ms))

    def to_dict(self) -> dict:
        def row(c):
            return {"structure": c.structure, "cull": c.cull, "predicted_ms": c.frame_ms,
                    "cull_ms": c.cull_ms, "render_ms": c.render_ms,
                    "triangles_sent": c.triangles_sent, "false_negatives": c.false_negatives}
        return {"world": self.world, "profile": self.profile, "probe_frames": self.frames,
                "choice": row(self.choice), "candidates": [row(c) for c in self.ranked()],
                "model": self.model.to_dict(), "build_seconds": self.build_seconds,
                "seconds": self.seconds, "explanations": self.explanations,
                "pruned": [list(p) for p in self.pruned]}

    def report(self) -> str:
        """Human-readable summary: the choice, runner-up per structure, why stages were dropped."""
        c = self.choice
        lines = [f"world {self.world}, profile {self.profile}, {len(self.frames)} probe frames, "
                 f"{len(self.candidates)} candidates, {self.seconds:.1f} s",
                 f"choice: --structure {c.structure} --cull {c.cull.replace('+', ',')}",
                 f"  predicted {c.frame_ms:.2f} ms/frame = cull {c.cull_ms:.2f} + render "
                 f"{c.render_ms:.2f} (sends {c.triangles_sent:,.0f} triangles, "
                 f"0 false negatives on the probe)",
                 "best per structure (predicted ms/frame, zero false negatives):"]
        best = {}
        for cand in self.ranked():
            if cand.false_negatives == 0:
                best.setdefault(cand.structure, cand)
        for cand in sorted(best.values(), key=lambda x: x.frame_ms):
            build = self.build_seconds.get(cand.structure, 0.0)
            lines.append(f"  {cand.structure:9s} {cand.frame_ms:8.2f}  {cand.cull:32s} "
                         f"{cand.triangles_sent:10,.0f} tris  (build {build:.2f} s)")
        lossy = [p for p in self.pruned if p[2].startswith("missed")]
        slow = [p for p in self.pruned if not p[2].startswith("missed")]
        if lossy:
            lines.append(f"rejected for false negatives on the probe: {len(lossy)} candidates "
                         f"(e.g. {lossy[0][0]} {lossy[0][1]}: {lossy[0][2]})")
        if slow:
            lines.append(f"abandoned early (branch and bound): {len(slow)} candidates "
                         f"(e.g. {slow[0][0]} {slow[0][1]}: {slow[0][2]})")
        lines.append("stages on the chosen structure:")
        lines += [f"  {text}" for text in self.explanations]
        lines.append("cost model (fitted in this run; cull times of the choice are measured,"
                     " not modelled):\n  " +
                     self.model.describe().replace("\n", "\n  "))
        return "\n".join(lines)


def probe_frames(trajectory, count: int) -> list:
    return frame_indices(f"sample:{count}", len(trajectory), trajectory.waypoints)


def _stage_cost_rank(cull: str) -> int:
    """Probe order within a structure: cheap combinations first, so the bound tightens early."""
    stages = cull_stages(cull)
    return 4 * ("occlusion" in stages) + 2 * ("portals" in stages) + len(stages)


class _Probe:
    """Probes candidates on the probe frames with branch and bound: a candidate is abandoned
    once its mean cull time alone exceeds the best predicted frame time found so far (after
    `MIN_FRAMES` frames), or at its first false negative."""

    MIN_FRAMES = 3

    def __init__(self, world, profile, cameras, truths, model, cache_dir, progress):
        self.world, self.profile, self.cameras, self.truths = world, profile, cameras, truths
        self.model, self.cache_dir, self.progress = model, cache_dir, progress
        self.renderer = engine.renderer(world, profile)
        self.partitions, self.builds = {}, {}
        self.candidates, self.pruned = [], []
        self.model_rows, self.model_ms = [], []
        self.best = None

    def structure(self, label):
        if label not in self.partitions:
            self.partitions[label], self.builds[label] = engine.load_structure(
                self.world, label, self.cache_dir)
        return self.partitions[label]

    def run(self, label, cull):
        """Probe one candidate; returns the Candidate, or None when abandoned (see pruned)."""
        stages = cull_stages(cull)
        truth = self.truths[any(s in ("bfc", "cbfc", "cone") for s in stages)]
        partition = self.structure(label)
        engine.make_culler(partition, stages).cull(self.cameras[0])  # warm-up: lazy tables
        culler = engine.make_culler(partition, stages)
        back = "bfc" in stages
        times, counters, sent_counts, render, missed = [], [], [], [], 0
        for camera, visible in zip(self.cameras, truth):
            result, ms = engine.timed_cull(culler, camera)
            sent = engine.sent_triangles(result)
            missed += frame_errors(visible, sent)["false_negatives"]
            times.append(ms)
            counters.append(dict(result.stats))
            sent_counts.append(len(sent))
            batches = _batches(self.renderer, sent)
            render.append(self.model.render_ms({"triangles_sent": len(sent),
                                                "draw_batches": batches}, back))
            if missed:
                self.pruned.append((label, cull, f"missed {missed} visible triangles"))
                return None
            if (self.best is not None and len(times) >= self.MIN_FRAMES
                    and np.mean(times) > self.best.frame_ms):
                self.pruned.append((label, cull, f"cull alone {np.mean(times):.2f} ms > best "
                                                 f"{self.best.frame_ms:.2f} ms"))
                return None
        cand = Candidate(label, cull, float(np.mean(times)), float(np.mean(render)),
                         float(np.mean(sent_counts)), 0.0, missed, _mean_stats(counters))
        self.model_rows.extend(counters)
        self.model_ms.extend(times)
        self.candidates.append(cand)
        if self.best is None or cand.frame_ms < self.best.frame_ms:
            self.best = cand
        return cand

    def structure_best(self, label):
        """Probe every candidate combination on a structure; its best Candidate or None."""
        found = [self.run(label, cull) for cull in sorted(candidate_culls(label),
                                                          key=_stage_cost_rank)]
        found = [c for c in found if c is not None]
        if self.progress:
            self.progress(len(self.partitions), None)
        return min(found, key=lambda c: c.frame_ms) if found else None


def _search_order(labels) -> list:
    """Structures without a depth first, then each depth family as (family, sorted depths)."""
    flat = [label for label in labels if ":" not in label]
    families = {}
    for label in labels:
        if ":" in label:
            kind, depth = label.split(":")
            families.setdefault(kind, []).append(int(depth))
    return flat, {kind: sorted(depths) for kind, depths in families.items()}


def tune(world, trajectory, profile, probe: int = 16, structures: str = DEFAULT_STRUCTURES,
         cache_dir=None, exhaustive: bool = False, progress=None) -> TuneResult:
    """Choose the configuration minimising predicted mean frame time with zero false negatives.

    world      : World;  trajectory : Trajectory;  profile : Profile
    probe      : evenly spaced probe frames (the waypoints are added)
    cache_dir  : optional folder for partition files (a second tune reuses them)
    exhaustive : probe every depth listed; otherwise each depth family (octree, portal) is
                 searched from its start depth in the improving direction and stops at the
                 first depth that is slower than its neighbour (unimodal search)
    progress   : optional callable(structures_done, None)
    """
    start = time.perf_counter()
    frames = probe_frames(trajectory, probe)
    cameras = [trajectory.camera(f, profile.aspect) for f in frames]
    truths = {back: trajectory_truth(world, cameras, frames,
                                     engine.item_buffer_fn(world, profile, back),
                                     profile.resolution, trajectory.poses, back)
              for back in (False, True)}
    model = calibrate(world, profile, cameras, truths[False])
    search = _Probe(world, profile, cameras, truths, model, cache_dir, progress)
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
    model.cull, model.residual["cull"] = fit_linear(search.model_rows, search.model_ms,
                                                    CULL_FEATURES)
    result = TuneResult(world.name, profile.name, frames, search.best, search.candidates,
                        model, search.builds, 0.0, pruned=search.pruned, notes=notes)
    result.explanations = explain(result)
    result.seconds = time.perf_counter() - start
    return result


START_DEPTH = {"octree": 4, "portal": 1}


def _toggle_stages(structure: str) -> list:
    """Conservative stages tune may switch on a structure."""
    return ["vfc", "bfc", "cbfc", "cone", "occlusion"] + \
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
        if stage == "bfc":
            delta = without.render_ms - with_.render_ms
            lines.append(f"{stage:9s} {'kept' if kept else 'dropped'}: GL_CULL_FACE changes "
                         f"modelled render time by {-delta:+.3f} ms/frame (a render flag: the "
                         "same triangles are sent)")
            continue
        added = with_.cull_ms - without.cull_ms
        removed = without.triangles_sent - with_.triangles_sent
        saved = without.render_ms - with_.render_ms
        net = saved - added
        reason = f"it pays {net:+.3f} ms/frame" if kept else \
            f"it costs {-net:.3f} ms/frame more than it saves"
        lines.append(f"{stage:9s} {'kept' if kept else 'dropped'}: {reason} (cull {added:+.3f} "
                     f"ms, removes {removed:,.0f} triangles = {saved:.3f} ms of rendering at "
                     f"{model.render_saving_ms(1, 0, with_.cull_back) * 1e3:.3g} us/triangle)")
    return lines + list(result.notes)

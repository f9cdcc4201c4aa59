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

import numpy as np

from .candidates import (COSTS, DEFAULT_STRUCTURES, PROBE_FRAMES,  # noqa: F401  (re-exported)
                         SIMPLE_STRUCTURES, Candidate, TuneResult, candidate_culls)
from .costmodel import CULL_FEATURES, fit_linear
from .matrix import canonical_cull, cull_stages, frame_indices, parse_structures, with_pvs
from .probe import _setup, cost_model_for, probe_frames


def _search_order(labels) -> list:
    """Structures without a depth first (and those with a baked PVS: each is probed as it is),
    then each depth family as (family, sorted depths)."""
    flat = [label for label in labels if ":" not in label or "+" in label]
    families = {}
    for label in labels:
        if label not in flat:
            kind, depth = label.split(":")
            families.setdefault(kind, []).append(int(depth))
    return flat, {kind: sorted(depths) for kind, depths in families.items()}


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
                        warning=search.warning, behind=search.behind, bakes=search.bakes)
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
                        warning=search.warning, behind=search.behind, bakes=search.bakes)
    uncertainty(result)
    result.explanations = explain(result)
    result.seconds = time.perf_counter() - start
    return result


START_DEPTH = {"octree": 4, "portal": 1}
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


def stage_subsets(structure: str) -> list:
    """Every combination of the stages tune may toggle on a structure, canonical, "none" too."""
    stages = _toggle_stages(structure)
    return [with_pvs(canonical_cull("+".join(s for i, s in enumerate(stages) if mask >> i & 1)),
                     structure) for mask in range(1 << len(stages))]


def _toggle_stages(structure: str) -> list:
    """Conservative stages tune may switch on a structure (`pvs` stays on where it was
    baked: without it the structure is its base structure, a candidate of its own)."""
    return ["vfc", "bfc", "cbfc", "cone", "tbfc", "occlusion", "horizon"] + \
        (["portals"] if structure.startswith("portal") else [])


def _signed(value, positive, negative, fmt) -> str:
    """'12 fewer' / '3 more': a signed difference in words (no minus signs in the prose)."""
    return f"{format(abs(value), fmt)} {positive if value >= 0 else negative}"


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
            change = ("does not change modelled render time" if abs(delta) < 5e-4 else
                      "makes modelled rendering "
                      + _signed(delta, "ms/frame faster", "ms/frame slower", ".3f"))
            lines.append(f"{stage:9s} {'kept' if kept else 'dropped'}: GL_CULL_FACE {change} "
                         f"(a render flag: the "
                         "same triangles are sent"
                         + ("; the device model prices it as neutral, so it is left off"
                            if device and not kept and delta == 0 else "") + ")")
            continue
        added = with_.cull_ms - without.cull_ms
        removed = without.triangles_sent - with_.triangles_sent
        saved = without.render_ms - with_.render_ms
        net = saved - added
        if kept:
            reason = (f"it saves {net:.3f} ms/frame more than it costs" if net >= 0 else
                      f"it costs {-net:.3f} ms/frame more than it saves, a difference too "
                      "small to tell (statistically tied)")
        else:
            reason = (f"it costs {-net:.3f} ms/frame more than it saves" if net < 0 else
                      f"it would save {net:.3f} ms/frame, too little to tell from the "
                      "simpler configuration (statistically tied)")
        calls = ""
        if counter:
            fewer = without.stats.get(counter, 0) - with_.stats.get(counter, 0)
            calls = f", {_signed(fewer, 'fewer', 'more', ',.0f')} draw calls"
        lines.append(f"{stage:9s} {'kept' if kept else 'dropped'}: {reason} (culling takes "
                     f"{_signed(added, 'ms more', 'ms less', '.3f')}; it sends "
                     f"{_signed(removed, 'fewer', 'more', ',.0f')} triangles{calls}, so rendering "
                     f"takes {_signed(saved, 'ms less', 'ms more', '.3f')} at {model.render_saving_ms(1, 0, with_.cull_back) * 1e3:.3g} "
                     "us/triangle)")
    return lines + list(result.notes)

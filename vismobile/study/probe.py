"""The probe behind tune: plays the probe frames through candidates (branch and bound, or every
frame for the sweep), checks each sent set against the ground truth, and prices it with the
device model or a cost model calibrated on this machine; warns when back-face culling would
hide what the unculled image shows."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..culling import BACKFACE_STAGES
from . import engine
from .candidates import COSTS, Candidate, candidate_culls
from .costmodel import CostModel, DeviceModel, device_counters
from .groundtruth import trajectory_truth
from .matrix import cull_stages, frame_indices
from .metrics import frame_errors


def probe_frames(trajectory, count: int) -> list:
    """Frame indices the probe plays: `count` evenly spaced plus the waypoints."""
    return frame_indices(f"sample:{count}", len(trajectory), trajectory.waypoints)


def _stage_cost_rank(cull: str) -> int:
    """Probe order within a structure: cheap combinations first, so the bound tightens early."""
    stages = cull_stages(cull)
    return (4 * ("occlusion" in stages) + 3 * ("horizon" in stages) + 2 * ("portals" in stages)
            + len(stages))


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
        self.partitions, self.builds, self.bakes = {}, {}, {}
        self.candidates, self.pruned = [], []
        self.model_rows, self.model_ms = [], []
        self.best = None
        self.warning, self.behind = None, (0, 0, 0, 0)

    def structure(self, label):
        if label not in self.partitions:
            self.partitions[label], self.builds[label] = engine.load_structure(
                self.world, label, self.cache_dir)
            bake = engine.bake_stats(self.world, label, self.cache_dir)
            if bake is not None:  # a baked PVS: its offline cost goes in the report
                self.bakes[label] = bake
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


def cost_model_for(profile, cost: str) -> str:
    """"device" when asked for and the profile has device figures, else "measured"."""
    if cost not in COSTS:
        from ..errors import VisMobileError

        raise VisMobileError(f"unknown cost model {cost!r}; known: {', '.join(COSTS)}")
    return "device" if cost == "device" and profile.cost is not None else "measured"


def _setup(world, trajectory, profile, frames, cost, cache_dir, progress, bound):
    cameras = engine.frame_cameras(world, trajectory, frames, profile.aspect)  # timed if moving
    moving = engine.animated_of(world) is not None  # each frame's pose: truth not cached
    truths = {back: trajectory_truth(world, cameras, frames,
                                     engine.item_buffer_fn(world, profile, back),
                                     profile.resolution, trajectory.poses, back,
                                     None if cache_dir is None or moving
                                     else Path(cache_dir) / "truth")
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
    animated = engine.animated_of(world)
    at = getattr(camera, "time", None)
    if animated is not None and at is not None:  # the moving triangles as they stand at t
        world = animated.posed(at)
    return np.einsum("ij,ij->i", world.normals[ids], world.corners[ids, 0] - camera.eye) > 0


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

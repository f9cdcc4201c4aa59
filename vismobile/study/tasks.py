"""One run of a comparison matrix and what it needs, as tasks a worker executes (a process of
the pool, a Dask worker or the parent): building structures and ground truths (prepare), and
executing a run into its result file (execute). runner.py schedules them; distributed.py hands
them to Dask. Workers are spawned (not forked) so that none inherits another's OpenGL context.
"""
from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np

from ..device.costmodel import DEVICES, device_counters, frame_model_ms, model_block
from ..stats import summarize
from ..world.world import atomic_write_bytes
from . import engine
from .groundtruth import trajectory_truth
from .matrix import RunSpec, frame_indices
from .metrics import frame_errors, pearson

FRAME_COLUMNS = ("frame", "cull_ms", "render_ms", "frame_ms", "triangles_sent", "draw_batches",
                 "nodes_visited", "plane_tests", "triangles_tested", "visible",
                 "false_negatives", "fn_pixels", "tightness", "visible_pixels")
# Per frame, the modelled frame ms on each device (costmodel.frame_model_ms of the counters).
MODEL_COLUMNS = tuple(f"model_ms:{device}" for device in DEVICES)
# Per frame, with level of detail (RunSpec.lod_tau): selection ms, the full-detail frame's
# triangles, and the image error against it.
LOD_COLUMNS = ("lod_ms", "triangles_full", "psnr_db", "max_diff", "changed")
RESULT_VERSION = "4"  # 4: visible_pixels per frame
RENDER_REPEATS = 2


class Context:
    """Where a study reads and writes: repo root (trajectory paths), worlds, cache, results;
    and the repair every world gets on loading ("none" or "tjunctions": compare --repair)."""

    def __init__(self, root=".", out="out/compare", worlds_dir=None, cache_dir=None,
                 repair="none"):
        from ..scenes.thesis import default_cache_dir

        self.root = Path(root)
        self.out = Path(out)
        self.worlds_dir = Path(worlds_dir) if worlds_dir else default_cache_dir()
        self.cache_dir = Path(cache_dir) if cache_dir else Path("out/cache")
        self.repair = repair or "none"

    def trajectory_path(self, spec: RunSpec) -> Path:
        path = Path(spec.trajectory)
        return path if path.is_absolute() else self.root / path

    def world(self, spec: RunSpec):
        """The run's world, repaired as the context says (engine.load_world, cached)."""
        return engine.load_world(spec.world, self.worlds_dir, self.repair)

    def as_tuple(self) -> tuple:
        return (str(self.root), str(self.out), str(self.worlds_dir), str(self.cache_dir),
                self.repair)

    @classmethod
    def from_tuple(cls, values) -> "Context":
        return cls(*values)


def salts(specs, context: Context) -> dict:
    """{spec: key salt} from the sha256 of each world OBJ and trajectory file (built if missing)."""
    digests = {}
    result = {}
    for spec in specs:
        world_file = engine.ensure_world_file(spec.world, context.worlds_dir)
        for path in (world_file, context.trajectory_path(spec)):
            if path not in digests:
                if not path.is_file():
                    from ..errors import TrajectoryError

                    raise TrajectoryError(f"{path}: no such trajectory file")
                digests[path] = engine.file_digest(path)
        result[spec] = (f"{RESULT_VERSION}:{digests[world_file]}:"
                        f"{digests[context.trajectory_path(spec)]}"
                        # a repaired world's runs apart (unrepaired keys as before)
                        + ("" if context.repair == "none" else f":repair={context.repair}"))
    return result


def result_path(context: Context, key: str) -> Path:
    """<out>/runs/<key>.json: one run's result file."""
    return context.out / "runs" / f"{key}.json"


def _load_frames(spec: RunSpec, context: Context):
    from ..device.profile import get_profile
    from ..world.trajectory import Trajectory

    world = context.world(spec)
    trajectory = Trajectory.load(context.trajectory_path(spec))
    profile = get_profile(spec.profile)
    frames = frame_indices(spec.frames, len(trajectory), trajectory.waypoints)
    cameras = engine.frame_cameras(world, trajectory, frames, profile.aspect)  # timed if moving
    return world, trajectory, profile, frames, cameras


def truth_for(spec: RunSpec, context: Context, cull_back=None):
    """The ground-truth VisibleSets of a run's frames (cached in <cache>/truth)."""
    world, trajectory, profile, frames, cameras = _load_frames(spec, context)
    cull_back = spec.truth_cull_back if cull_back is None else cull_back
    moving = engine.animated_of(world) is not None  # its truth is each frame's pose: not cached
    return trajectory_truth(world, cameras, frames,
                            engine.item_buffer_fn(world, profile, cull_back),
                            profile.resolution, trajectory.poses, cull_back,
                            None if moving else context.cache_dir / "truth")


def prep_key(task) -> tuple:
    """What a prepare task makes: ("structure", world, structure) or ("truth", world,
    trajectory, profile, frames, cull_back); run tasks wait for the two of their spec."""
    what, spec, _ = task
    if what == "structure":
        return what, spec.world, spec.structure
    return what, spec.world, spec.trajectory, spec.profile, spec.frames, spec.truth_cull_back


def bake_first(prep, executor, progress=True) -> int:
    """Bake the conservative PVS of every structure among prepare tasks, in this process with
    its source cells spread over `executor` (a Dask Client, or a process pool: the runner's
    workers; None: serially), so the prepare tasks find them cached; a progress line per bake (progress False:
    none); returns how many were baked or found."""
    from ..progress import Progress
    from .matrix import pvs_of

    done = 0
    for what, spec, context_tuple in prep:
        if what != "structure" or pvs_of(spec.structure) != "conservative":
            continue
        context = Context.from_tuple(context_tuple)
        world = context.world(spec)
        bar = Progress(f"compare: baking {spec.world} {spec.structure}",
                       enabled=None if progress else False)
        try:
            engine.load_structure(world, spec.structure, context.cache_dir, executor, bar)
        finally:
            bar.close()
        done += 1
    return done


def prepare(task) -> str:
    """Worker task: build one partition or one ground truth so runs find them cached."""
    what, spec, context_tuple = task
    context = Context.from_tuple(context_tuple)
    try:
        if what == "structure":
            world = context.world(spec)
            engine.load_structure(world, spec.structure, context.cache_dir)
        else:
            truth_for(spec, context)
    except Exception as error:  # the run needing it fails again and records the error
        return f"{what}: {type(error).__name__}: {error}"
    return what


def execute(spec: RunSpec, context: Context) -> dict:
    """Play one run: per frame cull (timed), render (timed, glFinish), error against the truth.

    Returns {"spec", "summary", "frames": {column: list}}: FRAME_COLUMNS measured here, plus
    MODEL_COLUMNS (each device's modelled frame ms); summary["model"] is costmodel.model_block.
    """
    world, trajectory, profile, frames, cameras = _load_frames(spec, context)
    truth = truth_for(spec, context)
    partition, build_seconds = engine.load_structure(world, spec.structure, context.cache_dir)
    view = None
    if spec.lod_tau is not None:  # level of detail: draws the levels, measured against full
        from ..render.lod_view import LodView

        view = LodView(world, engine.load_chains(world, context.cache_dir), profile,
                       spec.lod_tau)
    renderer = view.renderer if view else engine.renderer(world, profile)
    # Warm-up frame (first-use uploads and shader compiles are not part of any frame).
    warm = engine.make_culler(partition, spec.stages, profile).cull(cameras[0])
    renderer.draw(engine.sent_triangles(warm), cameras[0], spec.cull_back)
    culler = engine.make_culler(partition, spec.stages, profile)
    columns = FRAME_COLUMNS + (LOD_COLUMNS if view else ())
    table = {name: np.zeros(len(frames)) for name in columns}
    counters = []
    for row, (frame, camera, visible) in enumerate(zip(frames, cameras, truth)):
        result, cull_ms = engine.timed_cull(culler, camera)
        sent = engine.sent_triangles(result)
        # Min of RENDER_REPEATS draws: drawing is stateless, and the minimum drops the frames
        # where another process took the core (llvmpipe rasterises on the CPU).
        lod = None
        if view:  # the reference (full detail, same culling), the levels, their image error
            lod = view.draw(sent, camera, spec.cull_back)
            cull_ms += lod.lod_ms
            draws = [lod.drawn] + [renderer.draw(lod.selection.triangles, camera, spec.cull_back)
                                   for _ in range(RENDER_REPEATS - 1)]
        else:
            draws = [renderer.draw(sent, camera, spec.cull_back) for _ in range(RENDER_REPEATS)]
        drawn = min(draws, key=lambda d: d.render_ms)
        errors = frame_errors(visible, sent)  # culling's error, on the original triangles
        stats = result.stats
        counters.append(device_counters(result, culler.tree))
        if lod:
            counters[-1]["triangles_sent"] = drawn.triangles
            table["lod_ms"][row] = lod.lod_ms
            table["triangles_full"][row] = len(sent)
            for name in ("psnr_db", "max_diff", "changed"):
                table[name][row] = lod.error[name]
        values = {
            "frame": frame, "cull_ms": cull_ms, "render_ms": drawn.render_ms,
            "frame_ms": cull_ms + drawn.render_ms,
            "triangles_sent": drawn.triangles if lod else len(sent),
            "draw_batches": drawn.draw_batches,
            "nodes_visited": stats.get("nodes_visited", 0),
            "plane_tests": stats.get("plane_tests", 0),
            "triangles_tested": stats.get("triangles_tested", 0), **errors,
            "visible_pixels": int(visible.pixels.sum()),
        }
        for name in FRAME_COLUMNS:
            table[name][row] = values[name]
    for device, column in zip(DEVICES, MODEL_COLUMNS):
        table[column] = frame_model_ms(counters, device)
    summary = summarize_run(table, trajectory, frames, partition, profile, world, build_seconds)
    summary["model"] = model_block(counters)
    bake = engine.bake_stats(world, spec.structure, context.cache_dir)
    if bake is not None:  # a baked PVS: its offline cost, for the report's bake-or-cull table
        summary["pvs"] = bake
    if context.repair != "none":  # the world the run measured (compare --repair)
        summary["repair"] = context.repair
    if view:
        from ..lod.image_error import error_summary

        summary.update(error_summary(table["psnr_db"], table["max_diff"], table["changed"],
                                     spec.lod_tau))
        summary["triangles_full"] = summarize(table["triangles_full"])
        summary["lod_ms"] = summarize(table["lod_ms"])
        # JSON has no infinity: identical frames are recorded as null
        table["psnr_db"] = [None if not np.isfinite(v) else float(v) for v in table["psnr_db"]]
    return {"spec": spec.to_dict(), "summary": summary,
            "frames": {name: list(np.asarray(table[name]).tolist()) if name != "psnr_db"
                       else table[name] for name in columns + MODEL_COLUMNS}}


def summarize_run(table, trajectory, frames, partition, profile, world, build_seconds) -> dict:
    """The per-run row: timings, fps, correlation, error totals, structure size."""
    summary = {name: summarize(table[name])
               for name in ("cull_ms", "render_ms", "frame_ms", "triangles_sent",
                            "draw_batches", "nodes_visited", "tightness")}
    frame_ms = table["frame_ms"]
    summary.update({
        "frames": len(frames),
        "mean_ms": float(frame_ms.mean()),
        "fps": 1000.0 / float(frame_ms.mean()),
        "mean_fps": float(np.mean(1000.0 / np.maximum(frame_ms, 1e-9))),
        "correlation": pearson(frame_ms, table["triangles_sent"]),
        "false_negatives_total": int(table["false_negatives"].sum()),
        "frames_with_fn": int((table["false_negatives"] > 0).sum()),
        "fn_pixels_mean": float(table["fn_pixels"].mean()),
        "fn_pixels_max": int(table["fn_pixels"].max(initial=0)),
        "fn_pixel_fraction": float(table["fn_pixels"].mean() / np.prod(profile.resolution)),
        # of the pixels that show some triangle: over the whole path, and the worst frame
        "fn_visible_fraction": float(table["fn_pixels"].sum()
                                     / max(float(table["visible_pixels"].sum()), 1.0)),
        "fn_visible_fraction_max": float((table["fn_pixels"]
                                          / np.maximum(table["visible_pixels"], 1.0))
                                         .max(initial=0.0)),
        "conservative": bool((table["false_negatives"] == 0).all()),
        "visible_mean": float(table["visible"].mean()),
        "world_triangles": int(world.triangle_count),
        "partition": partition.stats(),
        "build_seconds": build_seconds,
        "waypoints": {label: f for label, f in trajectory.waypoints.items() if f in set(frames)},
    })
    return summary


def _worker_init() -> None:
    """One llvmpipe rasteriser thread in every process that measures runs (the single process,
    pool and Dask workers): parallel runs must not fight for cores, and a run's render_ms must
    not depend on the scheduler. Mesa reads it when the process opens its first GL context."""
    os.environ.setdefault("LP_NUM_THREADS", "1")


def _execute_task(task) -> tuple:
    spec, key, context_tuple = task
    context = Context.from_tuple(context_tuple)
    try:
        record = execute(spec, context)
    except Exception as error:  # one failed run must not end the sweep; it is reported
        return key, {"spec": spec.to_dict(), "error": f"{type(error).__name__}: {error}"}
    record["key"] = key
    atomic_write_bytes(result_path(context, key), json.dumps(record).encode())
    return key, record



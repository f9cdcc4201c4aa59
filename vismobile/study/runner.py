"""Run a comparison matrix in parallel, resumably: one JSON result file per run, keyed by hash.

Phases: (1) the parent makes sure every world's OBJ exists and salts each run's key with the
bytes of its world and trajectory files, so a changed input never reuses a stale result;
(2) workers build the partitions and the ground-truth visible sets each run needs (cached on
disk, shared by every run of the same world, frames, profile and back-face setting);
(3) workers execute the runs. A run whose `runs/<key>.json` exists is read back, not re-run.
Workers are spawned (not forked) so that none inherits another's OpenGL context.
"""
from __future__ import annotations

import json
import multiprocessing
import os
from pathlib import Path

import numpy as np

from ..device.costmodel import DEVICES
from ..progress import Progress
from ..world.world import atomic_write_bytes
from . import engine
from .matrix import RunSpec
from .tasks import (MODEL_COLUMNS, Context, _execute_task, _worker_init, bake_first, prepare,
                    result_path, salts)


def _finished(specs, context: Context) -> tuple:
    """({spec: result key}, {key: record}) with the records of runs already on disk."""
    keyed = {spec: spec.key(salt) for spec, salt in salts(specs, context).items()}
    records = {}
    for spec, key in keyed.items():
        path = result_path(context, key)
        if path.is_file():
            try:
                records[key] = json.loads(path.read_text())
            except (OSError, ValueError):
                pass  # a damaged result is simply run again
    return keyed, records


def _measured_as(spec: RunSpec) -> tuple:
    """A run's identity without its profile's name: the profile counts only as it is measured."""
    from ..errors import ProfileError
    from ..device.profile import get_profile

    try:
        measured = get_profile(spec.profile).measured_as
    except ProfileError:  # runs alone, and its record says why it failed
        measured = spec.profile
    return (spec.world, spec.trajectory, spec.structure, spec.cull, spec.frames, measured,
            spec.lod_tau)


def _twin_record(record: dict, spec: RunSpec, key: str, context: Context) -> dict:
    """The record of `spec` from the record of a run measured alike (written to its own result
    file, so a resumed sweep finds it)."""
    twin = {**record, "spec": spec.to_dict()}
    if "error" in record:
        return twin
    twin.update(key=key, measured_by=record["key"])
    atomic_write_bytes(result_path(context, key), json.dumps(twin).encode())
    return twin


def reusable_runs(specs, context: Context) -> tuple:
    """(finished results on disk that run_matrix will reuse, runs it will execute: one per
    group of the others that differ only in a profile measured alike)."""
    keyed, records = _finished(list(dict.fromkeys(specs)), context)
    todo = {_measured_as(spec) for spec, key in keyed.items() if key not in records}
    return len(records), len(todo)


def run_matrix(specs, context: Context, processes: int | None = None,
               progress: bool = True, scheduler="local", on_record=None) -> list:
    """Run every spec (reusing finished ones); returns their records in spec order.

    A record is {"key", "spec", "summary", "frames"} or {"spec", "error"} for a failed run.
    Also writes <out>/runs.csv and <out>/runs.json (one summary row per run).
    progress  : draw a progress bar on stderr when it is a terminal (False: never)
    scheduler : "local" (a pool of `processes` worker processes), "dask" (a LocalCluster of
                `processes` workers), a Dask scheduler address, or a dask.distributed Client
                (study/distributed.py); results are the same files either way
    on_record : with Dask, called with (client, key, record) as each run finishes
    """
    _worker_init()  # before this process's first GL context (truths, single-process runs)
    specs = list(dict.fromkeys(specs))
    keyed, records = _finished(specs, context)
    # Runs that differ only in a profile measured alike are executed once and recorded for each.
    twins = {}
    for spec in (spec for spec, key in keyed.items() if key not in records):
        twins.setdefault(_measured_as(spec), []).append(spec)
    todo = [group[0] for group in twins.values()]
    processes = max(1, min(processes or os.cpu_count() or 1, len(todo) or 1))
    if todo:
        structures = list({(s.world, s.structure): s for s in todo}.values())
        truths = list({(s.world, s.trajectory, s.profile, s.frames, s.truth_cull_back): s
                       for s in todo}.values())
        local = isinstance(scheduler, str) and scheduler == "local"
        if not local:
            from . import distributed

            context = distributed.absolute(context)
        prep = [("structure", s, context.as_tuple()) for s in structures] + \
               [("truth", s, context.as_tuple()) for s in truths]
        tasks = [(s, keyed[s], context.as_tuple()) for s in todo]
        # The bar counts the preparations too; its label says so, so the totals add up.
        bar = Progress(f"compare: {len(prep)} structures and ground truths, then {len(tasks)} "
                       "runs", enabled=None if progress else False, total=len(prep) + len(tasks))
        if not local:
            records.update(distributed.run_tasks(prep, tasks, scheduler, processes, on_record,
                                                 bar.step, progress))
        elif processes == 1:
            bake_first(prep, None, progress)  # with its progress line
            for task in prep:
                prepare(task)
                bar.step()
            for task in tasks:
                key, record = _execute_task(task)
                records[key] = record
                bar.step()
        else:
            from concurrent.futures import ProcessPoolExecutor

            with ProcessPoolExecutor(processes, multiprocessing.get_context("spawn")) as bakers:
                bake_first(prep, bakers, progress)  # PVS bakes over the workers, cached
            with multiprocessing.get_context("spawn").Pool(processes, _worker_init) as pool:
                for _ in pool.imap_unordered(prepare, prep):
                    bar.step()
                for key, record in pool.imap_unordered(_execute_task, tasks):
                    records[key] = record
                    bar.step()
        bar.close()
    for first, *rest in twins.values():
        for spec in rest:
            records[keyed[spec]] = _twin_record(records[keyed[first]], spec, keyed[spec], context)
    ordered = [records[keyed[spec]] for spec in specs]
    write_tables(ordered, context.out)
    return ordered


# mean_ms .. render_ms are measured here; model_ms:<device> is that device's model
# (vismobile/device/costmodel.py) of the same frames' counters.
SUMMARY_COLUMNS = ("world", "structure", "cull", "profile", "frames", "mean_ms", "fps",
                   "mean_fps", "cull_ms", "render_ms") + MODEL_COLUMNS + (
                   "triangles_sent", "correlation", "false_negatives_total", "frames_with_fn",
                   "fn_pixels_mean", "tightness", "conservative", "key", "error",
                   "lod_tau", "psnr_db_min", "psnr_db_mean")


def summary_row(record: dict) -> dict:
    """A flat row of one record, for runs.csv."""
    spec = record["spec"]
    row = {name: spec.get(name, "") for name in ("world", "structure", "cull", "profile")}
    if "error" in record:
        row["error"] = record["error"]
        return row
    s = record["summary"]
    row.update({"frames": s["frames"], "mean_ms": s["mean_ms"], "fps": s["fps"],
                "mean_fps": s["mean_fps"], "cull_ms": s["cull_ms"]["mean"],
                "render_ms": s["render_ms"]["mean"],
                "triangles_sent": s["triangles_sent"]["mean"], "correlation": s["correlation"],
                "false_negatives_total": s["false_negatives_total"],
                "frames_with_fn": s["frames_with_fn"], "fn_pixels_mean": s["fn_pixels_mean"],
                "tightness": s["tightness"]["mean"], "conservative": s["conservative"],
                "key": record.get("key", ""), "error": ""})
    for device, column in zip(DEVICES, MODEL_COLUMNS):
        row[column] = s["model"][device]["frame_ms"]["mean"]
    if spec.get("lod_tau") is not None:  # level of detail (compare --lod; null: identical)
        row.update({name: s.get(name) for name in ("lod_tau", "psnr_db_min", "psnr_db_mean")})
    return row


def write_tables(records, out) -> None:
    """<out>/runs.csv and <out>/runs.json: every run's summary row, atomically."""
    out = Path(out)
    rows = [summary_row(r) for r in records]
    lines = [",".join(SUMMARY_COLUMNS)]
    for row in rows:
        cells = []
        for name in SUMMARY_COLUMNS:
            value = row.get(name, "")
            cells.append(f"{value:.6g}" if isinstance(value, float) else
                         str(value).replace(",", ";"))
        lines.append(",".join(cells))
    atomic_write_bytes(out / "runs.csv", ("\n".join(lines) + "\n").encode())
    atomic_write_bytes(out / "runs.json", (json.dumps(rows, indent=1) + "\n").encode())


def agreement(world_name: str, context: Context, profile: str = "ipaq-hx2490b",
              samples: int = 3, trajectory=None) -> list:
    """Raster-against-ray-cast agreement on `samples` evenly spaced frames, back faces culled
    and not: a list of compare_truths dicts with world, frame and cull_back added."""
    from ..device.profile import get_profile
    from ..world.trajectory import Trajectory
    from .groundtruth import compare_truths
    from .thesis import trajectory_for

    world = engine.load_world(world_name, context.worlds_dir, context.repair)
    path = Path(trajectory or trajectory_for(world_name))
    path = path if path.is_absolute() else context.root / path
    track = Trajectory.load(path)
    prof = get_profile(profile)
    frames = np.linspace(0, len(track) - 1, samples + 2).round().astype(int)[1:-1]
    results = []
    for frame in frames:
        camera = track.camera(int(frame), prof.aspect)
        for back in (False, True):
            raster = engine.item_buffer_fn(world, prof, back)(camera)
            item = compare_truths(world, camera, raster, cull_back=back)
            item.update({"world": world_name, "frame": int(frame), "cull_back": back})
            results.append(item)
    return results

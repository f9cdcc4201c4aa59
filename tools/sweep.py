"""The full chapter-5 matrix, and the check that `vismobile tune` picks the best or within 10%.

Run from the repository root (about 15-25 minutes on a 2-core machine with sample:24):

    .venv/bin/python tools/sweep.py                       # all six worlds, iPaq profile
    .venv/bin/python tools/sweep.py --worlds w1,w2 --frames sample:12 --confirm 4

Per world it (1) runs `tune` (probe frames, cost model), (2) runs the whole matrix through the
resumable runner (every structure and depth, the 8 thesis combinations plus ours) on a reduced
frame sample, (3) re-measures the sweep's K fastest zero-false-negative configurations and
tune's choice side by side in one process, interleaved frame by frame over several rounds, so
that load from other processes hits all of them alike, and reports tune's gap to the best.
Writes out/sweep/{runs.csv, runs.json, report.html, tune_check.json, w2_pareto.png}.

Under a device model (a few minutes; no rendering, the device model prices counters):

    .venv/bin/python tools/sweep.py --device --profile ipaq-hx2490b   # or nokia-n82
    .venv/bin/python tools/sweep.py --fit-device                      # refit the device figures

--device runs tune (device model) per world, then every structure x combination on more and
other frames (sample:32) under the same model, plus every subset of the stages tune
toggles, and reports tune's pick, the sweep's best, the
gap, and the thesis's best configuration (its ms beside our model's) per world; it writes
out/sweep/device_<profile>.json. --fit-device prints the device fits (costmodel.fit_device)
of thesis.DEVICE_POINTS on our counters, with their errors.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))


def paired_measure(world, trajectory, profile, configs, frames, rounds, cache_dir) -> dict:
    """{(structure, cull): mean frame ms} measured interleaved: per round, per frame, every
    config culls (timed) and renders (min of two draws, timed) before the next frame."""
    from vismobile.study import engine
    from vismobile.study.matrix import cull_stages

    cameras = [trajectory.camera(f, profile.aspect) for f in frames]
    renderer = engine.renderer(world, profile)
    totals = {config: [] for config in configs}
    for round_index in range(rounds):
        cullers = {c: engine.make_culler(engine.load_structure(world, c[0], cache_dir)[0],
                                         cull_stages(c[1])) for c in configs}
        order = list(configs)
        for camera in cameras:
            order = order[1:] + order[:1]  # rotate so no config always runs first
            for config in order:
                result, cull_ms = engine.timed_cull(cullers[config], camera)
                sent = engine.sent_triangles(result)
                back = "bfc" in cull_stages(config[1])
                render = min(renderer.draw(sent, camera, back).render_ms for _ in range(2))
                totals[config].append(cull_ms + render)
    return {config: float(np.mean(times)) for config, times in totals.items()}


def fit_devices() -> int:
    """Print every device fit (triangles alone, and with each draw-call counter) and the rows."""
    from vismobile.device.profile import get_profile
    from vismobile.study.costmodel import best_device_fit, calibration_rows, cull_cycles
    from vismobile.study.thesis import DEVICE_HELD_OUT, DEVICE_POINTS

    for name, points in DEVICE_POINTS.items():
        cost = get_profile(name).cost
        rows = calibration_rows(points, cache_dir="out/cache")
        chosen, fits = best_device_fit(rows, [p[3] for p in points], cost.float_op_cycles,
                                       cost.clock_mhz)
        print(f"{name}: {len(points)} points")
        for fit in fits:
            print(f"  calls {str(fit['call_counter']):13s} base {fit['base_ms']:7.2f} ms, "
                  f"{fit['triangle_us']:7.3f} us/triangle, {fit['call_us']:7.2f} us/call: fit "
                  f"{fit['fit_error']:.1%}, leave-one-out {fit['loo_error']:.1%} (worst "
                  f"{fit['loo_max']:.1%}){'  <- chosen' if fit is chosen else ''}")
        for point, row, predicted in zip(points, rows, chosen["predicted_ms"]):
            print(f"  {point[0]} {point[1]:9s} {point[2]:14s} thesis {point[3]:7.1f} ms, model "
                  f"{predicted:7.1f} ms; {row['triangles_sent']:8.1f} triangles, "
                  f"{row['nodes_drawn']:6.1f} draw nodes")
        held = DEVICE_HELD_OUT.get(name, [])
        for point, row in zip(held, calibration_rows(held, cache_dir="out/cache")):
            counter = chosen["call_counter"]
            model = (chosen["base_ms"] + chosen["triangle_us"] * 1e-3 * row["triangles_sent"]
                     + chosen["call_us"] * 1e-3 * (row.get(counter, 0) if counter else 0)
                     + cull_cycles(row, cost.float_op_cycles) / (cost.clock_mhz * 1e3))
            print(f"  held out: {point[0]} {point[1]} {point[2]} thesis {point[3]:.1f} ms, "
                  f"model {model:.1f} ms ({point[4]})")
    return 0


def device_check(args) -> int:
    """tune against a full sweep, both under the profile's device model, on every world."""
    from vismobile.device.profile import get_profile
    from vismobile.study import engine
    from vismobile.study.matrix import THESIS_CULLS, cull_stages, parse_worlds
    from vismobile.study.metrics import pearson
    from vismobile.study.thesis import IPAQ_BEST, N82_FPS, trajectory_for
    from vismobile.study.tune import sweep, tune
    from vismobile.world.trajectory import Trajectory
    from vismobile.world.world import atomic_write_bytes

    profile = get_profile(args.profile)
    frames = args.frames if args.frames != "sample:24" else "sample:32"
    checks = []
    for name in parse_worlds(args.worlds):
        world = engine.load_world(name, "worlds")
        trajectory = Trajectory.load(trajectory_for(name))
        picked = tune(world, trajectory, profile, probe=args.probe, structures=args.structures,
                      cache_dir="out/cache")
        full = sweep(world, trajectory, profile, frames, args.structures, cache_dir="out/cache")
        table = {(c.structure, c.cull): c for c in full.candidates}
        mine = table[(picked.choice.structure, picked.choice.cull)]  # every subset is swept
        best = full.choice
        ref = IPAQ_BEST[name]
        at_ref = table.get((ref["structure"], ref["cull"]))
        thesis_ms = ref["mean_ms"] if profile.name != "nokia-n82" else 1000.0 / N82_FPS[name]
        safe = [c for c in full.ranked() if c.false_negatives == 0]
        per_structure, thesis_only = {}, {}
        for cand in safe:
            per_structure.setdefault(cand.structure, cand)
            if cand.cull in THESIS_CULLS:
                thesis_only.setdefault(cand.structure, cand)
        model = full.model
        ref_ms = [model.frame_ms(row, "bfc" in cull_stages(ref["cull"]))
                  for row in at_ref.frame_rows] if at_ref else []
        ref_tris = [row["triangles_sent"] for row in at_ref.frame_rows] if at_ref else []
        check = {
            "world": name, "profile": profile.name, "frames": len(full.frames),
            "tune_choice": [mine.structure, mine.cull], "tune_ms": mine.frame_ms,
            "tune_predicted_on_probe_ms": picked.choice.frame_ms,
            "tune_seconds": picked.seconds, "sweep_seconds": full.seconds,
            "sweep_best": [best.structure, best.cull], "sweep_best_ms": best.frame_ms,
            "gap": mine.frame_ms / best.frame_ms - 1.0,
            "thesis_best": [ref["structure"], ref["cull"]], "thesis_ms": thesis_ms,
            "model_at_thesis_best_ms": at_ref.frame_ms if at_ref else None,
            "model_r_at_thesis_best": pearson(np.array(ref_ms), np.array(ref_tris))
            if len(ref_ms) > 2 else None,
            "thesis_r": ref["correlation"],
            "best_per_structure": {k: [c.cull, c.frame_ms] for k, c in per_structure.items()},
            "best_per_structure_thesis_culls": {k: [c.cull, c.frame_ms]
                                                for k, c in thesis_only.items()},
            "candidates": len(full.candidates),
            "unsafe": sum(c.false_negatives > 0 for c in full.candidates),
        }
        checks.append(check)
        order = " < ".join(f"{k} {v[1]:.0f}" for k, v in
                           check["best_per_structure_thesis_culls"].items())
        at_ms = check["model_at_thesis_best_ms"] or float("nan")
        at_r = check["model_r_at_thesis_best"] or float("nan")
        print(f"{name}: tune {mine.structure} {mine.cull} {mine.frame_ms:.1f} ms "
              f"({picked.seconds:.1f} s); sweep best {best.structure} {best.cull} "
              f"{best.frame_ms:.1f} ms; gap {check['gap']:+.1%}; thesis {ref['structure']} "
              f"{ref['cull']} {thesis_ms:.1f} ms, model there "
              f"{at_ms:.1f} ms (r {at_r:.2f} vs thesis {ref['correlation']})\n"
              f"  thesis combinations only, best per structure: {order}", flush=True)
    path = args.out / f"device_{profile.name}.json"
    atomic_write_bytes(path, json.dumps(checks, indent=1).encode())
    print(f"written {path}")
    return 0


def main(argv=None) -> int:
    from vismobile.device.profile import get_profile
    from vismobile.study import engine
    from vismobile.study.matrix import RunSpec, expand, parse_worlds
    from vismobile.study.report import pareto_png, write_report
    from vismobile.study.runner import Context, agreement, run_matrix
    from vismobile.study.thesis import trajectory_for
    from vismobile.study.tune import tune
    from vismobile.world.trajectory import Trajectory
    from vismobile.world.world import atomic_write_bytes

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--worlds", default="all")
    parser.add_argument("--structures", default="grid,octree:3-6,portal:1-3,bsp")
    parser.add_argument("--cull", default="all")
    parser.add_argument("--profile", default="ipaq-hx2490b")
    parser.add_argument("--frames", default="sample:24")
    parser.add_argument("--probe", type=int, default=16, help="tune's probe frames")
    parser.add_argument("--confirm", type=int, default=5,
                        help="top configurations re-measured beside tune's choice")
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--jobs", type=int, default=None)
    parser.add_argument("--out", type=Path, default=Path("out/sweep"))
    parser.add_argument("--device", action="store_true",
                        help="check tune against a sweep under the profile's device model")
    parser.add_argument("--fit-device", action="store_true",
                        help="print the device model fits to the thesis's device figures")
    args = parser.parse_args(argv)
    if args.fit_device:
        return fit_devices()
    if args.device:
        return device_check(args)

    profile = get_profile(args.profile)
    context = Context(".", args.out, "worlds", "out/cache")
    worlds = parse_worlds(args.worlds)
    tunes = {}
    for name in worlds:
        world = engine.load_world(name, "worlds")
        trajectory = Trajectory.load(trajectory_for(name))
        # Cold: tune builds its own partitions (no cache), as a first run would.
        tunes[name] = tune(world, trajectory, profile, probe=args.probe, cost="measured")
        print(f"tune {name}: {tunes[name].choice.structure} {tunes[name].choice.cull} "
              f"({tunes[name].seconds:.1f} s)", flush=True)
    specs = expand(args.worlds, args.structures, args.cull, args.profile, args.frames)
    specs += [RunSpec(n, trajectory_for(n), t.choice.structure, t.choice.cull, args.profile,
                      args.frames) for n, t in tunes.items()]
    start = time.perf_counter()
    records = run_matrix(specs, context, args.jobs)
    print(f"sweep: {len(records)} runs in {time.perf_counter() - start:.0f} s", flush=True)

    checks = []
    for name in worlds:
        world = engine.load_world(name, "worlds")
        trajectory = Trajectory.load(trajectory_for(name))
        runs = [r for r in records if "summary" in r and r["spec"]["world"] == name
                and r["summary"]["conservative"]]
        runs.sort(key=lambda r: r["summary"]["mean_ms"])
        choice = (tunes[name].choice.structure, tunes[name].choice.cull)
        configs = list(dict.fromkeys([(r["spec"]["structure"], r["spec"]["cull"])
                                      for r in runs[:args.confirm]] + [choice]))
        frames = [int(f) for f in runs[0]["frames"]["frame"]]
        measured = paired_measure(world, trajectory, profile, configs, frames, args.rounds,
                                  context.cache_dir)
        best = min(measured, key=measured.get)
        sweep_ms = {(r["spec"]["structure"], r["spec"]["cull"]): r["summary"]["mean_ms"]
                    for r in runs}
        checks.append({
            "world": name, "tune_choice": list(choice), "tune_seconds": tunes[name].seconds,
            "tune_predicted_ms": tunes[name].choice.frame_ms,
            "tune_ms": measured[choice], "best": list(best), "best_ms": measured[best],
            "gap": measured[choice] / measured[best] - 1.0,
            "sweep_best": [runs[0]["spec"]["structure"], runs[0]["spec"]["cull"]],
            "sweep_best_ms": runs[0]["summary"]["mean_ms"],
            "sweep_tune_ms": sweep_ms.get(choice),
            "confirmed": {f"{s} {c}": ms for (s, c), ms in measured.items()}})
        c = checks[-1]
        print(f"{name}: tune {choice[0]} {choice[1]} {c['tune_ms']:.2f} ms; best {best[0]} "
              f"{best[1]} {c['best_ms']:.2f} ms; gap {c['gap']:+.1%} (tune {c['tune_seconds']:.1f}"
              " s)", flush=True)
    atomic_write_bytes(args.out / "tune_check.json", json.dumps(checks, indent=1).encode())
    agree = []
    for name in worlds:
        agree += agreement(name, context, args.profile, samples=3)
    atomic_write_bytes(args.out / "agreement.json", json.dumps(agree, indent=1).encode())
    sections = [{"world": n, "text": t.report(), "result": t.to_dict()}
                for n, t in tunes.items()]
    report = write_report(records, args.out / "report.html", agreement=agree, tunes=sections,
                          title="vismobile sweep: the chapter-5 matrix",
                          notes=f"Frames {args.frames} of each path, profile {args.profile}.")
    if "w2" in worlds:
        pareto_png(records, "w2", args.profile, args.out / "w2_pareto.png")
    print(f"report: {report}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

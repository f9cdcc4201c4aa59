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


def main(argv=None) -> int:
    from vismobile.profile import get_profile
    from vismobile.study import engine
    from vismobile.study.matrix import RunSpec, expand, parse_worlds
    from vismobile.study.report import pareto_png, write_report
    from vismobile.study.runner import Context, agreement, run_matrix
    from vismobile.study.thesis import trajectory_for
    from vismobile.study.tune import tune
    from vismobile.trajectory import Trajectory
    from vismobile.world import atomic_write_bytes

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
    args = parser.parse_args(argv)

    profile = get_profile(args.profile)
    context = Context(".", args.out, "worlds", "out/cache")
    worlds = parse_worlds(args.worlds)
    tunes = {}
    for name in worlds:
        world = engine.load_world(name, "worlds")
        trajectory = Trajectory.load(trajectory_for(name))
        # Cold: tune builds its own partitions (no cache), as a first run would.
        tunes[name] = tune(world, trajectory, profile, probe=args.probe)
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
    sections = [{"world": n, "text": t.report()} for n, t in tunes.items()]
    report = write_report(records, args.out / "report.html", agreement=agree, tunes=sections,
                          title="vismobile sweep: the chapter-5 matrix",
                          notes=f"Frames {args.frames} of each path, profile {args.profile}.")
    if "w2" in worlds:
        pareto_png(records, "w2", args.profile, args.out / "w2_pareto.png")
    print(f"report: {report}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""`make demo`: tune W1 and W2, run a reduced comparison on both, write out/report/index.html.

tune picks for the iPaq by the device cost model (fitted to the thesis's own timings); the
comparison measures wall time on this machine, so the last lines set the two side by side.

Builds the thesis worlds first if worlds/ lacks them. The comparison is the thesis's matrix cut
down to fit a few minutes on a 2-core machine: 16 evenly spaced frames plus the waypoints of the
indoor path, the thesis's 8 culling combinations plus three of ours (occlusion, and portals on
the portal octree), six structures (each thesis structure, octree depths 3-5), the iPaq
profile; tune searches the same six structures, so its pick is always among the measured runs.
`vismobile compare` runs the full matrix, `vismobile tune` searches every structure.
"""
from __future__ import annotations

import sys
import time
from pathlib import Path

WORLDS = ("w1", "w2")
STRUCTURES = "grid,octree:3-5,portal:1,bsp"
CULLS = "thesis,vfc+bfc+occlusion,vfc+bfc+cbfc+occlusion,vfc+bfc+cbfc+portals"
FRAMES = "sample:16"
PROBE = 12  # tune's probe frames (plus the waypoints)
PROFILE = "ipaq-hx2490b"


def tune_gap(result, records) -> str:
    """Where tune's device choice landed in this machine's measured comparison of the world."""
    from ..study.report import best_run, find_run

    choice = result.choice
    run = find_run(records, result.world, choice.structure, choice.cull, PROFILE)
    best = best_run(records, result.world, PROFILE)
    if run is None or best is None:
        return "tune's choice was not measured in the comparison"
    ms, top = run["summary"]["mean_ms"], best["summary"]["mean_ms"]
    return (f"on this machine (wall time, not the device model) tune's iPaq choice ran "
            f"{ms:.2f} ms/frame; the fastest measured here (zero false negatives): "
            f"{best['spec']['structure']} {best['spec']['cull']} {top:.2f} ms")


def main(argv=None) -> int:
    from ..device.costmodel import label
    from ..device.profile import get_profile
    from ..progress import Status
    from ..study import engine
    from ..study.matrix import RunSpec, expand
    from ..study.report import write_report
    from ..study.runner import Context, agreement, run_matrix
    from ..study.thesis import trajectory_for
    from ..study.tune import tune
    from ..world.trajectory import Trajectory

    start = time.perf_counter()
    out = Path("out")
    context = Context(".", out / "demo", None, out / "cache")
    print("1/4 worlds: " + ", ".join(f"{engine.ensure_world_file(w, context.worlds_dir)}"
                                     for w in WORLDS))
    tunes = []
    for world_name in WORLDS:
        world = engine.load_world(world_name, context.worlds_dir)
        trajectory = Trajectory.load(trajectory_for(world_name))
        with Status(f"2/4 tune {world_name}") as status:
            status(f"ground truth of the probe frames ({world.triangle_count:,} triangles)")
            result = tune(world, trajectory, get_profile(PROFILE), probe=PROBE,
                          structures=STRUCTURES, cache_dir=context.cache_dir,
                          progress=lambda done, _: status(f"{done} structure(s) probed"))
        tunes.append(result)
        c = result.choice
        print(f"2/4 tune {world_name} ({label(PROFILE)}): --structure {c.structure} --cull "
              f"{c.cull}, {c.frame_ms:.1f} ms [{c.low_ms:.1f}-{c.high_ms:.1f}]"
              f" = {c.fps:.1f} fps, {len(result.tied)} tied ({result.seconds:.1f} s)")
    specs = expand(",".join(WORLDS), STRUCTURES, CULLS, PROFILE, FRAMES)
    specs += [RunSpec(r.world, trajectory_for(r.world), r.choice.structure, r.choice.cull,
                      PROFILE, FRAMES) for r in tunes]
    print(f"3/4 compare: {len(dict.fromkeys(specs))} runs on {FRAMES} frames (the bar also "
          "counts the structures and ground truths they need)")
    records = run_matrix(specs, context)
    checks = []
    for world_name in WORLDS:
        checks += agreement(world_name, context, PROFILE, samples=2)
    sections = [{"world": r.world, "text": r.report() + "\n" + tune_gap(r, records),
                 "result": r.to_dict()} for r in tunes]
    report = write_report(records, out / "report" / "index.html", agreement=checks,
                          tunes=sections, title="vismobile demo: W1 and W2",
                          notes=f"Reduced comparison: {FRAMES} frames of the indoor path, "
                                f"structures {STRUCTURES}, profile {PROFILE}.")
    for section in sections:
        print(f"4/4 {section['world']}: " + section["text"].splitlines()[-1])
    print(f"report: {report.resolve()}  (runs: {context.out.resolve()}/runs.csv; "
          f"{time.perf_counter() - start:.0f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())

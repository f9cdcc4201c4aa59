"""Is tune's pick stable to the probe size? tune every world at several probe sizes.

    .venv/bin/python tools/tune_stability.py [--worlds all] [--probes 16,24,48]
        [--profile ipaq-hx2490b] [--out out/tune_stability.json]

Prints, per world and probe size, the pick with its 95% interval, the fastest point estimate
and how many candidates were statistically tied, then whether every probe size picked the
same configuration. Partitions and ground truths are cached in out/cache between runs.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path


def main(argv=None) -> int:
    from vismobile.device.profile import get_profile
    from vismobile.study import engine
    from vismobile.study.matrix import parse_worlds
    from vismobile.study.thesis import trajectory_for
    from vismobile.study.tune import tune
    from vismobile.world.trajectory import Trajectory
    from vismobile.world.world import atomic_write_bytes

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--worlds", default="all")
    parser.add_argument("--probes", default="16,24,48")
    parser.add_argument("--profile", default="ipaq-hx2490b")
    parser.add_argument("--cache", type=Path, default=Path("out/cache"))
    parser.add_argument("--out", type=Path, default=Path("out/tune_stability.json"))
    args = parser.parse_args(argv)
    profile = get_profile(args.profile)
    probes = [int(p) for p in args.probes.split(",")]
    rows, stable = [], {}
    for name in parse_worlds(args.worlds):
        world = engine.load_world(name, "worlds")
        trajectory = Trajectory.load(trajectory_for(name))
        picks = []
        for probe in probes:
            start = time.perf_counter()
            result = tune(world, trajectory, profile, probe=probe, cache_dir=args.cache)
            c, f = result.choice, result.fastest
            picks.append((c.structure, c.cull))
            rows.append({"world": name, "probe": probe, "frames": len(result.frames),
                         "choice": f"{c.structure} {c.cull}", "ms": c.frame_ms,
                         "low_ms": c.low_ms, "high_ms": c.high_ms,
                         "fastest": f"{f.structure} {f.cull}", "fastest_ms": f.frame_ms,
                         "tied": len(result.tied), "seconds": time.perf_counter() - start})
            r = rows[-1]
            print(f"{name} probe {probe:3d} ({r['frames']} frames): {r['choice']:40s} "
                  f"{r['ms']:7.1f} ms [{r['low_ms']:.1f}-{r['high_ms']:.1f}]  fastest "
                  f"{r['fastest']} {r['fastest_ms']:.1f} ms, {r['tied']} tied "
                  f"({r['seconds']:.0f} s)", flush=True)
        stable[name] = len(set(picks)) == 1
        print(f"{name}: {'stable' if stable[name] else 'NOT stable'} over probes "
              f"{args.probes}", flush=True)
    atomic_write_bytes(args.out, json.dumps({"profile": profile.name, "rows": rows,
                                             "stable": stable}, indent=1).encode())
    print(f"all stable: {all(stable.values())}; wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

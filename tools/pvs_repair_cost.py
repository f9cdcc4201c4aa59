"""What repairing T-junctions costs the indoor PVS target (issue 29: pvs+vfc+tbfc sends at most
0.5x what vfc+tbfc sends along the W1-W4 path).

    .venv/bin/python tools/pvs_repair_cost.py [--worlds w1,w2,w3,w4] [--stride 1] [--jobs 2]
                                              [--cache DIR] [--sampled 0]

`--repair tjunctions` splits every triangle whose edge passes another's vertex, so the
rasteriser opens no crack along the creases and the conservative bake seals the rooms; but the
repaired world has more triangles, and vfc+tbfc sends more of them. Per world, over every
--stride-th frame of the indoor path (ipaq-hx2490b's aspect): the triangle counts as built and
repaired, vfc+tbfc's triangles on each, and the repaired world's default conservative bake
(portal:2, budget as shipped; cached in DIR as <world>-repaired.vmp) through pvs+vfc+tbfc, as a
ratio to vfc+tbfc on the same (repaired) world and on the world as built. With --sampled N,
also the share of vfc+tbfc's triangles that item buffers from N jittered points of the eye's
view cell see (six 90-degree views each, no back-face culling: a from-cell set sampled, so a
lower bound of any conservative set) and that the eye's own item buffer sees.
"""
from __future__ import annotations

import argparse
import dataclasses
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from vismobile.culling import Culler  # noqa: E402
from vismobile.device.profile import get_profile  # noqa: E402
from vismobile.errors import VisMobileError  # noqa: E402
from vismobile.files.loader import repaired  # noqa: E402
from vismobile.partition import load_partition, partition, pvs, save_partition  # noqa: E402
from vismobile.render import SENTINEL, item_buffer  # noqa: E402
from vismobile.render.pvs_sampled import RESOLUTION, seen_from  # noqa: E402
from vismobile.scenes import build_world  # noqa: E402
from vismobile.world.trajectory import Trajectory  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
PROFILE = get_profile("ipaq-hx2490b")


def baked(world, path, jobs):
    """The repaired world's portal:2 partition with its default conservative PVS, from path or
    baked and saved there."""
    if path.exists():
        try:
            return load_partition(path, world)
        except VisMobileError:
            pass  # another revision's or world's file: bake again
    part = partition(world, "portal", depth=2)
    part.params["pvs"] = "conservative"
    extras, _ = pvs.bake(part, jobs=jobs)
    part.extras.update(extras)
    save_partition(part, path)
    return part


def seen_from_cell(world, lo, hi, samples, rng) -> np.ndarray:
    """(T,) bool: what item buffers from `samples` jittered points in [lo, hi] show."""
    cube = dataclasses.replace(PROFILE, resolution=(RESOLUTION, RESOLUTION))
    return seen_from(world, lo + rng.uniform(0.0, 1.0, (samples, 3)) * (hi - lo), cube)


def run(name, stride, jobs, cache, samples):
    built = build_world(name)
    world = repaired(built, "tjunctions")
    part = baked(world, Path(cache) / f"{name}-repaired.vmp", jobs)
    traj = Trajectory.load(ROOT / "trajectories" / "indoor.csv")
    cams = [traj.camera(f, PROFILE.aspect) for f in range(0, len(traj), stride)]
    base_built = Culler(partition(built, "portal", depth=2), "vfc+tbfc")
    base, culled = Culler(part, "vfc+tbfc"), Culler(part, "pvs+vfc+tbfc")
    sent_built = sum(len(base_built.cull(c).triangles) for c in cams)
    sent_base = sum(len(base.cull(c).triangles) for c in cams)
    sent_pvs = sum(len(culled.cull(c).triangles) for c in cams)
    line = (f"{name}: triangles {built.triangle_count:,} as built, {world.triangle_count:,} "
            f"repaired ({world.triangle_count / built.triangle_count:.3f}x); {len(cams)} path "
            f"frames, vfc+tbfc repaired / as built {sent_base / sent_built:.3f}x; repaired "
            f"pvs+vfc+tbfc / vfc+tbfc {sent_pvs / sent_base:.3f}x on the repaired world, "
            f"{sent_pvs / sent_built:.3f}x against the world as built")
    if samples:
        boxes = part.extras["pvs_cells"]
        rng, sets, in_cell, visible = np.random.default_rng(0), {}, 0, 0
        for cam in cams:
            tris = base.cull(cam).triangles
            inside = np.all((boxes[:, 0] <= cam.position) & (cam.position <= boxes[:, 1]), axis=1)
            cell = int(np.flatnonzero(inside)[0]) if inside.any() else -1
            if cell not in sets:
                sets[cell] = (seen_from_cell(world, *boxes[cell], samples, rng) if cell >= 0
                              else np.ones(world.triangle_count, dtype=bool))
            in_cell += int(sets[cell][tris].sum())
            ids = np.unique(item_buffer(world, None, cam, PROFILE))
            visible += int(np.count_nonzero(ids != SENTINEL))
        line += (f"; of vfc+tbfc's triangles, {samples} points of the eye's cell see "
                 f"{in_cell / sent_base:.3f}, the eye {visible / sent_base:.3f}")
    print(line, flush=True)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--worlds", default="w1,w2,w3,w4")
    parser.add_argument("--stride", type=int, default=1, help="every Nth path frame (>= 1)")
    parser.add_argument("--jobs", type=int, default=2, help="bake processes (>= 1)")
    parser.add_argument("--cache", default="/tmp/pvs_repair_cost")
    parser.add_argument("--sampled", type=int, default=0,
                        help="points per view cell for the sampled from-cell set (0: none)")
    args = parser.parse_args(argv)
    worlds = [w for w in args.worlds.split(",") if w]
    if args.stride < 1 or args.jobs < 1 or args.sampled < 0 or not worlds or any(
            w not in ("w1", "w2", "w3", "w4") for w in worlds):
        parser.error("--worlds from w1..w4 (indoor), --stride >= 1, --jobs >= 1, --sampled >= 0")
    Path(args.cache).mkdir(parents=True, exist_ok=True)
    for name in worlds:
        run(name, args.stride, args.jobs, args.cache, args.sampled)
    return 0


if __name__ == "__main__":
    sys.exit(main())

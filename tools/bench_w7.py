"""W7 benchmark (issue 25): the hybrid world's path, its doors, regional culling, and the viewer
with moving objects.

    .venv/bin/python tools/bench_w7.py [--step 10] [--pvs] [--viewer 1000] [--skip-drops]
                                       [--wall-cells] [--door-stages portals] [--where 10]

Sections 1 and 3 partition W7 by portal:2 (automatic cells; --wall-cells: walls=True, cells
on both faces of every wall, a room per storey, `portals` following the rasteriser's cracks
there: culling/portal_cracks.py, docs/dynamic.md).
1. dropped: every conservative combination (tests/culling/test_conservative.COMBOS) on every
   --step-th frame of trajectories/hybrid.csv at t = f / 30 s, doors on their schedule, against
   the item buffer of that frame's pose (back faces culled in it when a backface stage is on).
2. doors: triangles `portals` (or --door-stages) sends (portal:2 over the static part, moving
   objects through culling/moving.py) on every other frame, with every door shut and with the
   scheduled doors, each against every door open; summed over the whole path, over the frames
   inside the building, over the street frames, and over the frames 2 m from the shut door
   into room (2, 0) (frames 600-616); over both cell layouts, wall cells with and without the
   crack slivers (LAYOUTS).
3. regional: RegionalCuller (portals+tbfc | vfc+occlusion+tbfc, with --pvs also
   pvs+vfc+tbfc over a conservative bake) against each fixed choice, every --step-th frame:
   triangles sent and iPaq-model ms summed (regional's probe culls added), and which choice
   each region kept.
5. where (--where STEP, alone): the triangles sent with every door shut and every door open,
   by what they are (the building's inside, its outside, the city, doors, people and cars),
   on the street and inside, over both cell layouts, beside the item buffer's visible set.
4. viewer: W7 with --viewer moving people added (walking loops on the streets), rendered by
   the viewer's own frame function (Session.render, headless) along the path: median and p95
   ms per frame (cull + pose upload + draw + HUD), after a warm-up; and the same for W7's own
   67 moving objects, and for W7 frozen (no motion) as the baseline, interleaved.
"""
from __future__ import annotations

import argparse
import importlib.util
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from vismobile.culling import Culler, parse_stages  # noqa: E402
from vismobile.culling.regional import RegionalCuller  # noqa: E402
from vismobile.device.profile import get_profile  # noqa: E402
from vismobile.partition import partition  # noqa: E402
from vismobile.render import SENTINEL, item_buffer  # noqa: E402
from vismobile.scenes import build_world  # noqa: E402
from vismobile.scenes.thesis import motion_path, write_motion  # noqa: E402
from vismobile.world.animated import AnimatedWorld  # noqa: E402
from vismobile.world.trajectory import Trajectory  # noqa: E402

PROFILE = get_profile("ipaq-hx2490b")
PATH = ROOT / "trajectories" / "hybrid.csv"
FPS = 30.0
INSIDE = (460, 888)  # frames between the walker's entrance crossings
FACING = (600, 617)  # 2 m from the door into room (2, 0), facing it
# the portal octree's cells: automatic (portal.py's default) or on both faces of every wall
# (walls=true), and whether `portals` follows the cracks (culling/portal_cracks.py; None: its
# default, on over wall cells)
LAYOUTS = {"automatic": (False, None), "wall": (True, None),
           "wall, no crack slivers": (True, False)}
_PARTS = {}


def portal_part(world, doors: str, walls: bool):
    """portal:2 over `world` (its doors' schedule named `doors`), built once per run."""
    if (doors, walls) not in _PARTS:
        _PARTS[doors, walls] = partition(world, "portal", depth=2, walls=walls)
    return _PARTS[doors, walls]


def combos():
    spec = importlib.util.spec_from_file_location(
        "conservative", ROOT / "tests" / "culling" / "test_conservative.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.COMBOS, module.OPTIONS


def animated(doors: str, folder: Path) -> AnimatedWorld:
    path = folder / f"w7_{doors}.json"
    write_motion("w7", path, doors=doors)
    return AnimatedWorld.from_motion_file(build_world("w7"), path)


def dropped(part, step: int) -> dict:
    from vismobile.culling import BACKFACE_STAGES

    names, options = combos()
    cullers = {c: Culler(part, c, **options.get(c, {})) for c in names}
    path = Trajectory.load(PATH)
    out = {c: 0 for c in names}
    frames = range(0, len(path), step)
    for f in frames:
        cam, t = path.camera(f, PROFILE.aspect), f / FPS
        posed = part.animated.posed(t)
        truth = {}
        for combo, culler in cullers.items():
            back = bool(set(BACKFACE_STAGES) & set(parse_stages(combo)))
            if back not in truth:
                ids = np.unique(item_buffer(posed, None, cam, PROFILE, cull_back=back))
                truth[back] = ids[ids != SENTINEL]
            out[combo] += len(np.setdiff1d(truth[back], culler.cull(cam, time=t).triangles))
    print(f"1. dropped on {len(frames)} frames of the path (every {step}th), doors scheduled:")
    for combo, n in out.items():
        print(f"   {combo:36s} {n}")
    return out


def door_ratios(folder: Path, stages: str = "portals") -> None:
    path = Trajectory.load(PATH)
    frames = np.arange(0, len(path), 2)
    inside = (frames >= INSIDE[0]) & (frames <= INSIDE[1])
    facing = (frames >= FACING[0]) & (frames <= FACING[1])
    parts = {"whole path": np.ones(len(frames), bool), "inside": inside, "street": ~inside,
             "facing the shut door": facing}
    worlds = {d: animated(d, folder) for d in ("closed", "scheduled", "open")}
    for layout, (walls, cracks) in LAYOUTS.items():
        sent, fallbacks = {}, 0
        for doors in ("closed", "scheduled", "open"):
            part = portal_part(worlds[doors], doors, walls)
            culler = Culler(part, stages, portals={"cracks": cracks})
            results = [culler.cull(path.camera(f), time=f / FPS) for f in frames]
            sent[doors] = np.array([len(r.triangles) for r in results])
            fallbacks += sum(r.stats.get("portals.fallbacks", 0) for r in results)
        print(f"2. {stages} over {layout} cells ({len(part.extras['cell_node'])}), triangles "
              f"sent on {len(frames)} frames (every 2nd), against every door open "
              f"({sent['open'].sum():,} on the path; {fallbacks} fallbacks to vfc in 3 runs):")
        for doors in ("closed", "scheduled"):
            ratio = "  ".join(f"{name} {sent[doors][m].sum() / sent['open'][m].sum():.3f}x"
                              for name, m in parts.items())
            print(f"   doors {doors:9s} {ratio}")


def category_of(world) -> np.ndarray:
    """(T,) int: 0 the building inside (W1's rooms), 1 its outside (outer faces, roof), 2 the
    city (towers, ground), 3 doors, 4 people and cars."""
    names = np.array(world.object_names)
    kind = np.zeros(len(names), dtype=np.int64)
    kind[np.char.startswith(names, "outside_") | (names == "roof")] = 1
    kind[np.char.startswith(names, "building_") | (names == "ground")] = 2
    kind[np.char.startswith(names, "door_")] = 3
    kind[np.char.startswith(names, "person_") | np.char.startswith(names, "car_")] = 4
    return kind[world.object_ids]


CATEGORIES = ("inside", "outside", "city", "doors", "moving")


def where(folder: Path, step: int, stages: str = "portals") -> None:
    """Where the triangles sent go, with every door shut and every door open: per category
    (category_of), on the street and inside, for `stages` over both cell layouts, beside the
    item buffer's visible set (the floor no conservative culler goes below)."""
    path = Trajectory.load(PATH)
    frames = np.arange(0, len(path), step)
    inside = (frames >= INSIDE[0]) & (frames <= INSIDE[1])
    worlds = {d: animated(d, folder) for d in ("closed", "open")}
    kind = category_of(worlds["open"].world)
    rows = {}
    for doors, world in worlds.items():
        for layout, (walls, cracks) in LAYOUTS.items():
            culler = Culler(portal_part(world, doors, walls), stages, portals={"cracks": cracks})
            rows[layout, doors] = np.array([np.bincount(kind[culler.cull(
                path.camera(f), time=f / FPS).triangles], minlength=5) for f in frames])
        rows["visible", doors] = np.array([np.bincount(kind[visible_ids(
            world.posed(f / FPS), path.camera(f, PROFILE.aspect))], minlength=5)
            for f in frames])
    print(f"5. where {stages} sends on {len(frames)} frames (every {step}th), summed; shares "
          f"of each row's total, and closed/open ratios:")
    for name, mask in (("street", ~inside), ("inside", inside), ("whole path", slice(None))):
        for source in list(LAYOUTS) + ["visible"]:
            closed, opened = rows[source, "closed"][mask].sum(0), rows[source, "open"][mask].sum(0)
            shares = "  ".join(f"{c} {v / max(closed.sum(), 1):.2f}" for c, v in
                               zip(CATEGORIES, closed))
            ratios = "  ".join(f"{c} {a / max(b, 1):.3f}x" for c, a, b in
                               zip(CATEGORIES, closed, opened))
            print(f"   {name:10s} {source:9s} closed {closed.sum():9,} open {opened.sum():9,} "
                  f"({closed.sum() / max(opened.sum(), 1):.3f}x)  shares closed: {shares}  "
                  f"ratios: {ratios}")
    print("   along the path, per 100 frames: sent shut / open (wall cells; automatic) and "
          "visible shut / open, and the inside's share of what wall cells send shut:")
    for start in range(0, len(path), 100):
        m = (frames >= start) & (frames < start + 100)
        cells = [rows[k, "closed"][m].sum() / max(rows[k, "open"][m].sum(), 1)
                 for k in ("wall", "automatic", "visible")]
        wall = rows["wall", "closed"][m].sum(0)
        print(f"   frames {start:4d}-{start + 99:4d} ({'inside' if inside[m].mean() > 0.5 else 'street'})"
              f"  sent {cells[0]:.3f}x; {cells[1]:.3f}x  visible {cells[2]:.3f}x  "
              f"inside share {wall[0] / max(wall.sum(), 1):.2f}  wall sent shut {wall.sum():,}")


def visible_ids(world, camera) -> np.ndarray:
    ids = np.unique(item_buffer(world, None, camera, PROFILE, cull_back=False))
    return ids[ids != SENTINEL].astype(np.int64)


def regional(part, step: int, choices) -> None:
    path = Trajectory.load(PATH)
    chooser = RegionalCuller(part, choices)
    fixed = [Culler(part, c) for c in chooser.choices]
    ms = np.zeros(len(fixed) + 1)
    sent = np.zeros(len(fixed) + 1, dtype=np.int64)
    for f in range(0, len(path), step):
        cam, t = path.camera(f), f / FPS
        for k, culler in enumerate(fixed):
            r = culler.cull(cam, time=t)
            ms[k] += chooser.price(r)
            sent[k] += len(r.triangles)
        r = chooser.cull(cam, time=t)
        ms[-1] += chooser.price(r) + r.stats.get("regional.probe_ms", 0.0)
        sent[-1] += len(r.triangles)
    print(f"3. regional against fixed choices, every {step}th frame (iPaq model ms, summed;"
          " regional's probes included):")
    for label, m, s in zip(list(chooser.choices) + ["regional"], ms, sent):
        print(f"   {label:24s} {m:10,.0f} ms  {s:10,} triangles  {m / ms[-1]:.3f}x regional")
    kept = {}
    for region, pick in sorted(chooser.decisions.items()):
        kept.setdefault(chooser.choices[pick], []).append(region)
    for choice, regions in kept.items():
        print(f"   {choice}: cells {regions}")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--step", type=int, default=10)
    parser.add_argument("--pvs", action="store_true", help="regional may pick a baked PVS")
    parser.add_argument("--viewer", type=int, default=1000, help="street walkers (0: skip)")
    parser.add_argument("--skip-drops", action="store_true")
    parser.add_argument("--wall-cells", action="store_true",
                        help="drops and regional over wall cells (portal walls=True; default: "
                             "automatic cells)")
    parser.add_argument("--door-stages", default="portals",
                        help="the stages whose sent triangles section 2 compares (portals)")
    parser.add_argument("--where", type=int, default=0, metavar="STEP",
                        help="only section 5: where the sent triangles go, every STEP-th frame")
    args = parser.parse_args(argv)
    build_world("w7")
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        if args.where:
            where(folder, args.where, args.door_stages)
            return 0
        scheduled = AnimatedWorld.from_motion_file(build_world("w7"), motion_path("w7"))
        walls = args.wall_cells
        part = partition(scheduled, "portal", depth=2, walls=walls)
        if not args.skip_drops:
            dropped(part, args.step)
        door_ratios(folder, args.door_stages)
        choices = ["portals+tbfc", "vfc+occlusion+tbfc"]
        if args.pvs:
            start = time.perf_counter()
            part = partition(scheduled, "portal", depth=2, walls=walls, pvs="conservative")
            print(f"   (PVS bake {time.perf_counter() - start:.1f} s)")
            choices.append("pvs+vfc+tbfc")
        regional(part, args.step, choices)
        if args.viewer:
            from bench_w7_viewer import viewer_times

            viewer_times(args.viewer)
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""Conservativeness sweep (issue 17): every conservative stage on every structure, on real meshes
and thesis worlds moved and scaled, from hard cameras, against what the device shows.

An independent tester's check. Worlds: thesis worlds (w1..w6), the stress base world
("stress"), the package's real meshes (cow, teapot, bunny, dragon, beetle, suzanne, homer,
cheburashka; scaled to 10 m) or any mesh file. Each is culled as it is and moved by 1e5 /
scaled by 1e-3 and 1e3, in float32 and fixed16.16 vertices (a case the format cannot hold is
reported as refused). Cameras: the classes of vismobile/scenes/hard_cameras.py (box, pitch
+-89/89.9, wall 1e-3 with near 1e-4, narrow fov 1, wide fov 170; aspects 9/16 to 2.5) plus one
on a node corner per structure. Structures: grid, octree 3, portal 1, bsp. Each stage culls
alone in the profile's arithmetic (Culler(..., **device_options(profile))); the truth is the
union of the device's, the rounded and the exact item buffers (vismobile/render/device_view.py),
back faces culled for back-face stages. cbfc_thesis, which is not conservative, is reported for
reference.

Prints, per stage, the calls, calls that dropped a shown triangle, dropped triangles and dropped
pixels (the buffer where they are most), then the same per world case, and the worst calls.

Usage: .venv/bin/python tools/conservative_sweep.py [--quick] [--worlds w1,stress,cow]
       [--cases base,offset-1e5,...] [--modes float32,fixed16.16] [--structures grid,...]
       [--stages vfc,...] [--cameras N] [--seed S] [--worlds-dir DIR] [--out FILE.md]
Exit status: 0 when no conservative stage dropped anything, 1 otherwise, 2 on bad arguments.
"""
from __future__ import annotations

import argparse
import sys
import time
from collections import defaultdict
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from vismobile.world.camera import Camera  # noqa: E402
from vismobile.culling import BACKFACE_STAGES, CONSERVATIVE, Culler, device_options  # noqa: E402
from vismobile.errors import ProfileError, WorldError  # noqa: E402
from vismobile.partition import partition  # noqa: E402
from vismobile.device.profile import get_profile  # noqa: E402
from vismobile.render.device_view import device_buffers, dropped_pixels, shown_ids  # noqa: E402
from vismobile.scenes.hard_cameras import CLASSES, hard_cameras, moved  # noqa: E402

PROFILE = "ipaq-hx2490b"  # 240 x 320
STRUCTURES = {"grid": {}, "octree": {"depth": 3}, "portal": {"depth": 1}, "bsp": {}}
# name -> (scale, offset)
CASES = {"base": (1.0, 0.0), "offset-1e5": (1.0, 1e5), "scale-1e-3": (1e-3, 0.0),
         "scale-1e3": (1e3, 0.0)}
MODES = ("float32", "fixed16.16")
MESH_SIZE = 10.0  # metres: a mesh's longest side, so hard cameras' 1e-3 and 1e-4 mean the same
REFERENCE = ("cbfc_thesis",)  # aggressive stages reported beside the conservative ones
DEFAULT_WORLDS = "w1,w6,stress,cow,teapot,suzanne"
QUICK_WORLDS = "w1,stress,cow"


class Usage(Exception):
    """A bad argument: one line on stderr, exit status 2."""


def load_world(name: str, worlds_dir):
    """World for a sweep name: thesis world, "stress", a package mesh (scaled to MESH_SIZE,
    standing on y = 0, centred) or a mesh file."""
    from vismobile.files.loader import load_world as load_file, open_world
    from vismobile.scenes import is_thesis_world
    from vismobile.scenes.objects import MODEL_FILES, model_world
    from vismobile.scenes.stress import base_world

    if name == "stress":
        return base_world()
    if is_thesis_world(name):
        world = open_world(name, worlds_dir)
        world.name = name
        return world
    if name in MODEL_FILES:
        return model_world(name, MESH_SIZE)
    else:
        path = Path(name)
        if not path.is_file():
            raise Usage(f"{name}: no such world (thesis w1..w6, stress, "
                        f"{', '.join(MODEL_FILES)} or a mesh file)")
        world = load_file(path)
    world.name = name
    return world


def corner_camera(part, rng, aspect, scale) -> Camera:
    """A camera exactly on a corner of a random non-empty leaf, random yaw and pitch; near 0.1
    and far 1000 times `scale`."""
    leaves = np.flatnonzero((part.child_count == 0) & (part.ref_end > part.ref_start))
    box = part.node_bounds[leaves[rng.integers(len(leaves))] if len(leaves) else 0]
    eye = box[rng.integers(0, 2, 3), np.arange(3)]
    return Camera(eye, rng.uniform(0, 360), rng.uniform(-60, 60), 45.0, aspect,
                  near=0.1 * scale, far=1000.0 * scale)


class Tally:
    """Counters of one stage (or one world case)."""

    def __init__(self):
        self.calls = self.dropping = self.triangles = self.pixels = self.crashes = 0
        self.worst_pixels = 0

    def add(self, missing: int, pixels: int) -> None:
        self.calls += 1
        self.dropping += missing > 0
        self.triangles += missing
        self.pixels += pixels
        self.worst_pixels = max(self.worst_pixels, pixels)

    def row(self, name: str) -> str:
        return (f"| {name} | {self.calls:,} | {self.dropping:,} | {self.triangles:,} | "
                f"{self.pixels:,} | {self.worst_pixels:,} | {self.crashes} |")


HEADER = ("| {} | calls | calls dropping | triangles dropped | pixels dropped | worst call px "
          "| crashes |\n| --- | --- | --- | --- | --- | --- | --- |")


def sweep(worlds, cases, modes, structures, stages, count, seed, worlds_dir, log):
    """Run the sweep: (per-stage tallies, per-case tallies, worst examples, refusals)."""
    per_stage = defaultdict(Tally)
    per_case = defaultdict(Tally)
    examples, refused = [], []
    start = time.perf_counter()
    for w_index, name in enumerate(worlds):
        base = load_world(name, worlds_dir)
        cams = hard_cameras(base, count, seed=seed + w_index)
        for case in cases:
            scale, offset = CASES[case]
            world = base.transformed(scale, (offset, offset, offset))
            world.name = name
            for mode in modes:
                label = f"{name} {case} {mode}"
                profile = get_profile(PROFILE, mode)
                try:
                    world.quantized(mode)
                except ProfileError as error:
                    refused.append(f"{label}: {str(error).splitlines()[0]}")
                    continue
                parts = {kind: partition(world, kind, **STRUCTURES[kind]) for kind in structures}
                rng = np.random.default_rng(seed)
                views = [(c_label, moved(cam, scale, (offset,) * 3), None)
                         for c_label, cam in cams]
                views += [(f"corner_{kind}", corner_camera(parts[kind], rng, profile.aspect, scale),
                           kind) for kind in structures]
                cullers = {(kind, stage): Culler(parts[kind], stage, **device_options(profile))
                           for kind in structures for stage in stages}
                for c_label, cam, only in views:
                    truth = {}
                    for (kind, stage), culler in cullers.items():
                        if only is not None and kind != only:
                            continue
                        back = stage in BACKFACE_STAGES
                        try:
                            if back not in truth:
                                buffers = device_buffers(world, cam, profile, back)
                                truth[back] = (buffers, shown_ids(buffers))
                        except ProfileError as error:  # the eye: the format cannot hold it
                            refused.append(f"{label} {c_label}: {str(error).splitlines()[0]}")
                            break
                        buffers, shown = truth[back]
                        try:
                            if stage == "occlusion_thesis":
                                culler.cull(cam)  # its occluders are last frame's triangles
                            sent = culler.cull(cam).triangles
                        except Exception as error:  # noqa: BLE001 - a crash is a result here
                            per_stage[stage].crashes += 1
                            examples.append((np.inf, f"{stage} on {label} {kind} {c_label}: "
                                                     f"crash {type(error).__name__}: {error}"))
                            continue
                        missing = np.setdiff1d(shown, sent)
                        pixels = dropped_pixels(buffers, missing)
                        per_stage[stage].add(len(missing), pixels)
                        if stage not in REFERENCE:
                            per_case[label].add(len(missing), pixels)
                        if len(missing) and stage not in REFERENCE:
                            examples.append((pixels, f"{stage} on {label} {kind} {c_label}: "
                                                     f"{len(missing)} triangles, {pixels} px, "
                                                     f"{cam}"))
                print(f"{label:32s} done [{time.perf_counter() - start:.0f} s]", file=log,
                      flush=True)
    return per_stage, per_case, examples, refused


def report(per_stage, per_case, examples, refused, stages) -> str:
    lines = [HEADER.format("stage")]
    for stage in stages:
        tag = " (not conservative)" if stage in REFERENCE else ""
        lines.append(per_stage[stage].row(stage + tag))
    lines += ["", HEADER.format("world case (conservative stages)")]
    lines += [tally.row(name) for name, tally in per_case.items()]
    if refused:
        lines += ["", "Refused (the vertex format cannot hold the case):"]
        lines += [f"- {line}" for line in sorted(set(refused))]
    worst = sorted(examples, key=lambda e: -e[0])[:12]
    if worst:
        lines += ["", "Worst calls of conservative stages:"]
        lines += [f"- {text}" for _, text in worst]
    return "\n".join(lines)


def parse_list(text: str, valid, what: str) -> list:
    items = [s.strip() for s in text.split(",") if s.strip()]
    bad = [s for s in items if valid is not None and s not in valid]
    if bad or not items:
        raise Usage(f"unknown {what} {', '.join(bad) or '(none given)'}; valid: "
                    f"{', '.join(valid)}")
    return items


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--worlds", default=None, help=f"default {DEFAULT_WORLDS}")
    parser.add_argument("--cases", default=",".join(CASES))
    parser.add_argument("--modes", default=",".join(MODES))
    parser.add_argument("--structures", default=",".join(STRUCTURES))
    parser.add_argument("--stages", default=",".join(CONSERVATIVE + REFERENCE))
    parser.add_argument("--cameras", type=int, default=None,
                        help=f"cameras per class ({', '.join(CLASSES)}); default 3, quick 1")
    parser.add_argument("--seed", type=int, default=17)
    parser.add_argument("--worlds-dir", default=None, help="built thesis worlds (.obj)")
    parser.add_argument("--quick", action="store_true",
                        help=f"worlds {QUICK_WORLDS}, one camera per class")
    parser.add_argument("--out", help="also write the tables to this markdown file")
    args = parser.parse_args(argv)
    try:
        from vismobile.culling import STAGES

        worlds = parse_list(args.worlds or (QUICK_WORLDS if args.quick else DEFAULT_WORLDS),
                            None, "world")
        cases = parse_list(args.cases, list(CASES), "case")
        modes = parse_list(args.modes, list(MODES), "mode")
        structures = parse_list(args.structures, list(STRUCTURES), "structure")
        stages = parse_list(args.stages, sorted(STAGES), "stage")
        count = args.cameras if args.cameras is not None else (1 if args.quick else 3)
        if count < 1:
            raise Usage(f"--cameras must be at least 1, got {count}")
        start = time.perf_counter()
        per_stage, per_case, examples, refused = sweep(worlds, cases, modes, structures, stages,
                                                       count, args.seed, args.worlds_dir,
                                                       sys.stderr)
    except (Usage, WorldError) as error:
        print(f"conservative_sweep: {error}", file=sys.stderr)
        return 2
    text = report(per_stage, per_case, examples, refused, stages)
    calls = sum(t.calls for t in per_stage.values())
    text += (f"\n\n{calls:,} cull calls, {len(worlds)} worlds x {len(cases)} cases x "
             f"{len(modes)} modes x {len(structures)} structures, {count} camera(s) per class "
             f"+ 1 corner per structure, seed {args.seed}; "
             f"{time.perf_counter() - start:.0f} s wall.")
    print(text)
    if args.out:
        from vismobile.files.atomic import atomic_write_bytes
        atomic_write_bytes(args.out, (text + "\n").encode())
    bad = sum(per_stage[s].dropping + per_stage[s].crashes for s in stages
              if s not in REFERENCE)
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())

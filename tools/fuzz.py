"""Fuzz the readers of outside input: OBJ worlds, .vmp partition files (with level-of-detail
chains too) and trajectory CSVs (issue 11); textured GLB and OBJ+MTL scenes (issue 27); compare's --cull
lists (issue 31); compare's and tune's --structures lists with baked PVS labels and the --scheduler
address of compare and partition (issue 29); PLY, STL, OFF, GLB, gzip-compressed meshes, .vmt terrains and .npy
heightmaps (issue 28); GeoTIFF heightmaps and .vmt terrains as `play` runs them (vmtplay: LOD, objects culled, a frame;
issue 30); GLB node animations and JSON motion files (animglb, motion: issue 25), a motion file
as play --motion takes it, --fps values and play --regional choices (playmotion, fps,
regional: issue 25), play --page-budget values (budget: issue 30), GeoTIFFs built out of core,
--memory values, paged Röttger files (tifstream, memory, vmrpages: issue 30, fuzz_tiled.py),
--repair values and OBJs repaired (repair, objrepair, partition's partrepair: issue 29,
fuzz_repair.py), compare's and
tune's --repair values (studyrepair: issue 29).
The targets live by family: the option texts in fuzz_options.py, the mesh, scene and terrain
files in fuzz_formats.py, issue 25's in fuzz_motion.py, issue 30's out-of-core ones in
fuzz_tiled.py, issue 29's repair in fuzz_repair.py; OBJ, .vmp and trajectories here.
Every input must load or end in a VisMobileError (one clean line from the CLI); any other exception, a run over the time limit or memory over the cap is a failure.

Three modes:
- mutate: seeded mutation of real files (a shared model, .vmp files of every structure built
  from it, a thesis trajectory): byte flips, insertions, deletions, repeats, truncation, extreme
  numbers swapped into tokens, and for .vmp crafted edits of the JSON header and of sections
  with their CRC32s recomputed, so the checks behind the checksums are reached (a baked PVS's
  side stream, pattern bits or shape edited inside, re-compressed; tools/fuzz_vmp.py). A .vmp that
  loads is also culled (vfc, occlusion, portals) from a camera inside its world.
- hostile: issue 28's crafted cases (tools/hostile.py: bad indices, node graphs, instancing,
  URIs, bombs, special files, .vmt headers, heightmap shapes), each through the CLI in a child
  process: exit 2, one line naming the file, nothing left behind, peak RSS under 2 GiB.
- atheris: coverage-guided fuzzing (pip install '.[fuzz]') of one entry point; arguments after
  the target go to libFuzzer, e.g. -max_total_time=600 -rss_limit_mb=4096.

Usage:
  .venv/bin/python tools/fuzz.py mutate [--target obj,vmp,trajectory,glb,objmtl,cull,structure,selection,scheduler,ply,stl,off,gz,vmt,vmtplay,npy,tif,vmtiles,animglb,motion,playmotion,fps,regional,budget,tifstream,memory,vmrpages,repair,objrepair,partrepair,studyrepair]
                                        [--cases 300] [--seed 0]
  .venv/bin/python tools/fuzz.py hostile [CASE ...]
  .venv/bin/python tools/fuzz.py atheris obj|vmp|trajectory|glb|objmtl|cull|structure|selection|scheduler [-max_total_time=600 ...]
Prints one line per target: cases, loaded, clean errors, failures (with the first failures'
tracebacks and the seed that reproduces each).
"""
from __future__ import annotations

import os
import random
import resource
import signal
import struct
import sys
import tempfile
import traceback
import warnings
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tools"))  # the targets; hostile_writers.py: the formats

import fuzz_formats  # noqa: E402 - mesh, scene and terrain files
import fuzz_motion  # noqa: E402 - issue 25's animations, motion files, --fps, --regional
import fuzz_options  # noqa: E402 - --cull, --structure(s), --scheduler, --page-budget texts
import fuzz_repair  # noqa: E402 - issue 29's --repair tjunctions (repair, objrepair)
import fuzz_tiled  # noqa: E402 - issue 30's out-of-core and paged Röttger targets
from fuzz_vmp import edit_vmp, mutate_pvs_pack  # noqa: E402,F401 - .vmp headers and sections

MODEL = ROOT.parent / "shared" / "models" / "suzanne.obj"
TRAJECTORY = ROOT / "trajectories" / "indoor.csv"
STRUCTURES = (("grid", {}), ("octree", {"depth": 3}), ("portal", {"depth": 1}),
              ("portal", {"depth": 1, "pvs": "conservative"}), ("portal", {"depth": 1, "walls": True}),
              ("portal", {"depth": 1, "pvs": "conservative", "budget": 0.02}),
              ("portal", {"depth": 1, "pvs": "conservative", "budget": "none"}),
              ("bsp", {"min_leaf": 16}), ("kdtree", {}))
EXTREMES = (b"1e308", b"-1e308", b"nan", b"inf", b"-0", b"0", b"1e30", b"1e31", b"9" * 400,
            b"-1", b"2147483648", b"1" + b"0" * 40, b"0x10", b"1_0", b"\xa0", b"\xc2\xa0")
TIME_LIMIT = 30  # seconds per case
MEMORY_LIMIT = 6 << 30  # address space cap (bytes): a runaway allocation fails fast


# ---- seeds -----------------------------------------------------------------------------------
def seeds(folder: Path) -> dict:
    """{target: [bytes, ...]} of real inputs: the model, its partitions, a trajectory."""
    from vismobile.partition import partition, save_partition
    from vismobile.world.world import World

    world = World.from_obj(MODEL)
    vmps = []
    for kind, params in STRUCTURES:
        path = folder / f"seed-{kind}{'-pvs' if 'pvs' in params else ''}" \
                        f"{'-walls' if 'walls' in params else ''}" \
                        f"{'-budget' + str(params['budget']) if 'budget' in params else ''}.vmp"
        save_partition(partition(world, kind, **params), path)
        vmps.append(path.read_bytes())
    # A PVS baked from an animated world with a door (extras pvs_door_*, checked on load): the
    # model with a shut door box through it (a `door_*` moving object) and a one-key motion.
    import numpy as np

    from vismobile.scenes.crowd import outward_boxes
    from vismobile.world.animated import AnimatedWorld
    from vismobile.world.motion import Motion, Track

    low, high = world.extent
    mid = (low + high) / 2
    box = np.array([[low[0], low[1], mid[2] - 0.05], [high[0], high[1], mid[2] + 0.05]])
    vertices, triangles = outward_boxes(box[None])
    door = World(vertices, triangles, np.zeros(len(triangles), dtype=np.int64), ["door_1"])
    doored = World.concatenate([world, door], name="doored")
    motion = Motion([Track(object_id=len(doored.object_names) - 1,
                           translation=(np.array([0.0]), np.zeros((1, 3))))])
    baked = partition(AnimatedWorld(doored, motion), "portal", depth=1, pvs="conservative",
                      pvs_doors=True)
    save_partition(baked.static, folder / "seed-pvs-doors.vmp")
    vmps.append((folder / "seed-pvs-doors.vmp").read_bytes())
    # A street-cell PVS (extras pvs_cover, partition/pvs_street.py): two blocks on a ground.
    from vismobile.scenes.city import Building, building_mesh
    from vismobile.scenes.surfaces import MeshCollector, tiled_rect

    mesh = MeshCollector()
    for k, x in enumerate((6.0, 14.0)):
        v, t = building_mesh(Building((x, 10.0), (4.0, 4.0), 20.0 * k, 8.0))
        mesh.add(f"b{k}", np.round(v, 5), t)
    mesh.add("ground", *tiled_rect((0.0, 0.0, 0.0), (20.0, 0.0, 0.0), (0.0, 0.0, 20.0), 4, 4,
                                   (0.0, 1.0, 0.0)))
    street = partition(mesh.world("street"), "portal", depth=1, pvs="conservative")
    save_partition(street, folder / "seed-pvs-street.vmp")
    vmps.append((folder / "seed-pvs-street.vmp").read_bytes())
    # A partition carrying level-of-detail chains (extras lod_*, checked on load).
    from vismobile.lod.simplify import build_chains

    tree = partition(world, "octree", depth=3)
    tree.extras.update(build_chains(world).to_extras())
    save_partition(tree, folder / "seed-lod.vmp")
    vmps.append((folder / "seed-lod.vmp").read_bytes())
    lines = TRAJECTORY.read_bytes().splitlines(keepends=True)
    return {"obj": [MODEL.read_bytes()], "vmp": vmps, "trajectory": [b"".join(lines[:60])],
            **fuzz_options.SEEDS,
            **fuzz_formats.format_seeds(world, folder, [fuzz_formats.textured_glb()])}


# ---- mutations (driven by pick(n) -> int in [0, n), so random and atheris share them) -------
def mutate_bytes(data: bytes, pick) -> bytes:
    data = bytearray(data)
    op = pick(7)
    where = pick(len(data) + 1)
    if op == 0 and data:  # flip bits in a few bytes
        for _ in range(1 + pick(8)):
            data[pick(len(data))] ^= 1 << pick(8)
    elif op == 1:  # insert random bytes
        data[where:where] = bytes(pick(256) for _ in range(1 + pick(16)))
    elif op == 2:  # delete a range
        del data[where:where + 1 + pick(64)]
    elif op == 3:  # repeat a range many times (duplicate-heavy input)
        chunk = bytes(data[where:where + 1 + pick(80)])
        data[where:where] = chunk * (1 + pick(2000))
    elif op == 4:  # truncate
        del data[where:]
    else:  # swap a token for an extreme value
        tokens = [i for i in range(1, len(data)) if data[i - 1] in b" ,\n\t" and data[i] not in b" ,\n\t"]
        if tokens:
            start = tokens[pick(len(tokens))]
            end = start
            while end < len(data) and data[end] not in b" ,\n\t/":
                end += 1
            data[start:end] = EXTREMES[pick(len(EXTREMES))]
    return bytes(data)


def mutate_vmp(data: bytes, pick) -> bytes:
    """Crafted .vmp (fuzz_vmp.edit_vmp: the JSON header or a section edited, the checksums
    recomputed); a byte mutation instead when an earlier mutation broke the layout."""
    try:
        return edit_vmp(data, pick)
    except (ValueError, struct.error, KeyError, IndexError, TypeError, AttributeError):
        return mutate_bytes(data, pick)


# ---- entry points (this file's; the others in fuzz_options, fuzz_formats, fuzz_motion and
# fuzz_tiled) ------------------------------------------------------------------------------ ----------------------------------------------------------------------------
def load_obj(path):
    from vismobile.world.world import World

    World.from_obj(path)


def load_trajectory(path):
    from vismobile.world.trajectory import Trajectory

    Trajectory.load(path)


def load_and_cull(path):
    import numpy as np

    from vismobile.world.camera import Camera
    from vismobile.culling import Culler
    from vismobile.lod import LodChains, LodSelector
    from vismobile.partition import load_partition

    partition = load_partition(path)
    low, high = partition.world.extent
    eye = (low + high) / 2.0
    stages = ["vfc", "occlusion"] + (["portals"] if partition.kind == "portal" else []) \
        + (["pvs"] if "pvs_pack" in partition.extras else [])
    for names in (stages[:1], stages):
        culler = Culler(partition, [s for s in names if not (s == "vfc" and "portals" in names)])
        for yaw in (0.0, 135.0):
            camera = Camera(tuple(eye), yaw, -10.0, 45.0, 0.75, 0.01,
                            float(np.ptp([low, high], axis=0).max()) * 4 + 1)
            culled = culler.cull(camera)
            chains = LodChains.from_extras(partition.extras)
            if chains is not None:  # the level selection reads every table of the chains
                LodSelector(partition.world, chains, (240, 320)).select(culled.triangles,
                                                                        camera, 1.0)


ENTRY = {"obj": (load_obj, ".obj"), "vmp": (load_and_cull, ".vmp"),
         "trajectory": (load_trajectory, ".csv"), **fuzz_options.ENTRY, **fuzz_formats.ENTRY,
         **fuzz_motion.ENTRY, **fuzz_tiled.ENTRY, **fuzz_repair.ENTRY}


def run_case(target, data, folder):
    """'ok' or 'error' (VisMobileError); any other exception propagates."""
    from vismobile.errors import VisMobileError

    function, suffix = ENTRY[target]
    path = Path(folder) / f"case{suffix}"
    path.write_bytes(data)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            function(path)
    except VisMobileError:
        return "error"
    return "ok"


# ---- seeded mutation -------------------------------------------------------------------------
class Timeout(Exception):
    pass


def _alarm(signum, frame):
    raise Timeout(f"over {TIME_LIMIT} s")


def mutate_main(targets, cases, seed):
    resource.setrlimit(resource.RLIMIT_AS, (MEMORY_LIMIT, MEMORY_LIMIT))
    signal.signal(signal.SIGALRM, _alarm)
    failures = 0
    with tempfile.TemporaryDirectory() as folder:
        folder = Path(folder)
        originals = seeds(folder)
        for target in targets:
            counts = {"ok": 0, "error": 0, "fail": 0}
            shown = []
            for data in originals[target]:  # numba compiles here, outside the time limit: an
                try:                        # alarm inside a compile leaves its library broken
                    run_case(target, data, folder)
                except Exception:  # noqa: BLE001 - warm-up only; the cases report failures
                    pass
            for case in range(cases):
                rng = random.Random(f"{seed}:{target}:{case}")
                pick = rng.randrange
                data = originals[target][pick(len(originals[target]))]
                for _ in range(1 + pick(3)):
                    data = (mutate_vmp(data, pick) if target == "vmp" and pick(3) and
                            data[:8] == b"\x89VMP\r\n\x1a\n" else mutate_bytes(data, pick))
                signal.alarm(TIME_LIMIT)
                try:
                    counts[run_case(target, data, folder)] += 1
                except Exception as error:  # noqa: BLE001 - every other exception is a finding
                    counts["fail"] += 1
                    if len(shown) < 3:
                        shown.append(f"  seed {seed} case {case}: {type(error).__name__}: "
                                     f"{error}\n" + "".join(traceback.format_exc(limit=-4)))
                finally:
                    signal.alarm(0)
            failures += counts["fail"]
            print(f"{target:11} cases {cases:5}  loaded {counts['ok']:5}  clean errors "
                  f"{counts['error']:5}  failures {counts['fail']:3}")
            for text in shown:
                print(text)
    return 1 if failures else 0


# ---- atheris ---------------------------------------------------------------------------------
def atheris_main(target, argv):
    import atheris
    import numpy  # noqa: F401 - libraries imported first stay uninstrumented (coverage of
    import trimesh  # noqa: F401   vismobile's own code is what guides the search)

    with atheris.instrument_imports():
        import vismobile.files.obj  # noqa: F401
        import vismobile.partition.store  # noqa: F401
        import vismobile.world.trajectory  # noqa: F401
        import vismobile.culling  # noqa: F401
    folder = Path(tempfile.mkdtemp(prefix="vismobile-fuzz-"))
    vmps = seeds(folder)["vmp"] if target == "vmp" else []

    def one(data: bytes):
        if target == "vmp" and data and vmps:
            provider = atheris.FuzzedDataProvider(data)
            pick = lambda n: provider.ConsumeIntInRange(0, max(n - 1, 0))  # noqa: E731
            mode = pick(3)
            if mode < 2:
                data = vmps[pick(len(vmps))]
                for _ in range(1 + pick(3)):
                    data = mutate_vmp(data, pick) if mode == 0 else mutate_bytes(data, pick)
            else:
                data = provider.ConsumeBytes(provider.remaining_bytes())
        run_case(target, data, folder)

    atheris.Setup([sys.argv[0]] + argv, one)
    atheris.Fuzz()


def main(argv=None):
    argv = list(sys.argv[1:] if argv is None else argv)
    if not argv or argv[0] not in ("mutate", "atheris", "hostile"):
        print(__doc__)
        return 2
    if argv[0] == "hostile":
        import hostile

        return hostile.main(argv[1:])
    if argv[0] == "atheris":
        if len(argv) < 2 or argv[1] not in ENTRY:
            print("target: " + ", ".join(ENTRY))
            return 2
        return atheris_main(argv[1], argv[2:])
    import argparse

    parser = argparse.ArgumentParser(prog="fuzz.py mutate")
    parser.add_argument("--target",
                        default="obj,vmp,trajectory,glb,objmtl,cull,structure,selection,scheduler,ply,stl,off,gz,vmt,vmtplay,npy,tif,vmtiles,animglb,motion")
    parser.add_argument("--cases", type=int, default=300)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv[1:])
    return mutate_main([t for t in args.target.split(",") if t], args.cases, args.seed)


if __name__ == "__main__":
    os.environ.setdefault("PYOPENGL_PLATFORM", "egl")
    sys.exit(main())

"""Fuzz the readers of outside input: OBJ worlds, .vmp partition files (with level-of-detail
chains too) and trajectory CSVs (issue 11); textured GLB and OBJ+MTL scenes (issue 27); compare's --cull
lists (issue 31); compare's and tune's --structures lists with baked PVS labels and the --scheduler
address of compare and partition (issue 29); PLY, STL, OFF, GLB, gzip-compressed meshes, .vmt terrains and .npy
heightmaps (issue 28); GeoTIFF heightmaps and .vmt terrains as `play` runs them (vmtplay: LOD, objects culled, a frame;
issue 30); GLB node animations and JSON motion files (animglb, motion: issue 25), a motion file
as play --motion takes it, --fps values and play --regional choices (playmotion, fps,
regional: issue 25), play --page-budget values (budget: issue 30), GeoTIFFs built out of core,
--memory values, paged Röttger files (tifstream, memory, vmrpages: issue 30, fuzz_tiled.py),
--repair values and OBJs repaired (repair, objrepair: issue 29, fuzz_repair.py).
Every input must load or end in a VisMobileError (one clean line from the CLI); any other exception, a run over the time limit or memory over the cap is a failure.

Three modes:
- mutate: seeded mutation of real files (a shared model, .vmp files of every structure built
  from it, a thesis trajectory): byte flips, insertions, deletions, repeats, truncation, extreme
  numbers swapped into tokens, and for .vmp crafted edits of the JSON header and of sections
  with their CRC32s recomputed, so the checks behind the checksums are reached (a baked PVS's
  zlib'd sets re-compressed after an edit inside; tools/fuzz_vmp.py). A .vmp that
  loads is also culled (vfc, occlusion, portals) from a camera inside its world.
- hostile: issue 28's crafted cases (tools/hostile.py: bad indices, node graphs, instancing,
  URIs, bombs, special files, .vmt headers, heightmap shapes), each through the CLI in a child
  process: exit 2, one line naming the file, nothing left behind, peak RSS under 2 GiB.
- atheris: coverage-guided fuzzing (pip install '.[fuzz]') of one entry point; arguments after
  the target go to libFuzzer, e.g. -max_total_time=600 -rss_limit_mb=4096.

Usage:
  .venv/bin/python tools/fuzz.py mutate [--target obj,vmp,trajectory,glb,objmtl,cull,structure,selection,scheduler,ply,stl,off,gz,vmt,vmtplay,npy,tif,vmtiles,animglb,motion,playmotion,fps,regional,budget,tifstream,memory,vmrpages,repair,objrepair]
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
sys.path.insert(0, str(ROOT / "tools"))  # hostile.py: writers of the formats

MODEL = ROOT.parent / "shared" / "models" / "suzanne.obj"
TRAJECTORY = ROOT / "trajectories" / "indoor.csv"
STRUCTURES = (("grid", {}), ("octree", {"depth": 3}), ("portal", {"depth": 1}),
              ("portal", {"depth": 1, "pvs": "conservative"}), ("portal", {"depth": 1, "walls": True}),
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
                        f"{'-walls' if 'walls' in params else ''}.vmp"
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
            "cull": [b"vfc+bfc;vfc+occlusion", b"thesis,ours", b"vfc,bfc",
                     b"vfc+cbfc+tbfc none; portals+vfc"],
            "structure": STRUCTURE_TEXTS, "selection": SELECTION_TEXTS,
            "scheduler": SCHEDULER_TEXTS,
            **format_seeds(world, folder, [textured_glb()])}


def vmtiles_seed(heightmap, folder, name="seed") -> bytes:
    """A .vmtiles file of a small terrain (terrain tile; issue 30's paged terrains; with
    no-data samples: the holes flag and the no-data normal bytes)."""
    from vismobile.terrain.paged import write_tiles
    from vismobile.terrain.tiles import TilePyramid

    write_tiles(TilePyramid.build(heightmap, 4), folder / f"{name}.vmtiles")
    return (folder / f"{name}.vmtiles").read_bytes()


def format_seeds(world, folder: Path, glbs=()) -> dict:
    """Seeds of the issue 28 surfaces: the model as PLY (ASCII, both binary byte orders), STL
    (binary, ASCII), OFF and GLB (one node, and two nodes with transforms), a .gz PLY, a small
    .vmt terrain with objects, .npy heightmaps; and an OBJ naming an MTL with a map_Kd image
    (issue 27). glbs: GLB seeds put first (the textured one)."""
    import gzip
    import io

    import numpy as np
    import trimesh

    import hostile
    from vismobile.terrain import sources, store
    from vismobile.terrain.heightmap import quantize
    from vismobile.terrain.placement import place_objects

    mesh = trimesh.Trimesh(world.vertices, world.triangles, process=False)
    v, f = mesh.vertices.tolist(), mesh.faces.tolist()
    plys = [hostile.ply(v, f, fmt) for fmt in ("ascii", "binary_little_endian",
                                               "binary_big_endian")]
    doc, binary = hostile.gltf(v, f)
    nodes = [{"children": [1], "matrix": [2, 0, 0, 0, 0, 0, -1, 0, 0, 1, 0, 0, 3, 4, 5, 1]},
             {"mesh": 0, "translation": [1, 2, 3], "scale": [1, -1, 1]}]
    two, _ = hostile.gltf(v, f, nodes=nodes)
    heightmap = sources.diamond_square(17, seed=1)
    store.save(folder / "seed.vmt", heightmap, place_objects(heightmap, 3, 1, 2.0))
    holed = heightmap.heights.astype(np.float64)
    holed[5:9, 3:12] = np.nan  # no data: a version 2 .vmt with its mask section (issue 30)
    store.save(folder / "holes.vmt", quantize(holed, 1.0, "holes"))
    arrays = []
    tifs = []
    for array, predictor in ((heightmap.heights.astype(np.float32), 3),
                             (np.arange(-40, 40, dtype=np.int16).reshape(8, 10), 2)):
        from PIL import Image, TiffImagePlugin

        info = TiffImagePlugin.ImageFileDirectory_v2()
        info[42113], info.tagtype[42113] = "-9999", 2  # GDAL_NODATA (issue 30's GeoTIFFs)
        info[33550], info.tagtype[33550] = (30.0, 30.0, 0.0), 12  # ModelPixelScaleTag
        info[317] = predictor
        buffer = io.BytesIO()
        Image.fromarray(array).save(buffer, format="TIFF", compression="tiff_adobe_deflate",
                                    tiffinfo=info)
        tifs.append(buffer.getvalue())
    for array in (heightmap.heights, np.arange(12, dtype=np.uint16).reshape(3, 4), holed):
        buffer = io.BytesIO()
        np.save(buffer, array)
        arrays.append(buffer.getvalue())
    return {"ply": plys, "stl": [mesh.export(file_type="stl"),
                                 mesh.export(file_type="stl_ascii").encode()],
            "off": [hostile.off(v, f)],
            "objmtl": [TEXTURED_OBJ],
            "glb": [*glbs, hostile.glb(doc, binary), hostile.glb(two, binary)],
            "gz": [gzip.compress(plys[1])], "vmt": [(folder / "seed.vmt").read_bytes(),
                                                    (folder / "holes.vmt").read_bytes()],
            "vmtplay": [(folder / "seed.vmt").read_bytes()],
            "npy": arrays, "tif": tifs,
            "vmtiles": [vmtiles_seed(heightmap, folder),
                        vmtiles_seed(quantize(holed, 1.0, "holes"), folder, "holes")],
            "budget": BUDGET_TEXTS, **animated_seeds(folder),
            **fuzz_tiled.tiled_seeds(folder), **fuzz_tiled.pages_seeds(folder),
            **fuzz_repair.repair_seeds()}


from fuzz_motion import (animated_seeds, load_animated, load_fps, load_motion,  # noqa: E402
                         load_play_motion, load_regional)
import fuzz_tiled  # noqa: E402 - issue 30's out-of-core and paged Röttger targets
import fuzz_repair  # noqa: E402 - issue 29's --repair tjunctions (repair, objrepair)


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


from fuzz_vmp import edit_vmp, mutate_pvs_pack  # noqa: E402,F401


# ---- entry points ----------------------------------------------------------------------------
def load_obj(path):
    from vismobile.world.world import World

    World.from_obj(path)


def load_trajectory(path):
    from vismobile.world.trajectory import Trajectory

    Trajectory.load(path)


# The structure grammar's seeds: every kind, its parameters and the PVS bake.
STRUCTURE_TEXTS = [b"grid:4", b"octree:3", b"portal:depth=1,pvs=conservative", b"portal:1,walls=true",
                   b"bsp:min_leaf=16",
                   b"kdtree:split=median,max_depth=6,min_leaf=4", b"kdtree:ratio=8,bins=16"]
CUBE_OBJ = ("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n"
            "f 1 3 2\nf 1 4 3\nf 5 6 7\nf 5 7 8\nf 1 2 6\nf 1 6 5\nf 3 4 8\nf 3 8 7\n"
            "f 2 3 7\nf 2 7 6\nf 1 5 8\nf 1 8 4\n")


def load_structure(path):
    """partition's --structure text, through the CLI on a cube: built (rc 0) or refused in one
    line (rc 2, raised as VisMobileError); any other outcome is a finding."""
    from vismobile.app.cli import main as cli
    from vismobile.errors import VisMobileError

    text = path.read_bytes()[:256].decode("utf-8", errors="replace").replace("\x00", "")
    cube = path.with_name("cube.obj")
    if not cube.exists():
        cube.write_text(CUBE_OBJ)
    try:
        rc = cli(["partition", str(cube), f"--structure={text}", "-o",
                  str(path.with_suffix(".vmp"))])
    except SystemExit as exit:  # argparse's own refusal
        rc = exit.code
    if rc == 2:
        raise VisMobileError(f"--structure {text!r} refused")
    if rc != 0:
        raise RuntimeError(f"partition --structure {text!r}: exit code {rc}")


# compare's and tune's --structures lists: depth ranges, baked PVS labels (+pvs, +pvs=...).
SELECTION_TEXTS = [b"grid,octree:3-6,portal:1-3,bsp,kdtree", b"portal:2+pvs,bsp+pvs",
                   b"grid+pvs=sampled:8,octree:2-3+pvs=conservative", b"all,kdtree+pvs"]


def load_selection(path):
    """A --structures list: parsed (SelectionError, a VisMobileError, when refused), and every
    label's partition parameters and PVS mode read back as engine.load_structure reads them."""
    from vismobile.study.matrix import parse_structures, pvs_of, structure_params

    text = path.read_bytes()[:4096].decode("utf-8", errors="replace")
    for label in parse_structures(text):
        params = structure_params(label)
        assert pvs_of(label) in (None, "conservative") or pvs_of(label).startswith("sampled:")
        assert set(params) <= {"auto", "depth", "pvs"}, params


# --scheduler values (partition's PVS bake, compare's runs), checked before anything connects.
SCHEDULER_TEXTS = [b"dask", b"tcp://127.0.0.1:8786", b"scheduler.local:8786"]


def load_scheduler(path):
    """A --scheduler value: accepted as an address (nothing connects) or SchedulerError."""
    from vismobile.study.distributed import scheduler_address

    text = path.read_bytes()[:1024].decode("utf-8", errors="replace")
    assert scheduler_address(text) == text.strip()


def load_cull_list(path):
    """compare's --cull text (issue 31's grammar: + joins stages, ';' or ',' separates
    combinations): parsed, and the ambiguity note computed."""
    from vismobile.study.matrix import ambiguous_commas, parse_culls

    text = path.read_bytes()[:4096].decode("utf-8", errors="replace")
    ambiguous_commas(text)
    parse_culls(text)
    parse_culls(text.split("\n"))  # as repeated --cull options


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


def load_textured(path):
    """A textured GLB: the world, its base-colour textures and UVs (issue 27), drawn once."""
    import numpy as np

    from vismobile.device.profile import get_profile
    from vismobile.files.loader import load_world
    from vismobile.render.textured import renderer_for
    from vismobile.world.camera import Camera

    world = load_world(path)
    profile = get_profile("ipaq-hx2490b")
    profile.check_memory(world)
    low, high = world.extent
    renderer_for(world, profile).draw(np.arange(world.triangle_count),
                                      Camera(tuple(high + (high - low) + 1.0), 45.0, -30.0))


TEXTURED_OBJ = (b"mtllib quad.mtl\no a_quad\nv -2 -2 0\nv 2 -2 0\nv 2 2 0\nv -2 2 0\n"
                b"vt 0 0\nvt 8 0\nvt 8 8\nvt 0 8\nusemtl checker\nf 1/1 2/2 3/3\n"
                b"f 1/1 3/3 4/4\no b_plain\nv 0 0 1\nv 0.5 0 1\nv 0 0.5 1\nvt 0 0\n"
                b"usemtl plain\nf 5/5 6/5 7/5\n")


def load_textured_obj(path):
    """An OBJ naming an MTL with a map_Kd image (both written beside it): world, textures,
    one textured draw (issue 27)."""
    import numpy as np
    from PIL import Image

    folder = Path(path).parent
    if not (folder / "quad.mtl").exists():
        (folder / "quad.mtl").write_text("newmtl checker\nKd 1 1 1\nmap_Kd checker.png\n"
                                         "newmtl plain\nKd 0.5 0.5 0.5\n")
        rows, cols = np.indices((24, 40)) // 4
        image = np.where(((rows + cols) % 2 == 0)[..., None], (230, 30, 30), (30, 30, 230))
        Image.fromarray(image.astype(np.uint8)).save(folder / "checker.png")
    load_textured(path)


def textured_glb() -> bytes:
    """A quad with a checker base-colour texture and an untextured box, as GLB bytes."""
    import numpy as np
    import trimesh
    from PIL import Image

    quad = trimesh.Trimesh([[-2, -2, 0], [2, -2, 0], [2, 2, 0], [-2, 2, 0]],
                           [[0, 1, 2], [0, 2, 3]], process=False)
    rows, cols = np.indices((24, 40)) // 4
    image = np.where(((rows + cols) % 2 == 0)[..., None], (230, 30, 30), (30, 30, 230))
    material = trimesh.visual.material.PBRMaterial(
        baseColorTexture=Image.fromarray(image.astype(np.uint8)))
    quad.visual = trimesh.visual.TextureVisuals(uv=[[0, 0], [8, 0], [8, 8], [0, 8]],
                                                material=material)
    scene = trimesh.Scene()
    scene.add_geometry(quad, node_name="a_quad", geom_name="quad")
    scene.add_geometry(trimesh.creation.box(extents=(0.5, 0.5, 0.5)), node_name="b_box")
    return scene.export(file_type="glb")



def load_mesh(path):
    from vismobile.world.world import World

    World.from_file(path)


def load_vmt(path):
    from vismobile.files.loader import load_world

    load_world(path)  # the terrain's ground and objects as a World


def load_vmt_play(path):
    """A .vmt as `play` runs it (issue 30): its LOD method (ROAM), its objects partitioned and
    culled by vfc+horizon over the heightmap, one frame drawn."""
    from vismobile.app.terrain_scene import TerrainScene, default_cameras

    scene = TerrainScene(path, "roam", 1.0, ("vfc", "horizon"), "octree:2")
    scene.frame(default_cameras(scene.heightmap, 1, scene.profile.aspect)[0])


def load_vmtiles(path):
    """A .vmtiles terrain paged in by tiles (issue 30): opened, every record read, a frame
    selected and its tiles drawn from the page cache."""
    import numpy as np

    from vismobile.device.profile import get_profile
    from vismobile.render.tile_arena import PagedArena
    from vismobile.terrain.paged import PagedTiles
    from vismobile.terrain.tiles import select_tiles
    from vismobile.world.camera import Camera

    paged = PagedTiles(path, budget_bytes=4096, thread=False)
    try:
        for tile in range(int(paged.offsets[-1])):
            paged._read(tile)
        hm = paged.heightmap
        camera = Camera((hm.extent / 2, hm.high + hm.extent, hm.extent * 1.2), 0.0, -40.0,
                        fov=60, far=10 * hm.extent + 10, near=0.01 * hm.extent + 1e-3)
        profile = get_profile("ipaq-hx2490b")
        selection = select_tiles(paged.pyramid, camera, profile.resolution, 1.0)
        if np.isfinite(paged.pyramid.flat_error).all():
            PagedArena(paged, profile).draw(selection, camera)
    finally:
        paged.close()


# play --page-budget values in MB (commands/options.py RANGES: (0, 2^20]).
BUDGET_TEXTS = [b"16", b"0.5", b"4", b"1048576"]


def load_page_budget(path):
    """--page-budget text through play's parser and its RANGES check."""
    from vismobile.app.cli import build_parser
    from vismobile.commands import options
    from vismobile.errors import VisMobileError

    text = path.read_bytes()[:256].decode("utf-8", errors="replace")
    try:
        args = build_parser().parse_args(["play", "t.vmtiles", "-o", str(path) + ".out",
                                          "--page-budget", text])
    except SystemExit:  # argparse's own refusal (exit 2, one usage line)
        raise VisMobileError(f"--page-budget {text!r}: not a number") from None
    options.check(args)
    assert 0.0 < args.page_budget <= 1 << 20


def load_heightmap(path):
    from vismobile.terrain.sources import load_file

    load_file(path)


ENTRY = {"obj": (load_obj, ".obj"), "vmp": (load_and_cull, ".vmp"),
         "trajectory": (load_trajectory, ".csv"), "glb": (load_textured, ".glb"),
         "cull": (load_cull_list, ".txt"), "structure": (load_structure, ".txt"),
         "selection": (load_selection, ".txt"), "scheduler": (load_scheduler, ".txt"),
         "ply": (load_mesh, ".ply"),
         "stl": (load_mesh, ".stl"), "off": (load_mesh, ".off"),
         "gz": (load_mesh, ".ply.gz"), "vmt": (load_vmt, ".vmt"),
         "vmtplay": (load_vmt_play, ".vmt"),
         "npy": (load_heightmap, ".npy"), "tif": (load_heightmap, ".tif"),
         "vmtiles": (load_vmtiles, ".vmtiles"), "objmtl": (load_textured_obj, ".obj"),
         "animglb": (load_animated, ".glb"), "motion": (load_motion, ".json"),
         "playmotion": (load_play_motion, ".json"), "fps": (load_fps, ".txt"),
         "regional": (load_regional, ".txt"), "budget": (load_page_budget, ".txt"),
         **fuzz_tiled.ENTRY, **fuzz_repair.ENTRY}


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

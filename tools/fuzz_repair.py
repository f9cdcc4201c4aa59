"""tools/fuzz.py's targets for the world repair (issue 29, world/tjunctions.py): `repair`, the
--repair option's text through `vismobile info`; `partrepair`, through `vismobile partition`
baking a conservative PVS (its default, auto, repairs a world with T-junctions); `objrepair`,
a mutated OBJ with T-junctions loaded with repair="tjunctions" and its contract checked (area
per parent, winding, no vertex left inside an edge)."""
from __future__ import annotations

import numpy as np

# a floor whose far edge (z = 2) runs past the foot of a wall standing on it in two quads
TJUNCTION_OBJ = (b"v 0 0 0\nv 2 0 0\nv 2 0 2\nv 0 0 2\n"
                 b"v 1 0 2\nv 0 1 2\nv 1 1 2\nv 2 1 2\n"
                 b"o floor\nf 1 4 3\nf 1 3 2\no wall\nf 4 6 7\nf 4 7 5\nf 5 7 8\nf 5 8 3\n")
REPAIR_TEXTS = [b"tjunctions", b"none"]
PARTITION_REPAIR_TEXTS = [b"auto", b"none", b"tjunctions"]


def repair_seeds() -> dict:
    return {"repair": REPAIR_TEXTS, "objrepair": [TJUNCTION_OBJ],
            "partrepair": PARTITION_REPAIR_TEXTS}


def _repair_option(path, argv):
    """The --repair value in path (its first 256 bytes as text) through the CLI command
    argv(world, text) on a small world with T-junctions (fuzz_options.run_option)."""
    from fuzz_options import run_option

    text = path.read_bytes()[:256].decode("utf-8", errors="replace").replace("\x00", "")
    world = path.with_name("tjunction.obj")
    if not world.exists():
        world.write_bytes(TJUNCTION_OBJ)
    run_option(argv(str(world), text), "--repair", text)


def load_repair(path):
    """info's --repair value."""
    _repair_option(path, lambda world, text: ["info", world, f"--repair={text}"])


def load_partition_repair(path):
    """partition's --repair value, baking a conservative PVS."""
    _repair_option(path, lambda world, text: [
        "partition", world, "--structure=grid:pvs=conservative", f"--repair={text}", "-o",
        str(path.with_suffix(".vmp"))])


def load_obj_repair(path):
    """A (mutated) OBJ loaded with repair="tjunctions": the contract holds or the load fails
    with a VisMobileError."""
    from vismobile.files.loader import load_world
    from vismobile.world.tjunctions import repair_tjunctions

    world = load_world(path)
    fixed, repair = repair_tjunctions(world)
    area = np.bincount(repair.parent, fixed.areas, world.triangle_count)
    scale = max(float(world.areas.max()), 1e-300)
    assert np.allclose(area, world.areas, rtol=1e-6, atol=1e-9 * scale), "area not kept"
    dots = (fixed.normals * world.normals[repair.parent]).sum(axis=1)
    wide = fixed.areas > 1e-9 * scale  # a sliver's normal is rounding noise
    assert (dots[wide] > 0).all(), "winding not kept"
    assert fixed.repair == "tjunctions" and load_world(path, "tjunctions").digest() == \
        fixed.digest()


ENTRY = {"repair": (load_repair, ".txt"), "objrepair": (load_obj_repair, ".obj"),
         "partrepair": (load_partition_repair, ".txt")}

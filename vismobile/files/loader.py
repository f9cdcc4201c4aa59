"""The one place a world file is dispatched on its type: a terrain .vmt (terrain/), else a mesh
file (World.from_file: OBJ, PLY, STL, OFF, glTF, GLB, optionally .gz). It sits above both
world/ and terrain/, so neither needs the other."""
from __future__ import annotations

from pathlib import Path


def load_world(path, repair=None):
    """World of a mesh file or of a terrain .vmt (its ground at a bounded stride plus its
    objects, terrain/mesh.py). Raises WorldError naming the file on unknown formats and bad
    input.

    repair : None / "none", or "tjunctions": split every triangle whose edge passes another's
             vertex (world/tjunctions.py; triangle ids change, `world.repair` says so)."""
    return repaired(_load(Path(path)), repair, path)


def repaired(world, repair, source="<world>"):
    """world after the named repair (None / "none": unchanged). VisMobileError naming the
    source for an unknown repair."""
    if repair in (None, "none"):
        return world
    if repair != "tjunctions":
        from ..errors import VisMobileError

        raise VisMobileError(f"{source}: unknown repair {repair!r} (none, tjunctions)")
    from ..world.tjunctions import repair_tjunctions

    return repair_tjunctions(world)[0]


def _load(path):
    if path.suffix.lower() == ".vmt":
        from ..terrain.mesh import terrain_world_file

        return terrain_world_file(path)
    if path.suffix.lower() in (".glb", ".gltf", ".obj"):
        from ..world.textures import textured_world  # base-colour textures, when it has any

        return textured_world(path)
    from ..world.world import World

    return World.from_file(path)


def open_world(text, worlds_dir=None, repair=None):
    """World of a world argument (thesis name or world file path); WorldError names a bad file.
    repair: as load_world's."""
    from ..scenes.lookup import world_file

    return load_world(world_file(text, worlds_dir), repair)

"""What a world argument names: a thesis world (w1..w7, built on first use) or a mesh file."""
from __future__ import annotations

from pathlib import Path

from .thesis import TARGETS


def is_thesis_world(text) -> bool:
    """True for a thesis world name, w1..w7 in any case (a file of that name is not looked for)."""
    return str(text).strip().lower() in TARGETS


def world_file(text, worlds_dir=None) -> Path:
    """Path of a world argument: a thesis name gives <worlds_dir>/<name>.obj, (re)built when
    missing or stale (worlds_dir None: scenes.default_cache_dir()); anything else is taken as
    the path of a mesh file and returned unchecked (files.loader.load_world reports a bad one)."""
    if not is_thesis_world(text):
        path = Path(text)
        if not path.suffix and not path.exists():  # "w7", "room": neither a world nor a file
            from ..errors import WorldError

            raise WorldError(text, "unknown world: thesis worlds are w1..w7; anything else is a "
                                   "mesh file (.obj .ply .stl .off .glb .gltf, optionally .gz)")
        return path
    from .thesis import build_key, build_world, default_cache_dir

    name = str(text).strip().lower()
    path = Path(worlds_dir if worlds_dir is not None else default_cache_dir()) / f"{name}.obj"
    key_path = path.with_suffix(".key")
    if not (path.is_file() and key_path.is_file()
            and key_path.read_text().strip() == build_key(name)):
        build_world(name, path.parent)
    return path


def animated_world(text, world, motion=None, worlds_dir=None):
    """The AnimatedWorld of a world argument `text` whose World is `world`, or None when nothing
    in it moves: a JSON motion file given (files/motionfile.py), a thesis world with its own
    (W7: thesis.motion_path), or a .glb/.gltf file whose first animation moves some nodes.
    WorldError names a bad motion or glTF file."""
    from ..world.animated import AnimatedWorld

    if motion is not None:
        return AnimatedWorld.from_motion_file(world, Path(motion))
    if is_thesis_world(text):
        from .thesis import motion_path

        path = motion_path(str(text).strip().lower(), worlds_dir)
        return None if path is None else AnimatedWorld.from_motion_file(world, path)
    if Path(str(text)).suffix.lower() in (".glb", ".gltf"):
        animated = AnimatedWorld.from_gltf(Path(str(text)))
        return animated if len(animated.motion) else None
    return None

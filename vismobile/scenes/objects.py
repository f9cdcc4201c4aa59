"""The thesis's objects (Table 5.4) from the models shipped in this package, decimated to the table's counts.

The models (vismobile/scenes/models/*.obj.gz, sources and licences in SOURCES.md there) lack a lamp, a flower, a penguin and a goblet; stand-ins take their place
(named in worlds/README.md). Each object is returned normalised: base centred on the origin,
standing on y = 0, height 1, outward winding.
"""
from __future__ import annotations

import functools
import os
from pathlib import Path

import numpy as np

from ..errors import WorldError

# kind: (model file in the models directory, Table 5.4 triangles)
OBJECTS = {
    "lamp": ("beetle.obj", 600),
    "teapot": ("teapot.obj", 1056),
    "bunny": ("stanford-bunny.obj", 1500),
    "dragon": ("dragon.obj", 1500),
    "flower": ("cheburashka.obj", 5288),
    "penguin": ("homer.obj", 4000),
    "goblet": ("suzanne.obj", 296),
    "cow": ("cow.obj", 1500),
}
# Decimation may stop a little short of the target; ask for up to this many more to hit it.
DECIMATION_RETRIES = 24


PACKAGE_MODELS = Path(__file__).resolve().parent / "models"


def models_dir() -> Path:
    """Directory of the object models: $VISMOBILE_MODELS, else the copies shipped in the package."""
    env = os.environ.get("VISMOBILE_MODELS")
    return Path(env) if env else PACKAGE_MODELS


def model_path(filename: str, directory=None) -> Path:
    """Path of a model in `directory` (default models_dir()): `filename`, else `filename`.gz.

    Returns the plain name when neither exists, so the caller's error names what was looked for.
    """
    path = (Path(directory) if directory else models_dir()) / filename
    if path.is_file():
        return path
    packed = path.with_name(path.name + ".gz")
    return packed if packed.is_file() else path


def model_size(filename: str, directory=None) -> int:
    """Uncompressed size in bytes of a model (-1 when missing): part of the worlds' build key."""
    path = model_path(filename, directory)
    if not path.is_file():
        return -1
    if path.suffix == ".gz":  # gzip's trailer holds the size modulo 2**32: ample for a model
        with open(path, "rb") as handle:
            handle.seek(-4, os.SEEK_END)
            return int.from_bytes(handle.read(4), "little")
    return path.stat().st_size


def decimate_exact(vertices, triangles, target: int) -> tuple:
    """Quadric decimation to exactly `target` triangles if a few nearby requests reach it.

    Returns (vertices (V,3) float64, triangles (target,3) int32); falls back to the largest
    count at or below the target.
    """
    from ..open3d_import import decimate

    best = None
    for extra in range(DECIMATION_RETRIES + 1):
        v, t = decimate(vertices, triangles, target + extra)
        if len(t) == target:
            return v, t
        if len(t) < target and (best is None or len(t) > len(best[1])):
            best = (v, t)
        if len(t) > target:
            break
    return refine_to(*best, target)


def refine_to(vertices, triangles, target: int) -> tuple:
    """Add the few triangles quadric decimation's pairwise collapses cannot leave out.

    An open edge split at its midpoint adds 1 triangle and a centroid split of the largest
    triangle adds 2, neither leaving a T-junction. Returns (vertices, triangles).
    """
    vertices, triangles = np.asarray(vertices, float), np.asarray(triangles, np.int32)
    while len(triangles) < target:
        missing = target - len(triangles)
        edges = np.sort(np.stack([triangles[:, [0, 1]], triangles[:, [1, 2]],
                                  triangles[:, [2, 0]]], axis=1).reshape(-1, 2), axis=1)
        unique, counts = np.unique(edges, axis=0, return_counts=True)
        open_edges = {tuple(e) for e in unique[counts == 1]}
        corners = vertices[triangles]
        areas = np.linalg.norm(np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]), axis=1)
        if missing % 2 and open_edges:
            flat = np.flatnonzero([tuple(e) in open_edges for e in edges])
            pick = flat[np.argmax(areas[flat // 3])]
            face, corner = divmod(int(pick), 3)
            a, b, c = np.roll(triangles[face], -corner)  # edge a-b is open
            vertices = np.vstack([vertices, (vertices[a] + vertices[b]) / 2])
            m = len(vertices) - 1
            triangles = np.vstack([np.delete(triangles, face, 0), [[a, m, c], [m, b, c]]])
        else:
            face = int(np.argmax(areas))
            a, b, c = triangles[face]
            vertices = np.vstack([vertices, corners[face].mean(axis=0)])
            m = len(vertices) - 1
            triangles = np.vstack([np.delete(triangles, face, 0), [[a, b, m], [b, c, m], [c, a, m]]])
    return vertices, triangles.astype(np.int32)


def outward(vertices, triangles) -> np.ndarray:
    """(T,3) int32 triangles wound consistently, flipped if the enclosed volume is negative."""
    import trimesh

    mesh = trimesh.Trimesh(vertices, triangles, process=False)
    if not mesh.is_winding_consistent:
        trimesh.repair.fix_winding(mesh)
    faces = np.asarray(mesh.faces, dtype=np.int32)
    if mesh.volume < 0:
        faces = faces[:, ::-1]
    return np.ascontiguousarray(faces)


@functools.lru_cache(maxsize=None)
def load_object(kind: str, directory: str | None = None) -> tuple:
    """(vertices (V,3) float64, triangles (T,3) int32) of a Table 5.4 object, unit height.

    Raises WorldError naming the model file if it is missing or unreadable.
    """
    from ..world.world import World

    filename, target = OBJECTS[kind]
    world = World.from_obj(model_path(filename, directory))
    vertices, triangles = decimate_exact(world.vertices, world.triangles, target)
    triangles = outward(vertices, triangles)
    low, high = vertices.min(axis=0), vertices.max(axis=0)
    vertices = (vertices - [(low[0] + high[0]) / 2, low[1], (low[2] + high[2]) / 2]) / (high[1] - low[1])
    vertices.setflags(write=False)
    triangles.setflags(write=False)
    return vertices, triangles


def placed(kind: str, height: float, position, yaw_degrees: float = 0.0) -> tuple:
    """An object scaled to `height` metres, turned about +y, its base centre at `position`."""
    vertices, triangles = load_object(kind)
    a = np.radians(yaw_degrees)
    rotation = np.array([[np.cos(a), 0.0, np.sin(a)], [0.0, 1.0, 0.0], [-np.sin(a), 0.0, np.cos(a)]])
    return vertices @ rotation.T * height + np.asarray(position, float), triangles


def check_models(directory=None) -> None:
    """Raise WorldError naming the first missing model file."""
    for filename, _ in OBJECTS.values():
        path = model_path(filename, directory)
        if not path.is_file():
            raise WorldError(path, "model missing (set VISMOBILE_MODELS to a directory holding "
                             "it as .obj or .obj.gz)")


# Model files by short name, for model_world (the full meshes, not decimated).
MODEL_FILES = {"cow": "cow.obj", "teapot": "teapot.obj", "bunny": "stanford-bunny.obj",
               "dragon": "dragon.obj", "beetle": "beetle.obj", "suzanne": "suzanne.obj",
               "homer": "homer.obj", "cheburashka": "cheburashka.obj"}


def model_world(name: str, size: float = 10.0, directory=None):
    """A shipped model at full resolution (MODEL_FILES) as a World of one object: longest side
    `size`, base centred on the origin, standing on y = 0. Raises WorldError naming a missing or
    bad file; KeyError lists the names."""
    from ..world.world import World

    if name not in MODEL_FILES:
        raise KeyError(f"unknown model {name!r}; valid: {', '.join(MODEL_FILES)}")
    world = World.from_file(model_path(MODEL_FILES[name], directory))
    low, high = world.extent
    base = np.array([(low[0] + high[0]) / 2, low[1], (low[2] + high[2]) / 2])
    world = world.transformed(1.0, -base).transformed(size / float((high - low).max()))
    world.name = name
    return world

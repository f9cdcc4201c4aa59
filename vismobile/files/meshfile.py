"""Mesh files other than OBJ (PLY, STL, OFF, glTF/GLB, each optionally .gz) and trimesh objects.

trimesh parses; this module flattens what it returns into the world's arrays: every mesh
instance of a scene, moved by its node's transform, becomes one object.
"""
from __future__ import annotations

import io
from pathlib import Path

import numpy as np

from ..errors import WorldError, one_line
from .limits import MAX_COORDINATE, MAX_TRIANGLES, quiet_parser, read_input

# Suffix (without .gz) -> trimesh file type; .obj goes through the validating reader in obj.py.
FORMATS = {".obj": "obj", ".ply": "ply", ".stl": "stl", ".off": "off", ".glb": "glb",
           ".gltf": "gltf"}


def mesh_format(path) -> str:
    """trimesh file type of a path by its suffix (a trailing .gz ignored); WorldError if unknown."""
    path = Path(path)
    name = path.name.lower()
    stem = name[:-3] if name.endswith(".gz") else name
    suffix = Path(stem).suffix
    if suffix not in FORMATS:
        raise WorldError(path, f"unsupported mesh format {suffix or '(no suffix)'!r}; expected "
                         + ", ".join(FORMATS) + " (optionally .gz)")
    return FORMATS[suffix]


def load_mesh(path) -> tuple:
    """(vertices (V,3) f8, triangles (T,3) i4, object_ids (T,) i4, names) of a PLY, STL, OFF,
    glTF or GLB file (optionally gzip-compressed). Raises WorldError naming the file.

    Before trimesh parses: only a regular file is read, within MAX_BYTES (a .gz inflated with
    a running limit); PLY and OFF headers may not declare more elements than the file can hold
    or than MAX_TRIANGLES; a glTF's node graph must be a tree, its instanced triangles within
    MAX_TRIANGLES and its buffer and image URIs regular files beside it (meshcheck.py)."""
    import trimesh

    from . import meshcheck

    path = Path(path)
    file_type = mesh_format(path)
    data = read_input(path)
    meshcheck.check(path, file_type, data)
    if path.name.lower().endswith(".gz"):
        source = io.BytesIO(data)
    else:
        source = str(path)  # a path lets trimesh find a .gltf's external buffers (checked)
    del data
    try:
        with np.errstate(all="ignore"), quiet_parser():  # overflow: a coordinate limit below
            scene = trimesh.load(source, file_type=file_type, force="scene", process=False)
    except Exception as error:  # trimesh raises assorted types on malformed input
        raise WorldError(path, f"unparsable {file_type.upper()} ({type(error).__name__}: "
                         f"{one_line(error)[:200]})") from None
    return flatten(scene, path)


def flatten(geometry, origin="<trimesh>") -> tuple:
    """(vertices, triangles, object_ids, names) of a trimesh.Trimesh or trimesh.Scene.

    A scene contributes one object per node holding a mesh, its vertices moved by the node's
    world transform (faces reversed under a mirroring transform, so front faces stay front);
    objects are ordered by node name. Point clouds and paths are skipped. WorldError names
    `origin` when no triangles remain or a vertex is not finite.
    """
    import trimesh

    if isinstance(geometry, trimesh.Trimesh):
        parts = [(str(geometry.metadata.get("name") or "mesh"), geometry, np.eye(4))]
    elif isinstance(geometry, trimesh.Scene):
        parts = []
        with np.errstate(all="ignore"):  # transforms that overflow are refused below
            for node in sorted(geometry.graph.nodes_geometry, key=str):
                transform, geometry_name = geometry.graph[node]
                mesh = geometry.geometry.get(geometry_name)
                if isinstance(mesh, trimesh.Trimesh):
                    parts.append((str(node), mesh, np.asarray(transform, float)))
    else:
        raise WorldError(origin, f"expected a trimesh.Trimesh or Scene, got {type(geometry).__name__}")
    total = sum(len(mesh.faces) for _, mesh, _ in parts)
    if total > MAX_TRIANGLES:
        raise WorldError(origin, f"{total:,} triangles in its mesh instances, over the limit of "
                                 f"{MAX_TRIANGLES:,}")
    vertices, triangles, ids, names, offset = [], [], [], [], 0
    for name, mesh, transform in parts:
        if not len(mesh.faces):
            continue
        faces = np.asarray(mesh.faces, np.int64)
        local = np.asarray(mesh.vertices, float)
        if faces.min() < 0 or faces.max() >= len(local):  # trimesh keeps them as read
            bad = faces[(faces < 0) | (faces >= len(local))][0]
            raise WorldError(origin, f"mesh {name!r}: face index {bad} outside its "
                                     f"{len(local):,} vertices")
        with np.errstate(all="ignore"):  # an overflowing transform is refused just below
            v = local @ transform[:3, :3].T + transform[:3, 3]
            flip = np.linalg.det(transform[:3, :3]) < 0 if np.isfinite(transform).all() else False
        if not (np.abs(v) <= MAX_COORDINATE).all():  # NaN and infinity too
            what = "NaN or infinite" if not np.isfinite(v).all() else \
                f"beyond +-{MAX_COORDINATE:g}"
            raise WorldError(origin, f"mesh {name!r}: vertex coordinate {what} (after its "
                                     "node's transform)")
        if flip:
            faces = faces[:, ::-1]
        vertices.append(v)
        triangles.append(faces + offset)
        ids.append(np.full(len(faces), len(names), np.int32))
        names.append(name)
        offset += len(v)
    if not names:
        raise WorldError(origin, "no triangles (only empty meshes, points or lines)")
    vertices = np.concatenate(vertices)
    return vertices, np.concatenate(triangles).astype(np.int32), np.concatenate(ids), names

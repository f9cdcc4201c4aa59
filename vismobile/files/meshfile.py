"""Mesh files other than OBJ (PLY, STL, OFF, glTF/GLB, each optionally .gz) and trimesh objects.

trimesh parses; this module flattens what it returns into the world's arrays: every mesh
instance of a scene, moved by its node's transform, becomes one object.
"""
from __future__ import annotations

import gzip
import io
import zlib
from pathlib import Path

import numpy as np

from ..errors import WorldError

# Suffix (without .gz) -> trimesh file type; .obj goes through the validating reader in obj.py.
FORMATS = {".obj": "obj", ".ply": "ply", ".stl": "stl", ".off": "off", ".glb": "glb",
           ".gltf": "gltf"}
MAX_BYTES = 1 << 30


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
    glTF or GLB file (optionally gzip-compressed). Raises WorldError naming the file."""
    import trimesh

    path = Path(path)
    file_type = mesh_format(path)
    if not path.is_file():
        raise WorldError(path, "no such file" if not path.exists() else "not a file")
    if path.stat().st_size == 0:
        raise WorldError(path, "file is empty")
    if path.stat().st_size > MAX_BYTES:
        raise WorldError(path, f"file is over the {MAX_BYTES} byte limit")
    if path.name.lower().endswith(".gz"):
        try:
            source = io.BytesIO(gzip.decompress(path.read_bytes()))
        except (OSError, EOFError, zlib.error) as error:
            raise WorldError(path, f"not a readable gzip file ({error})") from None
    else:
        source = str(path)  # a path lets trimesh find a .gltf's external buffers
    try:
        scene = trimesh.load(source, file_type=file_type, force="scene", process=False)
    except Exception as error:  # trimesh raises assorted types on malformed input
        raise WorldError(path, f"unparsable {file_type.upper()} ({type(error).__name__}: "
                         f"{error})") from None
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
        for node in sorted(geometry.graph.nodes_geometry, key=str):
            transform, geometry_name = geometry.graph[node]
            mesh = geometry.geometry.get(geometry_name)
            if isinstance(mesh, trimesh.Trimesh):
                parts.append((str(node), mesh, np.asarray(transform, float)))
    else:
        raise WorldError(origin, f"expected a trimesh.Trimesh or Scene, got {type(geometry).__name__}")
    vertices, triangles, ids, names, offset = [], [], [], [], 0
    for name, mesh, transform in parts:
        if not len(mesh.faces):
            continue
        v = np.asarray(mesh.vertices, float) @ transform[:3, :3].T + transform[:3, 3]
        faces = np.asarray(mesh.faces, np.int64)
        if np.linalg.det(transform[:3, :3]) < 0:
            faces = faces[:, ::-1]
        vertices.append(v)
        triangles.append(faces + offset)
        ids.append(np.full(len(faces), len(names), np.int32))
        names.append(name)
        offset += len(v)
    if not names:
        raise WorldError(origin, "no triangles (only empty meshes, points or lines)")
    vertices = np.concatenate(vertices)
    if not np.isfinite(vertices).all():
        raise WorldError(origin, "vertex coordinate is NaN or infinite")
    return vertices, np.concatenate(triangles).astype(np.int32), np.concatenate(ids), names

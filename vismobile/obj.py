"""OBJ input: a line-level validator for clear errors, then trimesh for the parsing itself."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from .errors import WorldError

# Statements of the OBJ format (geometry, grouping, display and free-form); anything else is garbage.
KNOWN_STATEMENTS = frozenset(
    "v vt vn vp f l p o g s mtllib usemtl usemap maplib shadow_obj trace_obj lod bevel "
    "c_interp d_interp ctech stech cstype deg bmat step curv curv2 surf parm trim hole "
    "scrv sp end con mg call csh".split())
MAX_BYTES = 1 << 30


def validate_obj(path: Path, text: str) -> None:
    """Raise WorldError at the first line that trimesh would misread or silently drop.

    Checks statement keywords, vertex coordinates (three finite numbers) and face indices
    (integers within the vertices defined so far, negative ones relative).
    """
    vertex_count = 0
    for number, line in enumerate(text.splitlines(), start=1):
        fields = line.split()
        if not fields or fields[0].startswith("#"):
            continue
        keyword = fields[0]
        if keyword not in KNOWN_STATEMENTS:
            raise WorldError(path, f"unparsable statement {keyword[:20]!r}", number)
        if keyword == "v":
            try:
                coords = [float(value) for value in fields[1:4]]
            except ValueError:
                raise WorldError(path, "vertex coordinate is not a number", number) from None
            if len(coords) < 3:
                raise WorldError(path, "vertex has fewer than 3 coordinates", number)
            if not all(math.isfinite(c) for c in coords):
                raise WorldError(path, "vertex coordinate is NaN or infinite", number)
            vertex_count += 1
        elif keyword == "f":
            if len(fields) < 4:
                raise WorldError(path, "face has fewer than 3 corners", number)
            for corner in fields[1:]:
                try:
                    index = int(corner.split("/")[0])
                except ValueError:
                    raise WorldError(path, f"face index {corner[:20]!r} is not an integer",
                                     number) from None
                resolved = index + vertex_count + 1 if index < 0 else index
                if not 1 <= resolved <= vertex_count:
                    raise WorldError(path, f"face index {index} out of range "
                                     f"(1..{vertex_count} vertices defined)", number)


def read_text(path: Path) -> str:
    """File contents as text, or WorldError for missing, unreadable, empty or binary files."""
    if not path.exists():
        raise WorldError(path, "no such file")
    if path.is_dir():
        raise WorldError(path, "is a directory, not an OBJ file")
    size = path.stat().st_size
    if size == 0:
        raise WorldError(path, "file is empty")
    if size > MAX_BYTES:
        raise WorldError(path, f"file is {size} bytes, over the {MAX_BYTES} byte limit")
    data = path.read_bytes()
    if b"\x00" in data:
        raise WorldError(path, "binary content, not an OBJ text file",
                         data[: data.index(b"\x00")].count(b"\n") + 1)
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as error:
        try:
            return data.decode("latin-1")
        except UnicodeDecodeError:  # pragma: no cover - latin-1 decodes every byte
            raise WorldError(path, "not text", data[: error.start].count(b"\n") + 1) from None


def load_obj(path) -> tuple:
    """Parse an OBJ with trimesh: (vertices (V,3) f8, triangles (T,3) i4, object_ids (T,) i4, names).

    Polygons are triangulated and coincident vertices welded by trimesh; missing .mtl and
    texture files are ignored. Raises WorldError with file and line on bad input.
    """
    import trimesh

    path = Path(path)
    text = read_text(path)
    if not text.strip():
        raise WorldError(path, "file holds only white space")
    validate_obj(path, text)
    try:
        scene = trimesh.load(path, file_type="obj", force="scene", split_objects=True,
                             split_groups=True, group_material=False, process=True,
                             skip_materials=True)
    except Exception as error:  # trimesh raises assorted types on malformed input
        raise WorldError(path, f"unparsable OBJ ({type(error).__name__}: {error})") from None
    meshes = [(name, geometry) for name, geometry in scene.geometry.items()
              if isinstance(geometry, trimesh.Trimesh) and len(geometry.faces)]
    if not meshes:
        raise WorldError(path, "no faces")
    vertices, triangles, ids, names = [], [], [], []
    offset = 0
    for name, mesh in sorted(meshes, key=lambda item: item[0]):
        mesh.merge_vertices()
        vertices.append(np.asarray(mesh.vertices, dtype=np.float64))
        triangles.append(np.asarray(mesh.faces, dtype=np.int64) + offset)
        ids.append(np.full(len(mesh.faces), len(names), dtype=np.int32))
        names.append(str(name))
        offset += len(mesh.vertices)
    return (np.concatenate(vertices), np.concatenate(triangles).astype(np.int32),
            np.concatenate(ids), names)

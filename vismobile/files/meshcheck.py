"""Checks of a mesh file's structure before trimesh parses it (issue 28), so that a file that
declares more than it holds, loops, or multiplies itself is refused in one line, before any
allocation its declarations would cause.

- PLY and OFF: declared vertex and face counts at most MAX_TRIANGLES and at most what the
  file's bytes can hold (an OFF declaring 2e9 faces but holding one loaded silently).
- glTF/GLB images: width x height from the image's header, at most MAX_IMAGE_PIXELS (a 12000^2
  one-bit PNG of 24 KB decoded to RGBA took 1.9 GB and played, with PIL's bomb warning).
- glTF/GLB: the JSON (GLB: its first chunk) parses, nesting counted without recursion; nodes
  form a forest (children in range, each node at most one parent, no cycle: a node that is its
  own child looped trimesh); the triangles its mesh instances draw, counted from the index
  accessors times the nodes showing each mesh, at most MAX_TRIANGLES (a 27-node DAG drew one
  mesh 67 million times); every buffer and image URI that is not a data: URI names a regular
  file inside the glTF's folder (a FIFO hung, /dev/zero never ended), within MAX_BYTES.
"""
from __future__ import annotations

import json
import re
import struct
from pathlib import Path

from ..errors import WorldError
from .limits import MAX_BYTES, MAX_TRIANGLES, regular_file

MAX_NESTING = 64  # JSON depth of a glTF
MAX_IMAGE_PIXELS = 1 << 26  # a texture's pixels (8192^2: the largest any profile draws)
MAX_NODES = 1 << 16  # trimesh's scene graph costs ~5 KB a node (300,000 nodes: 1.5 GB, minutes)


def check(path: Path, file_type: str, data: bytes) -> None:
    """WorldError naming path when data (the file, decompressed) fails its format's checks."""
    if file_type == "ply":
        _ply(path, data)
    elif file_type == "off":
        _off(path, data)
    elif file_type in ("gltf", "glb"):
        doc = _gltf_json(path, file_type, data)
        _gltf(path, doc, path.name.lower().endswith(".gz"))
        _images(path, doc, _glb_binary(data) if file_type == "glb" else None)


def _declared(path, what, count, room) -> None:
    if count > MAX_TRIANGLES:
        raise WorldError(path, f"declares {count:,} {what}, over the limit of "
                               f"{MAX_TRIANGLES:,}")
    if count > room:
        raise WorldError(path, f"declares {count:,} {what} but holds at most {room:,} "
                               "(truncated or corrupt)")


# ---- PLY ----------------------------------------------------------------------------------------
_PLY_SIZES = {"char": 1, "uchar": 1, "int8": 1, "uint8": 1, "short": 2, "ushort": 2, "int16": 2,
              "uint16": 2, "int": 4, "uint": 4, "int32": 4, "uint32": 4, "float": 4,
              "float32": 4, "double": 8, "float64": 8}


def _ply(path, data: bytes) -> None:
    end = data.find(b"end_header", 0, 1 << 16)
    if not data.startswith(b"ply") or end < 0:
        raise WorldError(path, "not a PLY file (no 'ply' ... 'end_header' header)")
    lines = data[:end].decode("latin-1").splitlines()
    body = len(data) - end - len(b"end_header\n")
    fmt, elements = "ascii", []
    for line in lines:
        words = line.split()
        if words[:1] == ["format"] and len(words) > 1:
            fmt = words[1]
        elif words[:1] == ["element"] and len(words) == 3:
            if not re.fullmatch(r"\d{1,12}", words[2]):
                raise WorldError(path, f"PLY element {words[1]!r} count {words[2]!r} is not a "
                                       "whole number")
            elements.append([words[1], int(words[2]), 0])
        elif words[:1] == ["property"] and elements:
            if len(words) >= 5 and words[1] == "list":  # count type + at least one item
                elements[-1][2] += _PLY_SIZES.get(words[2], 1) + _PLY_SIZES.get(words[3], 1)
            elif len(words) >= 3:
                elements[-1][2] += _PLY_SIZES.get(words[1], 1)
    total = sum(count for _, count, _ in elements)
    if total > 2 * MAX_TRIANGLES:
        raise WorldError(path, f"declares {total:,} elements, over the limit of "
                               f"{2 * MAX_TRIANGLES:,}")
    for name, count, row in elements:
        # ascii: each property at least one character and a separator; binary: its bytes
        room = body // max(1, 2 * max(row and 1, 1)) if fmt == "ascii" else body // max(row, 1)
        _declared(path, f"{name} elements", count, room)


# ---- OFF ------------------------------------------------------------------------------------------
def _off(path, data: bytes) -> None:
    counts, position = [], 0
    for line in data[:1 << 16].splitlines(keepends=True):  # "OFF", then V F [E]: comments,
        position += len(line)                                # blank lines, one line or two
        words = line.split(b"#", 1)[0].split()
        if not counts and words and words[0].endswith(b"OFF"):
            words = words[1:]
        counts += words
        if len(counts) >= 2:
            break
    try:
        vertices, faces = int(counts[0]), int(counts[1])
    except (IndexError, ValueError):
        raise WorldError(path, "OFF header has no vertex and face counts") from None
    if vertices < 0 or faces < 0:
        raise WorldError(path, "OFF header has a negative count")
    room = (max(len(data) - position, 0) + 1) // 2  # a number: a digit and a separator
    _declared(path, "vertices", vertices, room // 3)
    _declared(path, "faces", faces, room // 4)
    if 3 * vertices + 4 * faces > room:
        raise WorldError(path, f"declares {vertices:,} vertices and {faces:,} faces but holds "
                               "fewer numbers (truncated or corrupt)")


# ---- glTF / GLB ---------------------------------------------------------------------------------
def _depth(text: str) -> int:
    """Deepest [ / { nesting of JSON text, strings skipped, without recursion."""
    depth = deepest = 0
    for token in re.finditer(r'"(?:[^"\\]|\\.)*"|[\[\]{}]', text):
        mark = token.group()
        if mark in "[{":
            depth += 1
            deepest = max(deepest, depth)
        elif mark in "]}":
            depth -= 1
    return deepest


def _gltf_json(path, file_type, data: bytes) -> dict:
    if file_type == "glb":
        if len(data) < 20 or data[:4] != b"glTF":
            raise WorldError(path, "not a GLB file (bad magic)")
        length, kind = struct.unpack_from("<I4s", data, 12)
        if kind != b"JSON" or length > len(data) - 20:
            raise WorldError(path, "GLB's first chunk is not its JSON, or runs past the file")
        data = data[20:20 + length]
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError:
        raise WorldError(path, "glTF JSON is not UTF-8") from None
    if _depth(text) > MAX_NESTING:
        raise WorldError(path, f"glTF JSON nested deeper than {MAX_NESTING} levels")
    try:
        doc = json.loads(text)
    except ValueError as error:
        raise WorldError(path, f"glTF JSON does not parse ({error})") from None
    if not isinstance(doc, dict):
        raise WorldError(path, "glTF JSON is not an object")
    return doc


def _list(path, doc, key) -> list:
    value = doc.get(key, [])
    if not isinstance(value, list) or not all(isinstance(v, dict) for v in value):
        raise WorldError(path, f"glTF {key} must be a list of objects")
    return value


def _index(path, value, count, what) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value < count:
        raise WorldError(path, f"glTF {what} {value!r} is not an index below {count}")
    return value


def _gltf(path, doc: dict, compressed: bool) -> None:
    nodes, meshes = _list(path, doc, "nodes"), _list(path, doc, "meshes")
    accessors = _list(path, doc, "accessors")
    if len(nodes) > MAX_NODES:
        raise WorldError(path, f"glTF has {len(nodes):,} nodes, over the limit of {MAX_NODES:,}")
    parent = {}
    for n, node in enumerate(nodes):
        children = node.get("children", [])
        if not isinstance(children, list):
            raise WorldError(path, f"glTF node {n}'s children must be a list")
        for child in children:
            _index(path, child, len(nodes), f"node {n}'s child")
            if child == n:
                raise WorldError(path, f"glTF node {n} is its own child")
            if child in parent:
                raise WorldError(path, f"glTF node {child} has two parents ({parent[child]} and "
                                       f"{n}); nodes must form a tree")
            parent[child] = n
        if "mesh" in node:
            _index(path, node["mesh"], len(meshes), f"node {n}'s mesh")
    for n in range(len(nodes)):  # with one parent each, a cycle is a walk up that returns
        seen, up = set(), n
        while up in parent:
            if up in seen:
                raise WorldError(path, f"glTF nodes form a cycle through node {up}")
            seen.add(up)
            up = parent[up]
    triangles = []
    for m, mesh in enumerate(meshes):
        count = 0
        for primitive in mesh.get("primitives", []) if isinstance(mesh.get("primitives"),
                                                                  list) else []:
            if not isinstance(primitive, dict):
                continue
            ref = primitive.get("indices", (primitive.get("attributes") or {}).get("POSITION")
                                if isinstance(primitive.get("attributes"), dict) else None)
            if ref is None:
                continue
            accessor = accessors[_index(path, ref, len(accessors), f"mesh {m}'s accessor")]
            value = accessor.get("count", 0)
            count += value // 3 if isinstance(value, int) and value > 0 else 0
        triangles.append(count)
    total = sum(triangles[node["mesh"]] for node in nodes if "mesh" in node)
    if total > MAX_TRIANGLES:
        raise WorldError(path, f"its nodes draw {total:,} triangles, over the limit of "
                               f"{MAX_TRIANGLES:,}")
    folder = Path(path).resolve().parent
    for key in ("buffers", "images"):
        for k, item in enumerate(_list(path, doc, key)):
            uri = item.get("uri")
            if uri is None or (isinstance(uri, str) and uri.startswith("data:")):
                continue
            if not isinstance(uri, str):
                raise WorldError(path, f"glTF {key}[{k}] uri must be a string")
            if compressed:
                raise WorldError(path, f"glTF {key}[{k}] refers to {uri!r}; a .gz glTF must "
                                       "embed its buffers")
            def refuse(_, why, k=k, key=key, uri=uri):
                return WorldError(path, f"glTF {key}[{k}] {uri!r}: {why}")

            target = folder / uri  # as trimesh resolves it (no %-decoding)
            if regular_file(target, refuse) > MAX_BYTES:
                raise WorldError(path, f"glTF {key}[{k}] {uri!r} is over {MAX_BYTES:,} bytes")
            if folder not in target.resolve().parents:
                raise WorldError(path, f"glTF {key}[{k}] uri {uri!r} is outside the file's "
                                       "folder")


def _glb_binary(data: bytes) -> memoryview | None:
    """The GLB's BIN chunk (the second), or None."""
    length = struct.unpack_from("<I", data, 12)[0]
    start = 20 + length + (-length % 4)
    if len(data) < start + 8:
        return None
    size, kind = struct.unpack_from("<I4s", data, start)
    return memoryview(data)[start + 8:start + 8 + size] if kind == b"BIN\0" else None


def _image_head(path, doc, binary, image: dict) -> bytes | None:
    """The first bytes (up to HEAD) of a glTF image: from its data: URI, its file beside the
    glTF, or its buffer view (GLB BIN chunk or an external buffer); None when not found."""
    import base64

    head = 1 << 20
    uri = image.get("uri")
    if isinstance(uri, str) and uri.startswith("data:"):
        encoded = uri.split(",", 1)[-1][:head * 4 // 3 + 4]
        try:
            return base64.b64decode(encoded[:len(encoded) // 4 * 4])
        except ValueError:
            return None
    if isinstance(uri, str):
        with open(Path(path).resolve().parent / uri, "rb") as handle:  # checked regular
            return handle.read(head)
    views, buffers = doc.get("bufferViews", []), doc.get("buffers", [])
    view = image.get("bufferView")
    if not isinstance(view, int) or isinstance(view, bool) or not 0 <= view < len(views):
        return None
    view = views[view]
    offset, index = view.get("byteOffset", 0), view.get("buffer", 0)
    if not isinstance(offset, int) or not isinstance(index, int) or not 0 <= index < len(buffers):
        return None
    uri = buffers[index].get("uri")
    if uri is None:
        return None if binary is None else bytes(binary[offset:offset + head])
    if isinstance(uri, str) and not uri.startswith("data:"):
        with open(Path(path).resolve().parent / uri, "rb") as handle:
            handle.seek(max(offset, 0))
            return handle.read(head)
    return None


def _images(path, doc: dict, binary) -> None:
    """Each image's width x height, read from its header, at most MAX_IMAGE_PIXELS."""
    import io
    import warnings

    from PIL import Image

    for k, image in enumerate(_list(path, doc, "images")):
        data = _image_head(path, doc, binary, image)
        if not data:
            continue
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")  # PIL's own bomb warning: we decide below
                width, height = Image.open(io.BytesIO(data)).size
        except Image.DecompressionBombError as error:  # over twice PIL's limit: over ours
            raise WorldError(path, f"glTF image {k}: {error}") from None
        except Exception:  # noqa: BLE001 - not an image PIL reads: trimesh skips it too
            continue
        if width * height > MAX_IMAGE_PIXELS:
            raise WorldError(path, f"glTF image {k} has {width:,}x{height:,} pixels, over the "
                                   f"limit of {MAX_IMAGE_PIXELS:,}")

"""glTF/GLB scenes with node animations (pygltflib reads them; trimesh does not): the meshes as
triangle arrays, one object per mesh node, and the first animation's translation, rotation and
scale channels as tracks for world/motion.py.

Every mesh node moves with its nearest animated ancestor (or itself). With the animated node's
parent world transform P and rest TRS R, a vertex at rest v_rest = P R L v_local stands at
P TRS(t) R^-1 P^-1 v_rest at time t: post = P, pre = (P R)^-1 (motion.py). A mesh under two
animated nodes is refused (one line), and so is CUBICSPLINE interpolation, a sampler whose
channels mix interpolations on one node, morph-target (weights) channels are ignored.
The file is checked first as any glTF (meshcheck.py: size, node tree, buffer URIs), and every
accessor is bounds-checked against its buffer view before it is read.
"""
from __future__ import annotations

import base64
import struct
from pathlib import Path

import numpy as np

from ..errors import WorldError, one_line
from .limits import MAX_BYTES, MAX_COORDINATE, MAX_TRIANGLES, read_bytes, read_input
from .meshfile import mesh_format

COMPONENTS = {5120: np.int8, 5121: np.uint8, 5122: np.int16, 5123: np.uint16, 5125: np.uint32,
              5126: np.float32}
WIDTHS = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT4": 16}
PATHS = {"translation": 3, "rotation": 4, "scale": 3}


class _Reader:
    """Accessors of one parsed glTF, every range checked (WorldError naming the file)."""

    def __init__(self, path, gltf, data: bytes, file_type: str):
        self.path, self.gltf = path, gltf
        self.buffers = []
        for k, buffer in enumerate(gltf.buffers or []):
            uri = buffer.uri
            if uri is None:
                blob = gltf.binary_blob() if file_type == "glb" else None
                if blob is None:
                    raise WorldError(path, f"glTF buffers[{k}] has no uri and no GLB chunk")
                self.buffers.append(bytes(blob))
            elif uri.startswith("data:"):
                try:
                    self.buffers.append(base64.b64decode(uri.split(",", 1)[1], validate=True))
                except (ValueError, IndexError):
                    raise WorldError(path, f"glTF buffers[{k}] data uri is not base64") from None
            else:  # meshcheck made sure it is a regular file beside it, within MAX_BYTES
                self.buffers.append(read_bytes(Path(path).resolve().parent / uri, MAX_BYTES))

    def fail(self, message):
        return WorldError(self.path, message)

    def read(self, index, what) -> np.ndarray:
        """(count, width) array of accessor `index` (normalised integers are refused)."""
        accessors = self.gltf.accessors or []
        if not isinstance(index, int) or not 0 <= index < len(accessors):
            raise self.fail(f"glTF {what}: accessor {index!r} does not exist")
        a = accessors[index]
        if a.sparse is not None:
            raise self.fail(f"glTF accessor {index} is sparse (not supported)")
        dtype = COMPONENTS.get(a.componentType)
        width = WIDTHS.get(a.type)
        count = a.count
        if dtype is None or width is None or not isinstance(count, int) or count < 0:
            raise self.fail(f"glTF accessor {index}: unsupported type {a.type}/{a.componentType}")
        if count > 4 * MAX_TRIANGLES:
            raise self.fail(f"glTF accessor {index}: {count:,} elements, over the limit")
        views = self.gltf.bufferViews or []
        if a.bufferView is None:
            return np.zeros((count, width), dtype=dtype)
        if not 0 <= a.bufferView < len(views):
            raise self.fail(f"glTF accessor {index}: buffer view {a.bufferView} does not exist")
        view = views[a.bufferView]
        if not 0 <= view.buffer < len(self.buffers):
            raise self.fail(f"glTF buffer view {a.bufferView}: buffer {view.buffer} does not exist")
        data = self.buffers[view.buffer]
        size = np.dtype(dtype).itemsize * width
        stride = view.byteStride or size
        start = (view.byteOffset or 0) + (a.byteOffset or 0)
        need = start + (stride * (count - 1) + size if count else 0)
        end = (view.byteOffset or 0) + (view.byteLength or 0)
        if start < 0 or stride < size or need > end or end > len(data):
            raise self.fail(f"glTF accessor {index} runs past its buffer view or buffer")
        if count == 0:
            return np.zeros((0, width), dtype=dtype)
        raw = np.frombuffer(data, dtype=np.uint8, count=need - start, offset=start)
        rows = np.lib.stride_tricks.as_strided(raw, shape=(count, size), strides=(stride, 1))
        return np.ascontiguousarray(rows).view(dtype).reshape(count, width)


def _node_matrix(node) -> np.ndarray:
    if node.matrix is not None:
        return np.asarray(node.matrix, dtype=np.float64).reshape(4, 4).T  # column-major
    return _trs(node.translation or (0, 0, 0), node.rotation or (0, 0, 0, 1),
                node.scale or (1, 1, 1))


def _trs(t, r, s) -> np.ndarray:
    """(4, 4) float64 T @ R @ S of a translation, unit quaternion (x, y, z, w) and scale."""
    x, y, z, w = np.asarray(r, dtype=np.float64) / max(np.linalg.norm(r), 1e-300)
    rot = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                    [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                    [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])
    out = np.eye(4)
    out[:3, :3] = rot * np.asarray(s, dtype=np.float64)
    out[:3, 3] = t
    return out


def _channels(path, gltf, reader) -> dict:
    """{node: {"translation": (times, values), ..., "interpolation": str}} of the first
    animation (empty without one)."""
    out = {}
    if not gltf.animations:
        return out
    animation = gltf.animations[0]
    samplers = animation.samplers or []
    for c, channel in enumerate(animation.channels or []):
        target = channel.target
        if target is None or target.path == "weights" or target.node is None:
            continue  # morph weights move no vertex of ours
        if target.path not in PATHS:
            raise WorldError(path, f"glTF animation channel {c}: path {target.path!r}")
        if not 0 <= target.node < len(gltf.nodes or []):
            raise WorldError(path, f"glTF animation channel {c}: node {target.node} does not "
                                   "exist")
        if not isinstance(channel.sampler, int) or not 0 <= channel.sampler < len(samplers):
            raise WorldError(path, f"glTF animation channel {c}: sampler {channel.sampler!r} "
                                   "does not exist")
        sampler = samplers[channel.sampler]
        mode = sampler.interpolation or "LINEAR"
        if mode not in ("LINEAR", "STEP"):
            raise WorldError(path, f"glTF animation channel {c}: {mode} interpolation is not "
                                   "supported (LINEAR and STEP are)")
        times = reader.read(sampler.input, f"channel {c} input").astype(np.float64)[:, 0]
        values = reader.read(sampler.output, f"channel {c} output").astype(np.float64)
        if values.shape != (len(times), PATHS[target.path]):
            raise WorldError(path, f"glTF animation channel {c}: {len(values)} values of width "
                                   f"{values.shape[1]} for {len(times)} {target.path} keys")
        entry = out.setdefault(target.node, {"interpolation": mode.lower()})
        if entry["interpolation"] != mode.lower():
            raise WorldError(path, f"glTF node {target.node}: its channels mix LINEAR and STEP")
        entry[target.path] = (times, values)
    return out


def _scene(path, gltf, reader) -> tuple:
    nodes = gltf.nodes or []
    channels = _channels(path, gltf, reader)
    scene = gltf.scenes[gltf.scene or 0] if gltf.scenes else None
    roots = list(scene.nodes or []) if scene is not None else \
        sorted(set(range(len(nodes))) - {c for n in nodes for c in (n.children or [])})
    vertices, triangles, ids, names, tracks = [], [], [], [], []
    anchor_of = {}  # animated node -> its track index
    used, offset = set(), 0
    stack = [(r, np.eye(4), None) for r in reversed(roots)]
    while stack:  # meshcheck made the node graph a tree
        n, parent, animated = stack.pop()
        node = nodes[n]
        local = _node_matrix(node)
        if n in channels:
            if animated is not None:
                raise WorldError(path, f"glTF node {n} is animated under animated node "
                                       f"{animated[0]} (nested animations are not supported)")
            animated = (n, parent, local)
        world = parent @ local
        if node.mesh is not None:
            name = node.name or f"node{n}"
            name = name if name not in used else f"{name}#{n}"
            used.add(name)
            count = 0
            for p, primitive in enumerate(gltf.meshes[node.mesh].primitives or []):
                mode = 4 if primitive.mode is None else primitive.mode
                if mode != 4:
                    continue  # points, lines, strips: not triangles of ours
                position = reader.read(primitive.attributes.POSITION,
                                       f"mesh {node.mesh} POSITION").astype(np.float64)
                if position.shape[1] != 3:
                    raise WorldError(path, f"glTF mesh {node.mesh}: POSITION is not VEC3")
                if primitive.indices is None:
                    index = np.arange(len(position) - len(position) % 3, dtype=np.int64)
                else:
                    index = reader.read(primitive.indices, f"mesh {node.mesh} indices")
                    index = index.astype(np.int64).reshape(-1)
                    index = index[:len(index) - len(index) % 3]
                if len(index) and (index.min() < 0 or index.max() >= len(position)):
                    raise WorldError(path, f"glTF mesh {node.mesh}: an index outside its "
                                           f"{len(position):,} vertices")
                with np.errstate(all="ignore"):
                    v = position @ world[:3, :3].T + world[:3, 3]
                if not (np.abs(v) <= MAX_COORDINATE).all():
                    raise WorldError(path, f"glTF mesh {node.mesh}: a vertex NaN, infinite or "
                                           f"beyond +-{MAX_COORDINATE:g}")
                faces = index.reshape(-1, 3)
                if np.linalg.det(world[:3, :3]) < 0:
                    faces = faces[:, ::-1]  # a mirroring transform: fronts stay fronts
                vertices.append(v)
                triangles.append(faces + offset)
                offset += len(v)
                count += len(faces)
            oid = len(names)
            names.append(name)
            ids.append(np.full(count, oid, dtype=np.int64))
            if animated is not None:
                a, above, rest = animated
                entry = channels[a]
                pre = np.linalg.inv(above @ rest)
                tracks.append({"object_id": oid, "interpolation": entry["interpolation"],
                               "pre": pre, "post": above, "loop": False,
                               **{k: entry.get(k) for k in PATHS}})
                anchor_of.setdefault(a, []).append(oid)
        for child in reversed(node.children or []):
            stack.append((child, world, animated))
    if not triangles:
        raise WorldError(path, "no triangles in its scene's mesh nodes")
    rest = {"translation": "translation", "rotation": "rotation", "scale": "scale"}
    for track in tracks:  # a channel the animation does not drive holds the node's rest value
        node = nodes[[a for a, o in anchor_of.items() if track["object_id"] in o][0]]
        for key in rest:
            if track[key] is None:
                value = {"translation": node.translation or (0, 0, 0),
                         "rotation": node.rotation or (0, 0, 0, 1),
                         "scale": node.scale or (1, 1, 1)}[key]
                track[key] = (np.zeros(1), np.asarray(value, dtype=np.float64)[None])
    return (np.concatenate(vertices), np.concatenate(triangles), np.concatenate(ids), names,
            tracks)


def read_animated_gltf(path) -> tuple:
    """(vertices (V, 3) float64, triangles (T, 3) int64, object_ids (T,) int64, names, tracks)
    of a glTF/GLB file: one object per mesh node (named after the node, made unique), vertices
    in world coordinates at rest; tracks a list of dicts for motion.Track (object_id,
    translation/rotation/scale (times, values) or None, interpolation, pre, post), one per
    object that moves. Raises WorldError naming the file."""
    from . import meshcheck

    path = Path(path)
    file_type = mesh_format(path)
    if file_type not in ("gltf", "glb") or path.name.lower().endswith(".gz"):
        raise WorldError(path, "node animations are read from .gltf or .glb files (not .gz)")
    data = read_input(path)
    meshcheck.check(path, file_type, data)
    try:
        import pygltflib

        gltf = pygltflib.GLTF2.load_from_bytes(data) if file_type == "glb" else \
            pygltflib.GLTF2.from_json(data.decode("utf-8"))
    except Exception as error:  # pygltflib raises assorted types on malformed input
        raise WorldError(path, f"unparsable glTF ({type(error).__name__}: "
                               f"{one_line(error)[:120]})") from None
    try:
        return _scene(path, gltf, _Reader(path, gltf, data, file_type))
    except WorldError:
        raise
    except Exception as error:  # a field of the wrong type deep in the document
        raise WorldError(path, f"malformed glTF ({type(error).__name__}: "
                               f"{one_line(error)[:120]})") from None

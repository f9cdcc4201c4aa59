"""Writers of the formats tools/hostile.py's cases craft (issue 28): PLY, OFF and ASCII STL,
glTF/GLB (one mesh, its node graph, a base-colour texture), .vmt terrains, gzip and zlib bombs;
and the case helpers they share (a file written into the case's folder, the CLI arguments
that read it). Also used by tools/fuzz*.py for their seeds."""
from __future__ import annotations

import gzip
import json
import struct
import zlib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
TRAJECTORY = ROOT / "trajectories" / "indoor.csv"
CUBE_V = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (0, 0, 1), (1, 0, 1), (1, 1, 1), (0, 1, 1)]
CUBE_F = [(0, 2, 1), (0, 3, 2), (4, 5, 6), (4, 6, 7), (0, 1, 5), (0, 5, 4), (2, 3, 7), (2, 7, 6),
          (1, 2, 6), (1, 6, 5), (0, 4, 7), (0, 7, 3)]


# ---- writers -----------------------------------------------------------------------------
def ply(vertices, faces, fmt="ascii", declared=None, index="int") -> bytes:
    """A PLY file; fmt ascii, binary_little_endian or binary_big_endian; declared: (V, F)
    written in the header instead of the real counts."""
    nv, nf = declared or (len(vertices), len(faces))
    head = (f"ply\nformat {fmt} 1.0\nelement vertex {nv}\nproperty float x\nproperty float y\n"
            f"property float z\nelement face {nf}\nproperty list uchar {index} vertex_indices\n"
            "end_header\n").encode()
    if fmt == "ascii":
        body = "".join(f"{x} {y} {z}\n" for x, y, z in vertices)
        body += "".join("3 " + " ".join(map(str, f)) + "\n" for f in faces)
        return head + body.encode()
    end = "<" if fmt == "binary_little_endian" else ">"
    body = b"".join(struct.pack(end + "3f", *v) for v in vertices)
    code = {"int": "i", "uint": "I"}[index]
    body += b"".join(struct.pack(end + "B3" + code, 3, *f) for f in faces)
    return head + body


def off(vertices, faces, declared=None) -> bytes:
    nv, nf = declared or (len(vertices), len(faces))
    lines = ["OFF", f"{nv} {nf} 0"] + [f"{x} {y} {z}" for x, y, z in vertices]
    lines += ["3 " + " ".join(map(str, f)) for f in faces]
    return ("\n".join(lines) + "\n").encode()


def stl_ascii(triangles) -> bytes:
    out = ["solid s"]
    for tri in triangles:
        out += ["facet normal 0 0 1", "outer loop"]
        out += [f"vertex {x} {y} {z}" for x, y, z in tri]
        out += ["endloop", "endfacet"]
    return ("\n".join(out + ["endsolid s"]) + "\n").encode()


def gltf(vertices=CUBE_V, faces=CUBE_F, nodes=None, scene_nodes=(0,), index_count=None,
         positions=None) -> tuple:
    """(JSON dict, binary buffer) of one mesh: float32 positions, uint32 indices; nodes
    default to one node showing mesh 0. positions: raw float32 values to store instead."""
    pos = struct.pack(f"<{3 * len(vertices)}f", *(c for v in vertices for c in v)) \
        if positions is None else struct.pack(f"<{len(positions)}f", *positions)
    idx = struct.pack(f"<{3 * len(faces)}I", *(i for f in faces for i in f))
    count = len(pos) // 12
    doc = {
        "asset": {"version": "2.0"},
        "scene": 0, "scenes": [{"nodes": list(scene_nodes)}],
        "nodes": nodes if nodes is not None else [{"mesh": 0}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
        "buffers": [{"byteLength": len(pos) + len(idx)}],
        "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": len(pos)},
                        {"buffer": 0, "byteOffset": len(pos), "byteLength": len(idx)}],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": count, "type": "VEC3",
             "min": [0, 0, 0], "max": [1, 1, 1]},
            {"bufferView": 1, "componentType": 5125,
             "count": index_count if index_count is not None else 3 * len(faces),
             "type": "SCALAR"}],
    }
    return doc, pos + idx


def glb(doc, binary) -> bytes:
    text = json.dumps(doc).encode()
    text += b" " * (-len(text) % 4)
    binary += b"\0" * (-len(binary) % 4)
    chunks = (struct.pack("<I4s", len(text), b"JSON") + text
              + struct.pack("<I4s", len(binary), b"BIN\0") + binary)
    return struct.pack("<4sII", b"glTF", 2, 12 + len(chunks)) + chunks


def gz_bomb(prefix: bytes, gigabytes: float, fill=b"\0") -> bytes:
    """A gzip stream of prefix then `gigabytes` of fill: one 64 MiB member repeated."""
    block = gzip.compress(fill * (64 << 20), 9)
    return gzip.compress(prefix) + block * int(gigabytes * 16)


def vmt(header, payload: bytes) -> bytes:
    head = json.dumps(header).encode()
    return b"".join([b"VMT1", struct.pack("<II", len(head), zlib.crc32(head)), head,
                     struct.pack("<QI", len(payload), zlib.crc32(payload)), payload])


def vmt_header(size=3, **changes) -> dict:
    header = {"version": 1, "size": size, "spacing": 1.0, "z_scale": 1.0, "z_offset": 0.0,
              "name": "h", "digest": "", "objects": []}
    header.update(changes)
    return header


def vmt_payload(size=3) -> bytes:
    return zlib.compress(b"\0" * (2 * size * size))


def zlib_bomb(gigabytes: float) -> bytes:
    stream = zlib.compressobj(9)
    block = b"\0" * (64 << 20)
    out = [stream.compress(block) for _ in range(int(gigabytes * 16))]
    return b"".join(out) + stream.flush()


def textured(side: int, uri: str | None = None) -> tuple:
    """(glTF JSON, binary) of the cube with a side x side one-bit PNG as its base colour: in
    the binary buffer, or in a file `uri` beside the glTF (the PNG is then returned too)."""
    import io

    from PIL import Image

    buffer = io.BytesIO()
    Image.new("1", (side, side)).save(buffer, "PNG")
    png = buffer.getvalue()
    doc, binary = gltf()
    uv = struct.pack(f"<{2 * len(CUBE_V)}f", *([0.0, 0.0, 1.0, 0.0, 1.0, 1.0, 0.0, 1.0] * 2))
    start = len(binary)
    binary += uv
    doc["bufferViews"].append({"buffer": 0, "byteOffset": start, "byteLength": len(uv)})
    doc["accessors"].append({"bufferView": 2, "componentType": 5126, "count": len(CUBE_V),
                             "type": "VEC2"})
    primitive = doc["meshes"][0]["primitives"][0]
    primitive["attributes"]["TEXCOORD_0"], primitive["material"] = 2, 0
    doc["materials"] = [{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}]
    doc["textures"] = [{"source": 0}]
    if uri is None:
        binary += b"\0" * (-len(binary) % 4)
        doc["bufferViews"].append({"buffer": 0, "byteOffset": len(binary),
                                   "byteLength": len(png)})
        doc["images"] = [{"bufferView": 3, "mimeType": "image/png"}]
        binary += png
    else:
        doc["images"] = [{"uri": uri}]
    doc["buffers"][0]["byteLength"] = len(binary)
    return doc, binary, png


# ---- case helpers: a case is write(folder) -> (argv, the file the error must name) -----------
def put(folder: Path, name: str, data: bytes) -> Path:
    path = folder / name
    path.write_bytes(data)
    return path


def info(folder, name, data):
    """`info` on the file name holding data."""
    path = put(folder, name, data)
    return ["info", path], path


def case_in(cases: dict):
    """case(name): a decorator putting a case's write(folder) into cases under name."""
    def case(name):
        def register(write):
            cases[name] = write
            return write
        return register
    return case

"""Issue 28's crafted hostile inputs: mesh formats (PLY, STL, OFF, glTF/GLB: accessors, indices,
buffer URIs, node graphs, instancing, matrices), .gz, .vmt, .vmp and trajectories as special
files, and heightmap files. Each case writes its files into a folder and gives the CLI
arguments that read them; `run` plays one in a child process and reports how it ended.

A clean case: exit code 2, one stderr line naming the file, no traceback, nothing left in the
folder but the inputs, and the child's peak RSS under 2 GiB (read from os.wait4's rusage).

Usage (also `tools/fuzz.py hostile`):
  .venv/bin/python tools/hostile.py [NAME ...]     # all cases, or the named ones
"""
from __future__ import annotations

import gzip
import json
import os
import struct
import subprocess
import sys
import tempfile
import time
import zlib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
_TRAJ = ROOT / "trajectories" / "indoor.csv"
RSS_LIMIT = 2 << 30  # bytes: the bound for any input
ADDRESS_LIMIT = 6 << 30  # the child's address space cap: a runaway case fails, not the machine
TIME_LIMIT = 120  # seconds per case (a hang is a failure, not a wait)

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


# ---- cases: name -> (write(folder) -> (argv, the file the error must name)) -------------------
CASES = {}


def case(name):
    def register(write):
        CASES[name] = write
        return write
    return register


def _file(folder: Path, name: str, data: bytes) -> Path:
    path = folder / name
    path.write_bytes(data)
    return path


def _info(folder, name, data):
    path = _file(folder, name, data)
    return ["info", path], path


for _fmt in ("ascii", "binary_little_endian", "binary_big_endian"):
    CASES[f"ply_{_fmt}_index_beyond"] = (
        lambda folder, f=_fmt: _info(folder, "m.ply", ply(CUBE_V, CUBE_F[:-1] + [(0, 1, 99)], f)))
    CASES[f"ply_{_fmt}_negative_index"] = (
        lambda folder, f=_fmt: _info(folder, "m.ply", ply(CUBE_V, CUBE_F[:-1] + [(0, 1, -3)], f)))
CASES["ply_wrong_endianness"] = lambda folder: _info(
    folder, "m.ply", ply(CUBE_V, CUBE_F, "binary_little_endian").replace(
        b"binary_little_endian", b"binary_big_endian\0\0\0"[:len(b"binary_little_endian")]))
CASES["ply_declares_2e9_vertices"] = lambda folder: _info(
    folder, "m.ply", ply(CUBE_V, CUBE_F, "binary_little_endian", declared=(2_000_000_000, 12)))
CASES["ply_declares_2e9_faces_ascii"] = lambda folder: _info(
    folder, "m.ply", ply(CUBE_V, CUBE_F, declared=(8, 2_000_000_000)))
CASES["ply_declares_more_faces_than_held"] = lambda folder: _info(
    folder, "m.ply", ply(CUBE_V, CUBE_F, declared=(8, 1000)))
CASES["ply_binary_declares_more_faces_than_held"] = lambda folder: _info(
    folder, "m.ply", ply(CUBE_V, CUBE_F, "binary_little_endian", declared=(8, 1000)))
CASES["off_declares_more_faces_than_held"] = lambda folder: _info(
    folder, "m.off", off(CUBE_V, CUBE_F[:1], declared=(8, 1000)))
CASES["ply_coordinate_1e300"] = lambda folder: _info(
    folder, "m.ply", ply([(1e300, 0, 0)] + CUBE_V[1:], CUBE_F))
CASES["ply_coordinate_nan"] = lambda folder: _info(
    folder, "m.ply", ply([(float("nan"), 0, 0)] + CUBE_V[1:], CUBE_F))
CASES["stl_coordinate_1e300"] = lambda folder: _info(
    folder, "m.stl", stl_ascii([[(0, 0, 0), (1e300, 0, 0), (0, 1, 0)]]))
CASES["stl_coordinate_inf"] = lambda folder: _info(
    folder, "m.stl", stl_ascii([[(0, 0, 0), (1, 0, 0), (0, float("inf"), 0)]]))
CASES["stl_binary_count_2e9"] = lambda folder: _info(
    folder, "m.stl", b"\0" * 80 + struct.pack("<I", 2_000_000_000) + b"\0" * 50)
CASES["stl_binary_wrong_length"] = lambda folder: _info(  # trimesh logged a traceback
    folder, "m.stl", b"solid x" + b"\0" * 73 + struct.pack("<I", 2_000_000_000)
    + b"".join(struct.pack("<12fH", *range(12), 0) for _ in range(3)))
CASES["off_declares_2e9_faces"] = lambda folder: _info(
    folder, "m.off", off(CUBE_V, CUBE_F[:1], declared=(8, 2_000_000_000)))
CASES["off_index_beyond"] = lambda folder: _info(
    folder, "m.off", off(CUBE_V, CUBE_F[:-1] + [(0, 1, 99)]))
CASES["off_negative_index"] = lambda folder: _info(
    folder, "m.off", off(CUBE_V, CUBE_F[:-1] + [(0, 1, -2)]))
CASES["off_coordinate_1e300"] = lambda folder: _info(
    folder, "m.off", off([(0, 1e300, 0)] + CUBE_V[1:], CUBE_F))


@case("glb_index_past_vertices")
def _(folder):
    return _info(folder, "m.glb", glb(*gltf(faces=CUBE_F[:-1] + [(0, 1, 4000)])))


@case("glb_index_count_past_buffer")
def _(folder):
    return _info(folder, "m.glb", glb(*gltf(index_count=3_000_000)))


@case("glb_position_nan")
def _(folder):
    values = [c for v in CUBE_V for c in v]
    values[4] = float("nan")
    return _info(folder, "m.glb", glb(*gltf(positions=values)))


@case("glb_position_1e38")
def _(folder):
    values = [c for v in CUBE_V for c in v]
    values[4] = 3e38
    doc, binary = gltf(positions=values)
    doc["nodes"] = [{"mesh": 0, "scale": [1e300, 1e300, 1e300]}]
    return _info(folder, "m.glb", glb(doc, binary))


@case("glb_matrix_overflow")
def _(folder):
    doc, binary = gltf(nodes=[{"children": [1], "matrix": [1e200, 0, 0, 0, 0, 1e200, 0, 0, 0, 0,
                                                           1e200, 0, 0, 0, 0, 1]},
                              {"mesh": 0, "matrix": [1e200, 0, 0, 0, 0, 1e200, 0, 0, 0, 0,
                                                     1e200, 0, 0, 0, 0, 1]}])
    return _info(folder, "m.glb", glb(doc, binary))


@case("glb_matrix_nan")
def _(folder):
    doc, binary = gltf(nodes=[{"mesh": 0, "matrix": [float("nan")] + [0] * 14 + [1]}])
    return _info(folder, "m.glb", glb(doc, binary))


@case("glb_node_own_child")
def _(folder):
    return _info(folder, "m.glb", glb(*gltf(nodes=[{"mesh": 0, "children": [0]}])))


@case("glb_node_cycle")
def _(folder):
    nodes = [{"children": [1]}, {"children": [2]}, {"mesh": 0, "children": [0]}]
    return _info(folder, "m.glb", glb(*gltf(nodes=nodes)))


@case("glb_node_child_out_of_range")
def _(folder):
    return _info(folder, "m.glb", glb(*gltf(nodes=[{"mesh": 0, "children": [7]}])))


@case("glb_instances_60_million")
def _(folder):
    # 26 levels, each node showing the next twice: 2^26 = 67 M instances from 27 nodes
    nodes = [{"children": [i + 1, i + 1]} for i in range(26)] + [{"mesh": 0}]
    return _info(folder, "m.glb", glb(*gltf(nodes=nodes)))


@case("glb_instances_wide")
def _(folder):
    # a tree (each node one parent), but 300,000 nodes each showing the cube
    nodes = [{"children": list(range(1, 300_001))}] + [{"mesh": 0}] * 300_000
    return _info(folder, "m.glb", glb(*gltf(nodes=nodes)))


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


def _play(folder, name, data):
    path = _file(folder, name, data)
    return ["play", path, "--trajectory", _TRAJ, "-o", folder / "run", "--limit", "2",
            "--quiet"], path


CASES["glb_texture_12000_pixels"] = lambda folder: _play(  # 1.9 GB and PIL's warning before
    folder, "m.glb", glb(*textured(12000)[:2]))
CASES["glb_texture_20000_pixels"] = lambda folder: _play(  # the texture was dropped silently
    folder, "m.glb", glb(*textured(20000)[:2]))


@case("gltf_texture_file_12000_pixels")
def _(folder):
    doc, binary, png = textured(12000, "big.png")
    doc["buffers"][0]["uri"] = "m.bin"
    _file(folder, "m.bin", binary)
    _file(folder, "big.png", png)
    return _play(folder, "m.gltf", json.dumps(doc).encode())


@case("gltf_image_uri_fifo")
def _(folder):
    doc, binary, _ = textured(4, "tex.png")
    doc["buffers"][0]["uri"] = "m.bin"
    _file(folder, "m.bin", binary)
    os.mkfifo(folder / "tex.png")
    return _play(folder, "m.gltf", json.dumps(doc).encode())


def _gltf_with_uri(folder, target):
    doc, binary = gltf()
    doc["buffers"][0]["uri"] = "buffer.bin"
    path = _file(folder, "m.gltf", json.dumps(doc).encode())
    target(folder / "buffer.bin", binary)
    return ["info", path], path


CASES["gltf_buffer_fifo"] = lambda folder: _gltf_with_uri(
    folder, lambda p, b: os.mkfifo(p))
CASES["gltf_buffer_dev_zero"] = lambda folder: _gltf_with_uri(
    folder, lambda p, b: os.symlink("/dev/zero", p))
CASES["gltf_buffer_directory"] = lambda folder: _gltf_with_uri(
    folder, lambda p, b: os.mkdir(p))
CASES["gltf_buffer_missing"] = lambda folder: _gltf_with_uri(folder, lambda p, b: None)


@case("gltf_buffer_outside_folder")
def _(folder):
    doc, _ = gltf()
    doc["buffers"][0]["uri"] = "/etc/passwd"
    path = _file(folder, "m.gltf", json.dumps(doc).encode())
    return ["info", path], path


@case("gltf_json_nested")
def _(folder):
    return _info(folder, "m.gltf", b"[" * 100_000 + b"]" * 100_000)


def _gz(data, cut=None):
    packed = gzip.compress(data)
    return packed[:cut if cut is not None else len(packed)]


CASES["obj_gz_truncated"] = lambda folder: _info(
    folder, "m.obj.gz", _gz(b"v 0 0 0\nv 1 0 0\nv 0 1 0\n" + b"f 1 2 3\n" * 1000, -20))
CASES["ply_gz_truncated"] = lambda folder: _info(
    folder, "m.ply.gz", _gz(ply(CUBE_V, CUBE_F), -12))
CASES["ply_gz_trailing_garbage"] = lambda folder: _info(
    folder, "m.ply.gz", _gz(ply(CUBE_V, CUBE_F)) + b"garbage")
CASES["obj_gz_bomb"] = lambda folder: _info(
    folder, "m.obj.gz", gz_bomb(b"v 0 0 0\n", 3, b" "))
CASES["ply_gz_bomb"] = lambda folder: _info(
    folder, "m.ply.gz", gz_bomb(ply(CUBE_V, CUBE_F, "binary_little_endian",
                                    declared=(8, 200_000_000)), 3))
CASES["stl_gz_bomb"] = lambda folder: _info(folder, "m.stl.gz", gz_bomb(b"solid s\n", 3, b" "))


# ---- .vmt ---------------------------------------------------------------------------------------
def _terrain_info(folder, data, name="t.vmt"):
    path = _file(folder, name, data)
    return ["terrain", "info", path], path


VMT_HEADERS = {
    "vmt_header_list": [1, 2, 3],
    "vmt_version_string": vmt_header(version="1"),
    "vmt_size_missing": {k: v for k, v in vmt_header().items() if k != "size"},
    "vmt_size_text": vmt_header(size="abc"),
    "vmt_size_infinite": vmt_header(size=float("inf")),
    "vmt_size_huge": vmt_header(size=(1 << 20) + 1),
    "vmt_size_bool": vmt_header(size=True),
    "vmt_spacing_null": vmt_header(spacing=None),
    "vmt_spacing_nan": vmt_header(spacing=float("nan")),
    "vmt_objects_nan_height": vmt_header(objects=[{"kind": "cow", "position": [1, 0, 1],
                                                   "yaw": 0, "height": float("nan")}]),
    "vmt_objects_huge_position": vmt_header(objects=[{"kind": "cow", "position": [1e300, 0, 1],
                                                      "yaw": 0, "height": 1}]),
    "vmt_objects_thousands": vmt_header(objects=[{"kind": "flower", "position": [1, 0, 1],
                                                  "yaw": 0, "height": 1}] * 20_000),
    "vmt_objects_not_a_list": vmt_header(objects={"kind": "cow"}),
}
for _name, _header in VMT_HEADERS.items():
    CASES[_name] = lambda folder, h=_header: _terrain_info(folder, vmt(h, vmt_payload()))
CASES["vmt_zlib_bomb"] = lambda folder: _terrain_info(
    folder, vmt(vmt_header(size=8193), zlib_bomb(3)))


def _special(folder, name, make, argv):
    path = folder / name
    make(path)
    return [a if a != "{}" else path for a in argv], path


CASES["vmt_fifo"] = lambda folder: _special(folder, "t.vmt", os.mkfifo, ["terrain", "info", "{}"])
CASES["vmt_dev_zero"] = lambda folder: _special(
    folder, "t.vmt", lambda p: os.symlink("/dev/zero", p), ["terrain", "info", "{}"])
CASES["vmt_dev_urandom"] = lambda folder: _special(
    folder, "t.vmt", lambda p: os.symlink("/dev/urandom", p), ["terrain", "info", "{}"])
CASES["vmp_fifo_play"] = lambda folder: _special(
    folder, "w.vmp", os.mkfifo, ["play", "{}", "--trajectory", _TRAJ, "-o", folder / "run",
                                 "--quiet"])
CASES["vmp_dev_zero_play"] = lambda folder: _special(
    folder, "w.vmp", lambda p: os.symlink("/dev/zero", p),
    ["play", "{}", "--trajectory", _TRAJ, "-o", folder / "run", "--quiet"])
CASES["trajectory_fifo"] = lambda folder: _special(
    folder, "t.csv", os.mkfifo, ["play", "w1", "--trajectory", "{}", "-o", folder / "run",
                                 "--quiet"])
CASES["obj_fifo"] = lambda folder: _special(folder, "m.obj", os.mkfifo, ["info", "{}"])
CASES["ply_dev_zero"] = lambda folder: _special(
    folder, "m.ply", lambda p: os.symlink("/dev/zero", p), ["info", "{}"])


# ---- heightmap files ------------------------------------------------------------------------------
def _heightmap(folder, name, write):
    path = folder / name
    write(path)
    return ["terrain", "build", path, "-o", folder / "t.vmt"], path


def _npy(shape, values=None):
    def write(path):
        import numpy as np

        array = np.zeros(shape, np.float32) if values is None else np.array(values)
        np.save(path, array)
    return write


def _png(size):
    def write(path):
        from PIL import Image

        Image.new("L", size).save(path)
    return write


CASES["heightmap_npy_2x70000"] = lambda folder: _heightmap(folder, "h.npy", _npy((2, 70000)))
CASES["heightmap_npy_2x9000"] = lambda folder: _heightmap(folder, "h.npy", _npy((2, 9000)))
CASES["heightmap_png_9000x9000"] = lambda folder: _heightmap(folder, "h.png", _png((9000, 9000)))
CASES["heightmap_png_70000x2"] = lambda folder: _heightmap(folder, "h.png", _png((70000, 2)))
CASES["heightmap_range_1e300"] = lambda folder: _heightmap(
    folder, "h.npy", _npy(None, [[-1e300, 1e300], [0, 1]]))
CASES["heightmap_float_max"] = lambda folder: _heightmap(
    folder, "h.npy", _npy(None, [[1.7e308, 0], [0, 1]]))
CASES["heightmap_npy_object_dtype"] = lambda folder: _heightmap(
    folder, "h.npy", lambda p: p.write_bytes(
        b"\x93NUMPY\x01\x00v\x00{'descr': '|O', 'fortran_order': False, 'shape': (3, 3), }"
        + b" " * 53 + b"\n" + b"\0" * 72))
CASES["heightmap_fifo"] = lambda folder: _heightmap(folder, "h.npy", os.mkfifo)


# ---- running a case ---------------------------------------------------------------------------
def _cap():
    import resource

    resource.setrlimit(resource.RLIMIT_AS, (ADDRESS_LIMIT, ADDRESS_LIMIT))


def listing(folder: Path) -> list:
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*"))


def run(name: str, folder: Path | None = None) -> dict:
    """Play case `name` in a child `python -m vismobile`: {name, rc, stderr, seconds, rss_mb,
    clean, why}. clean: rc 2, one stderr line naming the file, no traceback, no new file,
    peak RSS under RSS_LIMIT."""
    with tempfile.TemporaryDirectory(prefix="hostile-") as tmp:
        folder = Path(tmp) if folder is None else folder
        argv, named = CASES[name](folder)
        before = listing(folder)
        env = dict(os.environ, PYTHONPATH=str(ROOT), VISMOBILE_STATUS="off")  # no status lines
        start = time.perf_counter()
        with tempfile.TemporaryFile() as err:
            child = subprocess.Popen([sys.executable, "-m", "vismobile", *map(str, argv)],
                                     stdout=subprocess.DEVNULL, stderr=err, env=env,
                                     cwd=folder, preexec_fn=_cap)
            timer = __import__("threading").Timer(TIME_LIMIT, child.kill)
            timer.start()
            try:
                _, status, usage = os.wait4(child.pid, 0)
            finally:
                timer.cancel()
            child.returncode = os.waitstatus_to_exitcode(status)
            err.seek(0)
            stderr = err.read().decode("utf-8", "replace")
        seconds = time.perf_counter() - start
        lines = stderr.strip().splitlines()
        rss = usage.ru_maxrss * 1024
        after = listing(folder)
        why = []
        if child.returncode != 2:
            why.append(f"rc {child.returncode}")
        if len(lines) != 1:
            why.append(f"{len(lines)} stderr lines")
        if "Traceback" in stderr:
            why.append("traceback")
        if lines and str(named) not in lines[-1]:
            why.append("file not named")
        if after != before:
            why.append(f"left {sorted(set(after) - set(before))}")
        if rss >= RSS_LIMIT:
            why.append(f"peak RSS {rss / 2**20:.0f} MB")
        return {"name": name, "rc": child.returncode, "stderr": lines[-1] if lines else "",
                "seconds": round(seconds, 2), "rss_mb": round(rss / 2 ** 20, 1),
                "clean": not why, "why": ", ".join(why)}


def main(names=None) -> int:
    names = names or list(CASES)
    clean = 0
    for name in names:
        result = run(name)
        clean += result["clean"]
        mark = "clean" if result["clean"] else f"FAIL ({result['why']})"
        print(f"{name:34s} {mark:10s} rc {result['rc']:3d} {result['seconds']:6.2f} s "
              f"{result['rss_mb']:7.1f} MB  {result['stderr'][:110]}", flush=True)
    print(f"{clean} of {len(names)} cases clean")
    return 0 if clean == len(names) else 1



def _corrupt_tiff(path):
    """A float32 deflate TIFF whose compressed strip is scrambled: the decoder fails, and
    nothing but the one error line may reach the terminal (issue 30)."""
    import io

    import numpy as np
    from PIL import Image

    buffer = io.BytesIO()
    Image.fromarray(np.random.default_rng(0).random((64, 80)).astype(np.float32)).save(
        buffer, format="TIFF", compression="tiff_adobe_deflate")
    data = bytearray(buffer.getvalue())
    for k in range(40, 400):
        data[k] ^= 0x5A
    path.write_bytes(bytes(data))


CASES["tif_corrupt_strip"] = lambda folder: _heightmap(folder, "dem.tif", _corrupt_tiff)


# Issue 30's out-of-core build and paged Röttger (terrain tile dem.tif, play t.vmrpages).
def _tile(folder, name, write, out="out.vmtiles"):
    path = folder / name
    write(path)
    return ["terrain", "tile", path, "-o", folder / out], path


def _one_huge_strip(path):
    """A TIFF header declaring 60,000 x 60,000 float32 pixels in a single strip: the streaming
    reader refuses it before reading (a strip beyond the memory budget)."""
    import struct

    entries = [(256, 4, 60000), (257, 4, 60000), (258, 3, 32), (259, 3, 1), (273, 4, 200),
               (277, 3, 1), (278, 4, 60000), (279, 4, 60000 * 60000 * 4 % (1 << 32)),
               (339, 3, 3)]
    ifd = struct.pack("<H", len(entries)) + b"".join(
        struct.pack("<HHII", tag, kind, 1, value) if kind == 4 else
        struct.pack("<HHIHH", tag, kind, 1, value, 0) for tag, kind, value in entries) + \
        b"\0\0\0\0"
    path.write_bytes(b"II" + struct.pack("<HI", 42, 8) + ifd + b"\0" * 64)


def _truncated_pages(path):
    from vismobile.terrain import sources
    from vismobile.terrain.paged_roettger import write_pages
    from vismobile.terrain.roettger import Roettger

    write_pages(Roettger(sources.diamond_square(65, seed=1)), path)
    path.write_bytes(path.read_bytes()[:-1000])


CASES["tifstream_corrupt_strip"] = lambda folder: _tile(folder, "dem.tif", _corrupt_tiff)
CASES["tifstream_one_huge_strip"] = lambda folder: _tile(folder, "dem.tif", _one_huge_strip)
CASES["tifstream_pages_corrupt_strip"] = lambda folder: _tile(folder, "dem.tif", _corrupt_tiff,
                                                              "out.vmrpages")


def _play_pages(folder):
    path = folder / "t.vmrpages"
    _truncated_pages(path)
    return ["play", path, "-o", folder / "run"], path


CASES["vmrpages_truncated"] = _play_pages


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))

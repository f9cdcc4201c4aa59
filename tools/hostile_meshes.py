"""tools/hostile.py's cases of mesh and scene files (issue 28): PLY, STL and OFF with indices
out of range, counts past what is held and extreme coordinates; GLB/glTF with bad indices,
positions and matrices, node cycles, millions of instances, huge textures and buffer URIs
that are FIFOs, /dev/zero, folders, missing or outside the folder; truncated, trailing and
bomb gzip streams."""
from __future__ import annotations

import json
import os
import struct

from hostile_writers import (CUBE_F, CUBE_V, TRAJECTORY, case_in, glb, gltf, gz_bomb, info,
                             off, ply, put, stl_ascii, textured)

CASES = {}
case = case_in(CASES)

for _fmt in ("ascii", "binary_little_endian", "binary_big_endian"):
    CASES[f"ply_{_fmt}_index_beyond"] = (
        lambda folder, f=_fmt: info(folder, "m.ply", ply(CUBE_V, CUBE_F[:-1] + [(0, 1, 99)], f)))
    CASES[f"ply_{_fmt}_negative_index"] = (
        lambda folder, f=_fmt: info(folder, "m.ply", ply(CUBE_V, CUBE_F[:-1] + [(0, 1, -3)], f)))
CASES["ply_wrong_endianness"] = lambda folder: info(
    folder, "m.ply", ply(CUBE_V, CUBE_F, "binary_little_endian").replace(
        b"binary_little_endian", b"binary_big_endian\0\0\0"[:len(b"binary_little_endian")]))
CASES["ply_declares_2e9_vertices"] = lambda folder: info(
    folder, "m.ply", ply(CUBE_V, CUBE_F, "binary_little_endian", declared=(2_000_000_000, 12)))
CASES["ply_declares_2e9_faces_ascii"] = lambda folder: info(
    folder, "m.ply", ply(CUBE_V, CUBE_F, declared=(8, 2_000_000_000)))
CASES["ply_declares_more_faces_than_held"] = lambda folder: info(
    folder, "m.ply", ply(CUBE_V, CUBE_F, declared=(8, 1000)))
CASES["ply_binary_declares_more_faces_than_held"] = lambda folder: info(
    folder, "m.ply", ply(CUBE_V, CUBE_F, "binary_little_endian", declared=(8, 1000)))
CASES["off_declares_more_faces_than_held"] = lambda folder: info(
    folder, "m.off", off(CUBE_V, CUBE_F[:1], declared=(8, 1000)))
CASES["ply_coordinate_1e300"] = lambda folder: info(
    folder, "m.ply", ply([(1e300, 0, 0)] + CUBE_V[1:], CUBE_F))
CASES["ply_coordinate_nan"] = lambda folder: info(
    folder, "m.ply", ply([(float("nan"), 0, 0)] + CUBE_V[1:], CUBE_F))
CASES["stl_coordinate_1e300"] = lambda folder: info(
    folder, "m.stl", stl_ascii([[(0, 0, 0), (1e300, 0, 0), (0, 1, 0)]]))
CASES["stl_coordinate_inf"] = lambda folder: info(
    folder, "m.stl", stl_ascii([[(0, 0, 0), (1, 0, 0), (0, float("inf"), 0)]]))
CASES["stl_binary_count_2e9"] = lambda folder: info(
    folder, "m.stl", b"\0" * 80 + struct.pack("<I", 2_000_000_000) + b"\0" * 50)
CASES["stl_binary_wrong_length"] = lambda folder: info(  # trimesh logged a traceback
    folder, "m.stl", b"solid x" + b"\0" * 73 + struct.pack("<I", 2_000_000_000)
    + b"".join(struct.pack("<12fH", *range(12), 0) for _ in range(3)))
CASES["off_declares_2e9_faces"] = lambda folder: info(
    folder, "m.off", off(CUBE_V, CUBE_F[:1], declared=(8, 2_000_000_000)))
CASES["off_index_beyond"] = lambda folder: info(
    folder, "m.off", off(CUBE_V, CUBE_F[:-1] + [(0, 1, 99)]))
CASES["off_negative_index"] = lambda folder: info(
    folder, "m.off", off(CUBE_V, CUBE_F[:-1] + [(0, 1, -2)]))
CASES["off_coordinate_1e300"] = lambda folder: info(
    folder, "m.off", off([(0, 1e300, 0)] + CUBE_V[1:], CUBE_F))


@case("glb_index_past_vertices")
def _(folder):
    return info(folder, "m.glb", glb(*gltf(faces=CUBE_F[:-1] + [(0, 1, 4000)])))


@case("glb_index_count_past_buffer")
def _(folder):
    return info(folder, "m.glb", glb(*gltf(index_count=3_000_000)))


@case("glb_position_nan")
def _(folder):
    values = [c for v in CUBE_V for c in v]
    values[4] = float("nan")
    return info(folder, "m.glb", glb(*gltf(positions=values)))


@case("glb_position_1e38")
def _(folder):
    values = [c for v in CUBE_V for c in v]
    values[4] = 3e38
    doc, binary = gltf(positions=values)
    doc["nodes"] = [{"mesh": 0, "scale": [1e300, 1e300, 1e300]}]
    return info(folder, "m.glb", glb(doc, binary))


@case("glb_matrix_overflow")
def _(folder):
    doc, binary = gltf(nodes=[{"children": [1], "matrix": [1e200, 0, 0, 0, 0, 1e200, 0, 0, 0, 0,
                                                           1e200, 0, 0, 0, 0, 1]},
                              {"mesh": 0, "matrix": [1e200, 0, 0, 0, 0, 1e200, 0, 0, 0, 0,
                                                     1e200, 0, 0, 0, 0, 1]}])
    return info(folder, "m.glb", glb(doc, binary))


@case("glb_matrix_nan")
def _(folder):
    doc, binary = gltf(nodes=[{"mesh": 0, "matrix": [float("nan")] + [0] * 14 + [1]}])
    return info(folder, "m.glb", glb(doc, binary))


@case("glb_node_own_child")
def _(folder):
    return info(folder, "m.glb", glb(*gltf(nodes=[{"mesh": 0, "children": [0]}])))


@case("glb_node_cycle")
def _(folder):
    nodes = [{"children": [1]}, {"children": [2]}, {"mesh": 0, "children": [0]}]
    return info(folder, "m.glb", glb(*gltf(nodes=nodes)))


@case("glb_node_child_out_of_range")
def _(folder):
    return info(folder, "m.glb", glb(*gltf(nodes=[{"mesh": 0, "children": [7]}])))


@case("glb_instances_60_million")
def _(folder):
    # 26 levels, each node showing the next twice: 2^26 = 67 M instances from 27 nodes
    nodes = [{"children": [i + 1, i + 1]} for i in range(26)] + [{"mesh": 0}]
    return info(folder, "m.glb", glb(*gltf(nodes=nodes)))


@case("glb_instances_wide")
def _(folder):
    # a tree (each node one parent), but 300,000 nodes each showing the cube
    nodes = [{"children": list(range(1, 300_001))}] + [{"mesh": 0}] * 300_000
    return info(folder, "m.glb", glb(*gltf(nodes=nodes)))


def _play(folder, name, data):
    path = put(folder, name, data)
    return ["play", path, "--trajectory", TRAJECTORY, "-o", folder / "run", "--limit", "2",
            "--quiet"], path


CASES["glb_texture_12000_pixels"] = lambda folder: _play(  # 1.9 GB and PIL's warning before
    folder, "m.glb", glb(*textured(12000)[:2]))
CASES["glb_texture_20000_pixels"] = lambda folder: _play(  # the texture was dropped silently
    folder, "m.glb", glb(*textured(20000)[:2]))


@case("gltf_texture_file_12000_pixels")
def _(folder):
    doc, binary, png = textured(12000, "big.png")
    doc["buffers"][0]["uri"] = "m.bin"
    put(folder, "m.bin", binary)
    put(folder, "big.png", png)
    return _play(folder, "m.gltf", json.dumps(doc).encode())


@case("gltf_image_uri_fifo")
def _(folder):
    doc, binary, _ = textured(4, "tex.png")
    doc["buffers"][0]["uri"] = "m.bin"
    put(folder, "m.bin", binary)
    os.mkfifo(folder / "tex.png")
    return _play(folder, "m.gltf", json.dumps(doc).encode())


def _gltf_with_uri(folder, target):
    doc, binary = gltf()
    doc["buffers"][0]["uri"] = "buffer.bin"
    path = put(folder, "m.gltf", json.dumps(doc).encode())
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
    path = put(folder, "m.gltf", json.dumps(doc).encode())
    return ["info", path], path


@case("gltf_json_nested")
def _(folder):
    return info(folder, "m.gltf", b"[" * 100_000 + b"]" * 100_000)


def _gz(data, cut=None):
    import gzip

    packed = gzip.compress(data)
    return packed[:cut if cut is not None else len(packed)]


CASES["obj_gz_truncated"] = lambda folder: info(
    folder, "m.obj.gz", _gz(b"v 0 0 0\nv 1 0 0\nv 0 1 0\n" + b"f 1 2 3\n" * 1000, -20))
CASES["ply_gz_truncated"] = lambda folder: info(
    folder, "m.ply.gz", _gz(ply(CUBE_V, CUBE_F), -12))
CASES["ply_gz_trailing_garbage"] = lambda folder: info(
    folder, "m.ply.gz", _gz(ply(CUBE_V, CUBE_F)) + b"garbage")
CASES["obj_gz_bomb"] = lambda folder: info(
    folder, "m.obj.gz", gz_bomb(b"v 0 0 0\n", 3, b" "))
CASES["ply_gz_bomb"] = lambda folder: info(
    folder, "m.ply.gz", gz_bomb(ply(CUBE_V, CUBE_F, "binary_little_endian",
                                    declared=(8, 200_000_000)), 3))
CASES["stl_gz_bomb"] = lambda folder: info(folder, "m.stl.gz", gz_bomb(b"solid s\n", 3, b" "))

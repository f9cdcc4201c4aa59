"""Structure-aware mutations of .vmp files for tools/fuzz.py (driven by pick(n) -> int in
[0, n), so random and atheris share them)."""
from __future__ import annotations

import json
import struct
import zlib

HEADER = struct.Struct("<8sIII")


def edit_vmp(data: bytes, pick) -> bytes:
    """A .vmp with its JSON header or one section edited (a PVS pack inside when it has one),
    the checksums recomputed so that the edit reaches the validation behind them."""
    magic, version, length, _ = HEADER.unpack_from(data, 0)
    header = json.loads(data[HEADER.size:HEADER.size + length])
    body_start = HEADER.size + length + (-(HEADER.size + length) % 64)
    body = bytearray(data[body_start:])
    names = {sec["name"] for sec in header["sections"]}
    fields = header["fields"]
    if {"extras.pvs_pack", "extras.pvs_shape"} <= names and all(
            fields[f"extras.pvs_{n}"]["encoding"] == "raw" for n in ("pack", "shape")) \
            and pick(3) == 0:
        body = mutate_pvs_pack(header, body, pick)
    elif pick(2) == 0:
        _edit_json(header, pick)
    elif header["sections"]:
        sec = header["sections"][pick(len(header["sections"]))]
        start, size = sec["offset"], sec["nbytes"]
        if size:
            for _ in range(1 + pick(8)):
                body[start + pick(size)] = pick(256)
            sec["crc32"] = zlib.crc32(bytes(body[start:start + size]))
    text = json.dumps(header, sort_keys=True, separators=(",", ":")).encode()
    head = HEADER.pack(magic, version, len(text), zlib.crc32(text)) + text
    return head + b"\0" * (-len(head) % 64) + bytes(body)


def mutate_pvs_pack(header, body, pick) -> bytearray:
    """A PVS (partition/pvs_codec.py: pvs_shape, and pvs_pack = an lzma side stream, then the
    range-coded pattern bits) edited inside, still well formed around the edit: a byte of the
    inflated side stream (a coordinate, a corner, a cell's group, a reference or a pattern
    id) or of the pattern bits, either stream cut or lengthened, a side stream that inflates
    far past its declared size, bytes after a stream, or a pvs_shape count off by a little; the new
    sections go at the end of the body (aligned), their entries, CRC32s and shapes updated."""
    import lzma

    import numpy as np

    sections = {sec["name"]: sec for sec in header["sections"]}
    shape_sec, pack_sec = sections["extras.pvs_shape"], sections["extras.pvs_pack"]
    shape = np.frombuffer(bytes(body[shape_sec["offset"]:shape_sec["offset"]
                                     + shape_sec["nbytes"]]), dtype=shape_sec["dtype"])
    shape = shape.astype(np.int64)
    pack = bytes(body[pack_sec["offset"]:pack_sec["offset"] + pack_sec["nbytes"]])
    filters = [{"id": lzma.FILTER_LZMA2, "preset": 9, "dict_size": 1 << 20}]
    known = len(shape) in (9, 10)  # layout 2, or 3 with its column groups last
    if not known or not 0 <= shape[8] <= len(pack):
        side, bits = b"", pack
    else:
        try:
            side = lzma.decompress(pack[:shape[8]], format=lzma.FORMAT_RAW, filters=filters)
        except lzma.LZMAError:
            side = b""
        bits = pack[shape[8]:]
    side, bits = bytearray(side), bytearray(bits)
    edit, at = pick(8), None
    if edit == 0 and side:  # one byte of a table, a corner, a reference or an id
        side[pick(len(side))] = pick(256)
    elif edit == 1 and bits:  # one byte of the pattern bits
        bits[pick(len(bits))] = pick(256)
    elif edit == 2:
        del side[pick(len(side) + 1):]
    elif edit == 3:
        del bits[pick(len(bits) + 1):]
    elif edit == 4:
        side += bytes([pick(256)]) * (1 + pick(64))
    elif edit == 5:
        side = bytearray(1 << (10 + pick(16)))  # inflates far past what pvs_shape declares
    elif edit == 6:
        bits += bytes([pick(256)]) * (1 + pick(8))  # bytes after the pattern stream
    elif len(shape):
        at = pick(len(shape))
        shape[at] += pick(5) - 2  # a count, a size or a length off by a little
    packed = lzma.compress(bytes(side), format=lzma.FORMAT_RAW, filters=filters)
    if known and at != 8:
        shape[8] = len(packed)
    for sec, data in ((pack_sec, packed + bytes(bits)), (shape_sec, shape.astype("<i8").tobytes())):
        body += b"\0" * (-len(body) % 64)
        sec.update(offset=len(body), nbytes=len(data), count=len(data) // (8 if sec is shape_sec
                                                                        else 1),
                   crc32=zlib.crc32(data), dtype="<i8" if sec is shape_sec else "|u1")
        body += data
    header["fields"]["extras.pvs_pack"]["shape"] = [pack_sec["count"]]
    header["fields"]["extras.pvs_shape"]["shape"] = [shape_sec["count"]]
    return body


def _edit_json(node, pick):
    """Replace one value somewhere in the header with a hostile one."""
    path = []
    while isinstance(node, (dict, list)) and node and pick(3):
        keys = sorted(node) if isinstance(node, dict) else list(range(len(node)))
        key = keys[pick(len(keys))]
        if not isinstance(node[key], (dict, list)) or not node[key]:
            path.append((node, key))
            break
        path.append((node, key))
        node = node[key]
    if not path:
        return
    parent, key = path[-1]
    choices = [-1, 0, 2 ** 31, 2 ** 40, -(2 ** 63), 1e300, float("nan"), "x", "|O8", "<f2",
               "runs", "octants", [], {}, [[[[[0]]]]], None, True, "a" * 100]
    value = choices[pick(len(choices))]
    if isinstance(parent[key], int) and not isinstance(parent[key], bool) and pick(2):
        value = parent[key] + pick(5) - 2  # an off-by-a-little size or offset
    parent[key] = value

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
    packs = [sec for sec in header["sections"] if sec["name"] == "extras.pvs_pack"]
    if packs and header["fields"]["extras.pvs_pack"]["encoding"] == "raw" and pick(3) == 0:
        body = mutate_pvs_pack(packs[0], header["fields"]["extras.pvs_pack"], body, pick)
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


def mutate_pvs_pack(sec, field, body, pick) -> bytearray:
    """A PVS whose pvs_pack (partition/pvs_codec.py) still inflates, edited inside: a pattern
    id or bits changed, the stream cut or lengthened, a zero bomb, bytes after the stream, or
    another compression level; the new section goes at the end of the body (aligned), the
    section entry, its CRC32 and the field's shape updated."""
    start, size = sec["offset"], sec["nbytes"]
    data = bytearray(zlib.decompress(bytes(body[start:start + size])))
    edit = pick(6)
    if edit == 0 and data:  # one byte: a pattern bit or a pattern id
        data[pick(len(data))] = pick(256)
    elif edit == 1 and data:
        del data[pick(len(data)):]
    elif edit == 2:
        data += bytes([pick(256)]) * (1 + pick(64))
    elif edit == 3:
        data = bytearray(1 << (10 + pick(16)))  # inflates far past what pvs_shape declares
    pack = zlib.compress(bytes(data), pick(10))
    if edit == 4:
        pack += bytes([pick(256)]) * (1 + pick(8))  # trailing bytes after the stream
    body += b"\0" * (-len(body) % 64)
    sec.update(offset=len(body), nbytes=len(pack), count=len(pack), crc32=zlib.crc32(pack))
    field["shape"] = [len(pack)]
    return body + pack


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

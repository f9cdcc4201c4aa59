"""The .vmt terrain file: a heightmap and its placed objects, compact and checksummed.

Layout (little-endian): magic b"VMT1", uint32 header length, uint32 header CRC32, the JSON
header, uint64 payload length, uint32 payload CRC32, then the payload: zlib of the uint16
samples with each row delta-coded (neighbouring samples are close, so deltas compress well).
A 1025^2 fractal is ~1.3 MB against 2.1 MB raw. Writes go through a temporary file.
Version 2 (a terrain with no-data samples, Heightmap.valid; header "holes": true) adds one
section after the samples: uint64 length, uint32 CRC32, zlib of the packed bit mask (row-major,
1 = valid). A terrain without holes is written as version 1, byte for byte as before.
"""
from __future__ import annotations

import json
import math
import struct
import zlib
from pathlib import Path

import numpy as np

from ..errors import WorldError
from ..files.atomic import atomic_write_bytes
from ..files.limits import inflate, read_bytes
from .heightmap import MAX_LEVEL, Heightmap, grid_exponent
from .placement import MAX_OBJECTS, Placement

MAGIC = b"VMT1"
VERSION = 2
MAX_FILE_BYTES = 1 << 28  # an 8193^2 terrain's samples are 134 MB before compression
MAX_EXTENT = 1e12  # world units: the terrain's width, heights and object positions


def save(path, heightmap: Heightmap, placement: Placement | None = None) -> None:
    """Write heightmap (and placement) to path atomically."""
    samples = heightmap.samples.astype("<u2")
    deltas = samples.copy()
    deltas[:, 1:] = np.diff(samples, axis=1)  # uint16 wrap-around is undone by cumsum on load
    payload = zlib.compress(deltas.tobytes(), 6)
    holes = heightmap.valid is not None
    header = {
        "version": 2 if holes else 1,
        "size": heightmap.size,
        "spacing": heightmap.spacing,
        "z_scale": heightmap.z_scale,
        "z_offset": heightmap.z_offset,
        "name": heightmap.name,
        "digest": heightmap.digest().hex(),
        "objects": (placement or Placement.empty()).to_json(),
    }
    if holes:
        header["holes"] = True
    head = json.dumps(header, sort_keys=True).encode("utf-8")
    parts = [MAGIC, struct.pack("<II", len(head), zlib.crc32(head)), head,
             struct.pack("<QI", len(payload), zlib.crc32(payload)), payload]
    if holes:
        mask = zlib.compress(np.packbits(heightmap.valid).tobytes(), 6)
        parts += [struct.pack("<QI", len(mask), zlib.crc32(mask)), mask]
    data = b"".join(parts)
    atomic_write_bytes(path, data)


def load(path) -> tuple:
    """(Heightmap, Placement) from a .vmt file.

    Raises WorldError naming the file on a missing, truncated, corrupt, wrong-magic or
    newer-version file.
    """
    path = Path(path)
    data = read_bytes(path, MAX_FILE_BYTES, what="terrain file")  # regular files only
    if data[:4] != MAGIC:
        raise WorldError(path, "not a vismobile terrain file (bad magic)")
    try:
        head_len, head_crc = struct.unpack_from("<II", data, 4)
        head = data[12:12 + head_len]
        if len(head) != head_len or zlib.crc32(head) != head_crc:
            raise WorldError(path, "terrain header is truncated or corrupt (CRC mismatch)")
        header = json.loads(head.decode("utf-8"))
        offset = 12 + head_len
        pay_len, pay_crc = struct.unpack_from("<QI", data, offset)
        payload = data[offset + 12:offset + 12 + pay_len]
        mask = None
        if isinstance(header, dict) and header.get("holes") is True:
            offset += 12 + pay_len
            mask_len, mask_crc = struct.unpack_from("<QI", data, offset)
            mask = data[offset + 12:offset + 12 + mask_len]
            if len(mask) != mask_len or zlib.crc32(mask) != mask_crc:
                raise WorldError(path, "terrain no-data mask is truncated or corrupt (CRC "
                                       "mismatch)")
    except (struct.error, UnicodeDecodeError, json.JSONDecodeError, RecursionError):
        raise WorldError(path, "terrain file is truncated or corrupt") from None
    size = check_header(path, header)
    if len(payload) != pay_len or zlib.crc32(payload) != pay_crc:
        raise WorldError(path, "terrain samples are truncated or corrupt (CRC mismatch)")
    del data
    valid = None
    if mask is not None:
        bits = inflate(mask, (size * size + 7) // 8, path, wbits=15,
                       what="terrain no-data mask decompresses")
        if len(bits) != (size * size + 7) // 8:
            raise WorldError(path, "terrain no-data mask has the wrong length")
        valid = np.unpackbits(np.frombuffer(bits, np.uint8), count=size * size).astype(bool)
        valid = valid.reshape(size, size)
    raw = inflate(payload, 2 * size * size, path, wbits=15, what="terrain samples decompress")
    if len(raw) != 2 * size * size:
        raise WorldError(path, "terrain samples have the wrong length")
    deltas = np.frombuffer(raw, dtype="<u2").reshape(size, size)
    samples = np.cumsum(deltas, axis=1, dtype=np.uint16)  # wraps exactly like the encoder
    try:
        heightmap = Heightmap(samples, header["spacing"], header["z_scale"], header["z_offset"],
                              header.get("name", path.stem), valid)
    except (ValueError, KeyError) as error:
        raise WorldError(path, f"bad terrain header ({error})") from None
    if heightmap.digest().hex() != header.get("digest"):
        raise WorldError(path, "terrain digest mismatch (samples do not match the header)")
    return heightmap, Placement.from_json(header.get("objects", []), path)


def _number(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) \
        and math.isfinite(value)


def check_header(path, header) -> int:
    """The terrain size of a .vmt header, or WorldError naming the file when a field has the
    wrong type or range (like .vmp headers): version, size (2^n+1 up to 2^MAX_LEVEL+1),
    spacing and z_scale (finite, > 0, extent within MAX_EXTENT), z_offset, and at most
    MAX_OBJECTS objects with finite positions (within MAX_EXTENT) and heights (> 0)."""
    def bad(message):
        return WorldError(path, f"bad terrain header: {message}")

    if not isinstance(header, dict):
        raise bad(f"a JSON object expected, got {type(header).__name__}")
    version = header.get("version")
    if isinstance(version, bool) or not isinstance(version, int) or version < 1:
        raise bad(f"version must be a whole number >= 1, got {version!r}")
    if version > VERSION:
        raise WorldError(path, f"terrain file version {version} is newer than this vismobile "
                               f"({VERSION})")
    size = header.get("size")
    if isinstance(size, bool) or not isinstance(size, int) or grid_exponent(size) is None \
            or grid_exponent(size) > MAX_LEVEL:
        raise bad(f"size must be 2^n+1 from 3 to {(1 << MAX_LEVEL) + 1}, got {size!r}")
    for key in ("spacing", "z_scale", "z_offset"):
        value = header.get(key)
        if not _number(value) or (key != "z_offset" and not value > 0):
            raise bad(f"{key} must be a finite number{'' if key == 'z_offset' else ' > 0'}, "
                      f"got {value!r}")
    extent = max(header["spacing"] * (size - 1), header["z_scale"] * 65535,
                 abs(header["z_offset"]))
    if extent > MAX_EXTENT:
        raise bad(f"the terrain spans {extent:g} world units, beyond {MAX_EXTENT:g}")
    if not isinstance(header.get("name", ""), str) or not isinstance(header.get("digest"), str):
        raise bad("name and digest must be strings")
    if header.get("holes", False) not in (True, False) or (header.get("holes") and version < 2):
        raise bad("holes must be true or false, and true only from version 2")
    objects = header.get("objects", [])
    if not isinstance(objects, list) or len(objects) > MAX_OBJECTS:
        raise bad(f"objects must be a list of at most {MAX_OBJECTS} records")
    for k, record in enumerate(objects):
        position = record.get("position") if isinstance(record, dict) else None
        fine = (isinstance(record, dict) and isinstance(record.get("kind"), str)
                and isinstance(position, list) and len(position) == 3
                and all(_number(c) and abs(c) <= MAX_EXTENT for c in position)
                and _number(record.get("yaw")) and _number(record.get("height"))
                and 0 < record["height"] <= MAX_EXTENT)
        if not fine:
            raise bad(f"object {k} needs a kind, a position of 3 finite numbers within "
                      f"+-{MAX_EXTENT:g}, a finite yaw and a height > 0")
    return size

"""The .vmt terrain file: a heightmap and its placed objects, compact and checksummed.

Layout (little-endian): magic b"VMT1", uint32 header length, uint32 header CRC32, the JSON
header, uint64 payload length, uint32 payload CRC32, then the payload: zlib of the uint16
samples with each row delta-coded (neighbouring samples are close, so deltas compress well).
A 1025^2 fractal is ~1.3 MB against 2.1 MB raw. Writes go through a temporary file.
"""
from __future__ import annotations

import json
import struct
import zlib
from pathlib import Path

import numpy as np

from ..errors import WorldError
from ..files.atomic import atomic_write_bytes
from .heightmap import Heightmap, grid_exponent
from .placement import Placement

MAGIC = b"VMT1"
VERSION = 1


def save(path, heightmap: Heightmap, placement: Placement | None = None) -> None:
    """Write heightmap (and placement) to path atomically."""
    samples = heightmap.samples.astype("<u2")
    deltas = samples.copy()
    deltas[:, 1:] = np.diff(samples, axis=1)  # uint16 wrap-around is undone by cumsum on load
    payload = zlib.compress(deltas.tobytes(), 6)
    header = {
        "version": VERSION,
        "size": heightmap.size,
        "spacing": heightmap.spacing,
        "z_scale": heightmap.z_scale,
        "z_offset": heightmap.z_offset,
        "name": heightmap.name,
        "digest": heightmap.digest().hex(),
        "objects": (placement or Placement.empty()).to_json(),
    }
    head = json.dumps(header, sort_keys=True).encode("utf-8")
    data = b"".join([MAGIC, struct.pack("<II", len(head), zlib.crc32(head)), head,
                     struct.pack("<QI", len(payload), zlib.crc32(payload)), payload])
    atomic_write_bytes(path, data)


def load(path) -> tuple:
    """(Heightmap, Placement) from a .vmt file.

    Raises WorldError naming the file on a missing, truncated, corrupt, wrong-magic or
    newer-version file.
    """
    path = Path(path)
    try:
        data = path.read_bytes()
    except OSError as error:
        raise WorldError(path, f"cannot read terrain file ({error.strerror or error})") from None
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
    except (struct.error, UnicodeDecodeError, json.JSONDecodeError):
        raise WorldError(path, "terrain file is truncated or corrupt") from None
    if header.get("version", 0) > VERSION:
        raise WorldError(path, f"terrain file version {header.get('version')} is newer than "
                               f"this vismobile ({VERSION})")
    if len(payload) != pay_len or zlib.crc32(payload) != pay_crc:
        raise WorldError(path, "terrain samples are truncated or corrupt (CRC mismatch)")
    size = int(header["size"])
    if grid_exponent(size) is None:
        raise WorldError(path, f"terrain size {size} is not 2^n+1")
    try:
        raw = zlib.decompress(payload)
    except zlib.error:
        raise WorldError(path, "terrain samples do not decompress") from None
    if len(raw) != 2 * size * size:
        raise WorldError(path, "terrain samples have the wrong length")
    deltas = np.frombuffer(raw, dtype="<u2").reshape(size, size)
    samples = np.cumsum(deltas, axis=1, dtype=np.uint16)  # wraps exactly like the encoder
    try:
        heightmap = Heightmap(samples, header["spacing"], header["z_scale"], header["z_offset"],
                              header.get("name", path.stem))
    except (ValueError, KeyError) as error:
        raise WorldError(path, f"bad terrain header ({error})") from None
    if heightmap.digest().hex() != header.get("digest"):
        raise WorldError(path, "terrain digest mismatch (samples do not match the header)")
    return heightmap, Placement.from_json(header.get("objects", []), path)

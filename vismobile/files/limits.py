"""Bounded reading of outside files (issue 28): only regular files are opened (a FIFO would
hang, /dev/zero never end), sizes are checked before reading, and gzip streams are inflated
with a running limit, so a decompression bomb is refused after at most `limit` bytes instead of
after gigabytes. Shared by OBJ, the other mesh formats, glTF buffers, .vmt and .vmp files."""
from __future__ import annotations

import contextlib
import logging
import os
import stat
import zlib
from pathlib import Path

from ..errors import WorldError

MAX_BYTES = 1 << 30  # a file, or what a .gz decompresses to
MAX_COORDINATE = 1e30  # |x|: squares and cross products stay finite in float64
MAX_TRIANGLES = 1 << 24  # triangles (and vertices) of a mesh file, instances counted
CHUNK = 1 << 20


def regular_file(path, error=WorldError) -> int:
    """The size of path when it is a regular file (symlinks followed), else error(path, why):
    missing, a directory, or a device, pipe or socket (reading one could hang or never end)."""
    try:
        info = os.stat(path)
    except FileNotFoundError:
        raise error(path, "no such file") from None
    except OSError as failure:
        raise error(path, f"cannot read ({failure.strerror or failure})") from None
    if stat.S_ISDIR(info.st_mode):
        raise error(path, "is a directory, not a file")
    if not stat.S_ISREG(info.st_mode):
        raise error(path, "not a regular file (device, pipe or socket); refusing to read it")
    return info.st_size


def read_bytes(path, limit: int = MAX_BYTES, error=WorldError, what="file") -> bytes:
    """The bytes of a regular file of at most `limit` bytes (error(path, why) otherwise)."""
    size = regular_file(path, error)
    if size > limit:
        raise error(path, f"{what} is {size:,} bytes, over the {limit:,} byte limit")
    try:
        with open(path, "rb") as handle:
            data = handle.read(limit + 1)
    except OSError as failure:
        raise error(path, f"cannot read ({failure.strerror or failure})") from None
    if len(data) > limit:  # grew while being read
        raise error(path, f"{what} is over the {limit:,} byte limit")
    return data


def inflate(data: bytes, limit: int, path, error=WorldError, wbits: int = 31,
            what="decompresses") -> bytes:
    """data inflated (wbits 31: gzip, every member; 15: one zlib stream) to at most `limit`
    bytes, or error(path, why) for a bomb, a truncated or corrupt stream or trailing garbage.
    Peak memory: the output so far plus one chunk."""
    out = bytearray()
    view = memoryview(data)
    position = 0
    while True:
        stream = zlib.decompressobj(wbits)
        try:
            while True:
                piece = stream.decompress(view[position:position + CHUNK], limit + 1 - len(out))
                out += piece
                if len(out) > limit:
                    raise error(path, f"{what} to over the {limit:,} byte limit "
                                      "(a decompression bomb?)")
                if stream.unconsumed_tail:  # the output cap stopped it: more to come
                    continue
                position = min(position + CHUNK, len(data))
                if stream.eof or position >= len(data):
                    break
            out += stream.flush(limit + 1 - len(out))
        except zlib.error as failure:
            raise error(path, f"corrupt compressed data ({failure})") from None
        if len(out) > limit:
            raise error(path, f"{what} to over the {limit:,} byte limit (a decompression bomb?)")
        if not stream.eof:
            raise error(path, "truncated compressed data (the stream ends early)")
        rest = stream.unused_data + bytes(view[position:])
        if not rest:
            return bytes(out)
        if wbits != 31 or rest[:2] != b"\x1f\x8b":
            raise error(path, f"{len(rest):,} bytes of garbage after the compressed data")
        data, view, position = rest, memoryview(rest), 0


def read_input(path, limit: int | None = None, error=WorldError) -> bytes:
    """A file's bytes, decompressed when its name ends in .gz, each within `limit` (default
    MAX_BYTES, read at call time)."""
    path = Path(path)
    limit = MAX_BYTES if limit is None else limit
    data = read_bytes(path, limit, error)
    if not data:
        raise error(path, "file is empty")
    if path.name.lower().endswith(".gz"):
        if data[:2] != b"\x1f\x8b":
            raise error(path, "not a gzip file (bad magic)")
        data = inflate(data, limit, path, error)
        if not data:
            raise error(path, "file is empty once decompressed")
    return data


@contextlib.contextmanager
def quiet_parser(name: str = "trimesh"):
    """The parser's own log records silenced (trimesh logs tracebacks as warnings, e.g. "failed
    to extract face_normals" on a malformed STL): the one line about a bad file is ours."""
    logger = logging.getLogger(name)
    was, logger.disabled = logger.disabled, True
    try:
        yield
    finally:
        logger.disabled = was

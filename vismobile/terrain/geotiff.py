"""A GeoTIFF DEM read by rows in bounded memory (issue 30's out-of-core build), and written.

`TiffRaster(path, budget_bytes)` parses the first image's directory (classic TIFF or BigTIFF,
either byte order) and decodes only the strips or tile rows that cover the rows asked for
(`rows(r0, r1)`), keeping the last one decoded: a DEM larger than memory is read strip by
strip, never whole. Supported: one sample per pixel, unsigned or signed 8/16/32-bit integers
and 32/64-bit floats, no compression, deflate (8, 32946), LZW (5) and PackBits (32773),
predictor 2 (integers) and 3 (floats, libtiff's byte planes, most significant first), GDAL's
no-data tag (42113) and the GeoTIFF pixel scale (33550). Anything else, and any truncated,
inconsistent or oversized directory, strip or tile, is a WorldError naming the file; no strip
or tile row may hold more than the budget. Pillow (terrain/sources.load_file) reads whole
files; it cannot stop after some strips, hence this reader.

`write_tiff(path, shape, rows, ...)` writes one the same way, strip by strip or tile row by
tile row from a function of a row range, through a temporary file and a rename (the tests'
and tools' large DEMs; Pillow reads what it writes, tests/terrain/test_outofcore.py).
"""
from __future__ import annotations

import os
import struct
import zlib
from pathlib import Path

import numpy as np
from numba import njit

from ..errors import WorldError

TAGS = {256: "width", 257: "height", 258: "bits", 259: "compression", 273: "offsets",
        277: "samples", 278: "rows_per_strip", 279: "counts", 284: "planar", 317: "predictor",
        322: "tile_width", 323: "tile_length", 324: "tile_offsets", 325: "tile_counts",
        339: "format", 33550: "pixel_scale", 42113: "nodata"}
# TIFF field types: (struct code, bytes)
TYPES = {1: ("B", 1), 2: ("s", 1), 3: ("H", 2), 4: ("I", 4), 5: ("II", 8), 6: ("b", 1),
         7: ("B", 1), 8: ("h", 2), 9: ("i", 4), 10: ("ii", 8), 11: ("f", 4), 12: ("d", 8),
         16: ("Q", 8), 17: ("q", 8), 18: ("Q", 8)}
COMPRESSIONS = {1: "none", 5: "lzw", 8: "deflate", 32946: "deflate", 32773: "packbits"}
MAX_ENTRIES = 1024
MAX_SIDE = 1 << 20


@njit(cache=True)
def _lzw(data, out):
    """TIFF LZW (MSB-first codes of 9-12 bits, codes 256 clear and 257 end, early change) into
    out; returns the bytes written, or -1 on a bad code."""
    prefix = np.zeros(4096, np.int32)
    suffix = np.zeros(4096, np.uint8)
    length = np.zeros(4096, np.int32)
    for k in range(256):
        suffix[k], length[k], prefix[k] = k, 1, -1
    stack = np.zeros(4096, np.uint8)
    nbits, nxt, previous, written = 9, 258, -1, 0
    bitpos, total = 0, data.shape[0] * 8
    while bitpos + nbits <= total:
        code = 0
        for b in range(nbits):
            p = bitpos + b
            code = (code << 1) | ((data[p >> 3] >> (7 - (p & 7))) & 1)
        bitpos += nbits
        if code == 257:
            break
        if code == 256:
            nbits, nxt, previous = 9, 258, -1
            continue
        if code > nxt or (code == nxt and previous < 0):
            return -1
        emit = code if code < nxt else previous
        n = length[emit]
        k, c = n - 1, emit
        while c >= 0:
            stack[k] = suffix[c]
            c = prefix[c]
            k -= 1
        first = stack[0]
        if code == nxt:
            stack[n] = first
            n += 1
        if written + n > out.shape[0]:
            n = out.shape[0] - written
        out[written:written + n] = stack[:n]
        written += n
        if previous >= 0 and nxt < 4096:
            prefix[nxt], suffix[nxt], length[nxt] = previous, first, length[previous] + 1
            nxt += 1
        previous = code
        if nxt + 1 >= (1 << nbits) and nbits < 12:
            nbits += 1
        if written >= out.shape[0]:
            break
    return written


@njit(cache=True)
def _packbits(data, out):
    """PackBits into out; returns the bytes written, or -1 when a run overflows out."""
    i, o = 0, 0
    while i < data.shape[0] and o < out.shape[0]:
        n = data[i]
        i += 1
        if n < 128:
            if o + n + 1 > out.shape[0] or i + n + 1 > data.shape[0]:
                return -1
            out[o:o + n + 1] = data[i:i + n + 1]
            i += n + 1
            o += n + 1
        elif n > 128:
            if o + 257 - n > out.shape[0] or i >= data.shape[0]:
                return -1
            out[o:o + 257 - n] = data[i]
            i += 1
            o += 257 - n
    return o


class TiffRaster:
    """The first image of a TIFF, read by row ranges (module doc).

    shape : (rows, cols); dtype: numpy dtype of the samples; nodata, spacing: from the GDAL
    and GeoTIFF tags (None when absent); chunk_rows: rows of one strip or tile row.
    """

    def __init__(self, path, budget_bytes: int = 64 << 20):
        self.path = Path(path)
        self.budget = int(budget_bytes)
        try:
            self.fd = os.open(self.path, os.O_RDONLY)
        except OSError as error:
            raise WorldError(path, f"cannot read ({error.strerror or error})") from None
        try:
            self.size = os.fstat(self.fd).st_size
            self._parse()
        except BaseException:
            self.close()
            raise
        self._cached = (-1, None)

    def close(self) -> None:
        if getattr(self, "fd", -1) >= 0:
            os.close(self.fd)
            self.fd = -1

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def _bad(self, message):
        return WorldError(self.path, message)

    def _read(self, offset, length) -> bytes:
        if offset < 0 or length < 0 or offset + length > self.size:
            raise self._bad(f"truncated TIFF (a read of {length} bytes at {offset} is past the "
                            f"end, {self.size} bytes)")
        data = os.pread(self.fd, length, offset)
        if len(data) != length:
            raise self._bad("truncated TIFF")
        return data

    def _parse(self) -> None:
        head = self._read(0, 16) if self.size >= 16 else self._read(0, 8)
        order = {b"II": "<", b"MM": ">"}.get(head[:2])
        if order is None:
            raise self._bad("not a TIFF (bad byte-order mark)")
        self.order = order
        version = struct.unpack(order + "H", head[2:4])[0]
        if version == 42:
            self.big, ifd = False, struct.unpack(order + "I", head[4:8])[0]
        elif version == 43 and len(head) == 16 and struct.unpack(order + "HH", head[4:8]) == (8, 0):
            self.big, ifd = True, struct.unpack(order + "Q", head[8:16])[0]
        else:
            raise self._bad(f"not a TIFF (version {version})")
        count_size, entry_size = (8, 20) if self.big else (2, 12)
        count = struct.unpack(order + ("Q" if self.big else "H"), self._read(ifd, count_size))[0]
        if not 1 <= count <= MAX_ENTRIES:
            raise self._bad(f"TIFF directory of {count} entries")
        raw = self._read(ifd + count_size, count * entry_size)
        fields = {}
        for k in range(count):
            entry = raw[k * entry_size:(k + 1) * entry_size]
            if self.big:
                tag, kind, n = struct.unpack(order + "HHQ", entry[:12])
                inline, where = entry[12:20], struct.unpack(order + "Q", entry[12:20])[0]
            else:
                tag, kind, n = struct.unpack(order + "HHI", entry[:8])
                inline, where = entry[8:12], struct.unpack(order + "I", entry[8:12])[0]
            if tag in TAGS:
                fields[TAGS[tag]] = self._value(tag, kind, n, inline, where)
        self._check(fields)

    def _value(self, tag, kind, n, inline, where):
        if kind not in TYPES:
            raise self._bad(f"TIFF tag {tag} has an unknown type {kind}")
        code, width = TYPES[kind]
        if n > (1 << 24) or n * width > self.budget:
            raise self._bad(f"TIFF tag {tag} holds {n:,} values, beyond the memory budget")
        nbytes = n * width
        data = inline[:nbytes] if nbytes <= len(inline) else self._read(where, nbytes)
        if kind == 2:
            return data.split(b"\x00")[0].decode("ascii", "replace")
        if kind in (5, 10):
            pairs = np.frombuffer(data, self.order + ("u4" if kind == 5 else "i4")).reshape(-1, 2)
            return pairs[:, 0] / np.maximum(pairs[:, 1], 1)
        return np.frombuffer(data, self.order + code).astype(np.float64 if code in "fd"
                                                             else np.int64)

    def _check(self, f) -> None:
        def one(name, default=None):
            value = f.get(name)
            if value is None:
                if default is None:
                    raise self._bad(f"TIFF has no {name.replace('_', ' ')} tag")
                return default
            if isinstance(value, str) or len(value) < 1:
                raise self._bad(f"TIFF tag {name} is malformed")
            return int(value[0])

        width, height = one("width"), one("height")
        if not (2 <= width <= MAX_SIDE and 2 <= height <= MAX_SIDE):
            raise self._bad(f"TIFF of {width} x {height} pixels (2 to {MAX_SIDE:,} a side)")
        if one("samples", 1) != 1 or one("planar", 1) != 1:
            raise self._bad("TIFF has more than one sample per pixel (a DEM has one band)")
        bits = f.get("bits")
        bits = 1 if bits is None else (int(bits[0]) if not isinstance(bits, str) and len(bits)
                                       else -1)
        form = one("format", 1)
        kinds = {(1, 8): "u1", (1, 16): "u2", (1, 32): "u4", (2, 8): "i1", (2, 16): "i2",
                 (2, 32): "i4", (3, 32): "f4", (3, 64): "f8"}
        if (form, bits) not in kinds:
            raise self._bad(f"TIFF samples of {bits} bits in format {form} (a DEM needs 8-32 "
                            "bit integers or 32/64-bit floats)")
        self.dtype = np.dtype(self.order + kinds[(form, bits)])
        compression = one("compression", 1)
        if compression not in COMPRESSIONS:
            raise self._bad(f"TIFF compression {compression} is not supported (none, deflate, "
                            "LZW or PackBits)")
        self.compression = COMPRESSIONS[compression]
        self.predictor = one("predictor", 1)
        if self.predictor not in (1, 2, 3) or (self.predictor == 3) != (form == 3) \
                and self.predictor != 1:
            raise self._bad(f"TIFF predictor {self.predictor} does not suit {kinds[(form, bits)]}"
                            " samples (2 for integers, 3 for floats)")
        self.shape = (height, width)
        if "tile_width" in f or "tile_offsets" in f:
            tw, tl = one("tile_width"), one("tile_length")
            if not (16 <= tw <= MAX_SIDE and 16 <= tl <= MAX_SIDE and tw % 16 == 0
                    and tl % 16 == 0):
                raise self._bad(f"TIFF tiles of {tw} x {tl} (multiples of 16 expected)")
            self.tile = (tl, tw)
            self.chunk_rows, across = tl, -(-width // tw)
            chunks = -(-height // tl) * across
            offsets, counts = f.get("tile_offsets"), f.get("tile_counts")
            self.chunk_bytes = tl * tw * self.dtype.itemsize
        else:
            rps = min(one("rows_per_strip", height), height)
            if rps < 1:
                raise self._bad("TIFF rows per strip is 0")
            self.tile, self.chunk_rows = None, rps
            chunks = -(-height // rps)
            offsets, counts = f.get("offsets"), f.get("counts")
            self.chunk_bytes = rps * width * self.dtype.itemsize
        if offsets is None or counts is None or isinstance(offsets, str) \
                or isinstance(counts, str) or len(offsets) != chunks or len(counts) != chunks:
            raise self._bad(f"TIFF needs {chunks} strip or tile offsets and byte counts")
        if (offsets < 0).any() or (counts < 0).any() or (offsets + counts > self.size).any():
            raise self._bad("TIFF strips or tiles lie past the end of the file (truncated)")
        # A decoded strip or tile row as float64 beside its bytes must fit the budget.
        need = self.chunk_rows * width * (8 + self.dtype.itemsize)
        if need > self.budget:
            raise self._bad(f"TIFF strips or tile rows of {need / (1 << 20):.1f} MB decoded "
                            f"exceed the memory budget ({self.budget / (1 << 20):.1f} MB)")
        if (counts > 2 * self.chunk_bytes + 4096).any():
            raise self._bad("TIFF strip or tile byte counts exceed their decoded size")
        self.offsets, self.counts = offsets, counts
        self.nodata = self.spacing = None
        if "nodata" in f:
            try:
                self.nodata = float(str(f["nodata"]).strip())
            except ValueError:
                raise self._bad(f"GDAL_NODATA tag {str(f['nodata'])[:40]!r} is not a number") \
                    from None
        scale = f.get("pixel_scale")
        if scale is not None:
            if isinstance(scale, str) or len(scale) < 2:
                raise self._bad("ModelPixelScaleTag is not (sx, sy, sz)")
            sx, sy = float(scale[0]), float(scale[1])
            if not (np.isfinite([sx, sy]).all() and sx > 0 and sy > 0):
                raise self._bad(f"ModelPixelScaleTag ({sx:g}, {sy:g}) must be finite and > 0")
            if not np.isclose(sx, sy, rtol=1e-9):
                raise self._bad(f"pixels are not square ({sx:g} x {sy:g}); pass --spacing")
            self.spacing = sx

    def _decode(self, k) -> np.ndarray:
        """(expected,) native samples of strip or tile k."""
        data = self._read(int(self.offsets[k]), int(self.counts[k]))
        rows = self.chunk_rows if self.tile else \
            min(self.chunk_rows, self.shape[0] - k * self.chunk_rows)
        width = self.tile[1] if self.tile else self.shape[1]
        expected = rows * width * self.dtype.itemsize
        if self.compression == "deflate":
            try:
                raw = zlib.decompressobj().decompress(data, expected)
            except zlib.error as error:
                raise self._bad(f"TIFF strip or tile {k} does not inflate ({error})") from None
        elif self.compression in ("lzw", "packbits"):
            out = np.zeros(expected, np.uint8)
            src = np.frombuffer(data, np.uint8)
            n = _lzw(src, out) if self.compression == "lzw" else _packbits(src, out)
            if n < 0:
                raise self._bad(f"TIFF strip or tile {k} is corrupt ({self.compression})")
            raw = out[:n].tobytes()
        else:
            raw = data[:expected]
        if len(raw) != expected:
            raise self._bad(f"TIFF strip or tile {k} holds {len(raw)} bytes, not {expected}")
        if self.predictor == 3:
            planes = np.cumsum(np.frombuffer(raw, np.uint8).reshape(rows, -1), axis=1,
                               dtype=np.uint8)
            size = self.dtype.itemsize
            values = planes.reshape(rows, size, width).transpose(0, 2, 1).copy()
            return values.view(">" + self.dtype.str[1:]).reshape(rows, width).astype(
                self.dtype.newbyteorder("="))
        values = np.frombuffer(raw, self.dtype).reshape(rows, width).astype(
            self.dtype.newbyteorder("="))
        if self.predictor == 2:
            values = np.cumsum(values, axis=1, dtype=values.dtype)
        return values

    def _chunk(self, k) -> np.ndarray:
        """(rows, width) native samples of strip or tile row k (the last one kept)."""
        if self._cached[0] == k:
            return self._cached[1]
        self._cached = (-1, None)  # free the previous one before decoding the next
        if self.tile is None:
            values = self._decode(k)
        else:
            tl, tw = self.tile
            across = -(-self.shape[1] // tw)
            values = np.empty((tl, across * tw), self.dtype.newbyteorder("="))
            for t in range(across):
                values[:, t * tw:(t + 1) * tw] = self._decode(k * across + t)
            values = values[:min(tl, self.shape[0] - k * tl), :self.shape[1]]
        self._cached = (k, values)
        return values

    def rows(self, r0: int, r1: int) -> np.ndarray:
        """(r1 - r0, cols) float64 samples of rows [r0, r1)."""
        out = np.empty((r1 - r0, self.shape[1]))
        r = r0
        while r < r1:
            k = r // self.chunk_rows
            chunk = self._chunk(k)
            top = k * self.chunk_rows
            take = min(r1, top + len(chunk)) - r
            out[r - r0:r - r0 + take] = chunk[r - top:r - top + take]
            r += take
        return out


def _encode(block, compression, predictor) -> bytes:
    """Bytes of one strip or tile (rows, width) in the file's byte order."""
    if predictor == 2:
        diff = block.copy()
        diff[:, 1:] = np.diff(block, axis=1)
        data = diff.tobytes()
    elif predictor == 3:
        size = block.dtype.itemsize
        planes = block.astype(">" + block.dtype.str[1:]).view(np.uint8)
        planes = planes.reshape(block.shape[0], block.shape[1], size).transpose(0, 2, 1)
        planes = planes.reshape(block.shape[0], -1)
        diff = planes.copy()
        diff[:, 1:] = np.diff(planes, axis=1)
        data = diff.tobytes()
    else:
        data = block.tobytes()
    return zlib.compress(data, 6) if compression == "deflate" else data


def write_tiff(path, shape, rows, dtype="<f4", compression="deflate", predictor=1,
               rows_per_strip=16, tile=None, nodata=None, spacing=None, bigtiff=False) -> None:
    """Write a one-band TIFF of shape (rows, cols) whose samples rows(r0, r1) returns
    ((r1 - r0, cols) arrays), strip by strip (or by tile rows: tile = (length, width)), with
    the GDAL no-data and GeoTIFF pixel-scale tags when given; atomically."""
    from ..files.atomic import atomic_writer

    dtype = np.dtype(dtype)
    order = dtype.str[0] if dtype.str[0] in "<>" else "<"
    height, width = shape
    form = {"u": 1, "i": 2, "f": 3}[dtype.kind]
    chunk_rows = tile[0] if tile else rows_per_strip
    offsets, counts = [], []
    with atomic_writer(path) as handle:
        handle.write(b"II" if order == "<" else b"MM")
        handle.write(struct.pack(order + ("HHHQ" if bigtiff else "HI"),
                                 *((43, 8, 0, 0) if bigtiff else (42, 0))))
        for r0 in range(0, height, chunk_rows):
            r1 = min(height, r0 + chunk_rows)
            block = np.asarray(rows(r0, r1)).astype(dtype)
            if block.shape != (r1 - r0, width):
                raise ValueError(f"rows({r0}, {r1}) gave {block.shape}, not {(r1 - r0, width)}")
            if tile:
                tl, tw = tile
                padded = np.zeros((tl, -(-width // tw) * tw), dtype)
                padded[:r1 - r0, :width] = block
                parts = [padded[:, t:t + tw] for t in range(0, padded.shape[1], tw)]
            else:
                parts = [block]
            for part in parts:
                data = _encode(np.ascontiguousarray(part), compression, predictor)
                offsets.append(handle.tell())
                counts.append(len(data))
                handle.write(data)
        if handle.tell() % 2:
            handle.write(b"\x00")
        entries = [(256, 4, [width]), (257, 4, [height]),
                   (258, 3, [dtype.itemsize * 8]),
                   (259, 3, [8 if compression == "deflate" else 1]), (262, 3, [1]),
                   (277, 3, [1]), (284, 3, [1]), (317, 3, [predictor]), (339, 3, [form])]
        long_kind = 16 if bigtiff else 4
        if tile:
            entries += [(322, 4, [tile[1]]), (323, 4, [tile[0]]), (324, long_kind, offsets),
                        (325, long_kind, counts)]
        else:
            entries += [(273, long_kind, offsets), (278, 4, [rows_per_strip]),
                        (279, long_kind, counts)]
        if spacing is not None:
            entries.append((33550, 12, [spacing, spacing, 0.0]))
        if nodata is not None:
            entries.append((42113, 2, f"{nodata!r}".encode() + b"\x00"))
        entries.sort()
        _write_ifd(handle, order, entries, bigtiff)


def _write_ifd(handle, order, entries, bigtiff) -> None:
    inline = 8 if bigtiff else 4
    ifd = handle.tell()
    size = (8 + 20 * len(entries) + 8) if bigtiff else (2 + 12 * len(entries) + 4)
    extra = ifd + size
    table, blobs = [], []
    for tag, kind, values in entries:
        code, width = TYPES[kind]
        data = bytes(values) if kind == 2 else struct.pack(order + code * len(values), *values)
        if len(data) <= inline:
            slot = data.ljust(inline, b"\x00")
        else:
            slot = struct.pack(order + ("Q" if bigtiff else "I"), extra)
            blobs.append(data + b"\x00" * (len(data) % 2))
            extra += len(blobs[-1])
        table.append(struct.pack(order + ("HHQ" if bigtiff else "HHI"), tag, kind,
                                 len(values)) + slot)
    handle.write(struct.pack(order + ("Q" if bigtiff else "H"), len(entries)))
    handle.write(b"".join(table))
    handle.write(b"\x00" * (8 if bigtiff else 4))
    handle.write(b"".join(blobs))
    handle.seek(8 if bigtiff else 4)
    handle.write(struct.pack(order + ("Q" if bigtiff else "I"), ifd))

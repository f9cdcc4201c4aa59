"""tools/hostile.py's cases of terrain inputs: .vmt headers of every wrong kind and a zlib bomb
(issue 28), heightmap files too large, too thin, out of range or of object dtype, corrupt
GeoTIFF strips, a TIFF declaring one huge strip to the out-of-core build and a truncated
.vmrpages file (issue 30)."""
from __future__ import annotations

import os

from hostile_writers import put, vmt, vmt_header, vmt_payload, zlib_bomb

CASES = {}


# ---- .vmt ---------------------------------------------------------------------------------------
def _terrain_info(folder, data, name="t.vmt"):
    path = put(folder, name, data)
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


# ---- heightmap files ----------------------------------------------------------------------
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

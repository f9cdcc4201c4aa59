"""The .vmp partition file: magic, version, JSON header (world digest, kind, build parameters,
section table), then 64-byte-aligned little-endian sections, each CRC32-checked.

Layout: b"\\x89VMP\\r\\n\\x1a\\n", uint32 version, uint32 header length, uint32 header CRC32,
header JSON (UTF-8, sorted keys), zero padding to 64, sections. The file holds the world too, so
it loads alone. Arrays are stored losslessly in the smallest form: floats as float32 when every
value survives the round trip, integers in the narrowest dtype, or as int8/int16 deltas with an
exception list (triangle indices and references are mostly close to their predecessor), or as
runs (object ids), and float64 values read from short decimal text (OBJ) as float32 plus the
digit count. first_child is derived (breadth-first: 1 + sum of earlier child counts).
"""
from __future__ import annotations

import json
import mmap
import struct
import zlib
from pathlib import Path

import numpy as np

from ..errors import PartitionError
from ..world.world import World, atomic_write_bytes
from . import pvs_codec
from .base import KINDS, Partition

MAGIC = b"\x89VMP\r\n\x1a\n"
VERSION = 1
PREFIX = struct.Struct("<8sIII")
ALIGN = 64
INT_DTYPES = ("<u1", "<i1", "<u2", "<i2", "<u4", "<i4", "<i8")
# Significant digits tried for float arrays that are not float32 (OBJ text: World.to_obj uses 6).
DECIMAL_DIGITS = (6, 7)
TREE_FIELDS = ("node_bounds", "child_count", "ref_start", "ref_end", "level_start", "tri_refs")


# ---- encoding -------------------------------------------------------------------------------
def _narrowest(values) -> str:
    if not len(values):
        return "<u1"
    low, high = int(values.min()), int(values.max())
    for dt in INT_DTYPES:
        info = np.iinfo(dt)
        if info.min <= low and high <= info.max:
            return dt
    return "<i8"


def _encode(values):
    """(encoding, [(suffix, array)]) for one array, lossless, smallest of the forms tried."""
    values = np.ascontiguousarray(values)
    if values.dtype.kind == "f":
        as32 = values.astype("<f4")
        if np.array_equal(as32.astype(values.dtype), values, equal_nan=True):
            return "raw", [("", as32)]
        for digits in DECIMAL_DIGITS:
            if np.array_equal(_from_decimal(as32, digits), values, equal_nan=True):
                return f"decimal{digits}", [("", as32)]
        return "raw", [("", values.astype("<f8"))]
    if values.dtype.kind == "b":
        return "raw", [("", values.astype("<u1"))]
    flat = values.ravel().astype(np.int64)
    options = [("raw", [("", flat.astype(_narrowest(flat)))])]
    if len(flat) > 64:
        delta = np.diff(flat, prepend=0)
        for name, dt in (("delta8", "<i1"), ("delta16", "<i2")):
            limit = np.iinfo(dt).max
            wide = np.flatnonzero(np.abs(delta) > limit)
            options.append((name, [("", np.where(np.abs(delta) <= limit, delta, 0).astype(dt)),
                                   (".index", wide.astype(_narrowest(wide))),
                                   (".value", delta[wide].astype(_narrowest(delta[wide])))]))
        starts = np.flatnonzero(np.r_[True, flat[1:] != flat[:-1]])
        options.append(("runs", [("", starts.astype(_narrowest(starts))),
                                 (".value", flat[starts].astype(_narrowest(flat[starts])))]))
    return min(options, key=lambda o: sum(a.nbytes for _, a in o[1]))


def stored_bytes(values) -> int:
    """Bytes an array takes in a .vmp section (its smallest lossless encoding, _encode),
    without the section table's entry and alignment padding."""
    return int(sum(a.nbytes for _, a in _encode(values)[1]))


def _from_decimal(as32, digits):
    """float64 values of `digits` significant decimal digits recovered from their float32.

    float32 keeps 24 bits (relative error 6e-8), so rounding it back to 6 or 7 significant
    digits finds the decimal exactly; n / 10**k with exact n and 10**k is then the correctly
    rounded float64 of that decimal, the value an OBJ parser returned.
    """
    x = as32.astype(np.float64)
    with np.errstate(divide="ignore", invalid="ignore"):
        k = (digits - 1) - np.floor(np.log10(np.abs(x)))
    k = np.where(np.isfinite(k), k, 0).astype(np.int64)
    up = np.clip(k, 0, 22)
    down = np.clip(-k, 0, 22)
    n = np.round(x * 10.0 ** up / 10.0 ** down)
    return np.where(k >= 0, n / 10.0 ** up, n * 10.0 ** down)


def _decode(encoding, parts, dtype, shape):
    count = int(np.prod(shape, dtype=np.int64))
    if encoding == "raw":
        out = parts[""]
    elif encoding in ("decimal6", "decimal7"):
        out = _from_decimal(parts[""], int(encoding[-1]))
    elif encoding in ("delta8", "delta16"):
        delta = parts[""].astype(np.int64)
        index = parts[".index"].astype(np.int64)
        if len(index) and (index.min() < 0 or index.max() >= len(delta)):
            raise ValueError("delta exception index out of range")
        delta[index] = parts[".value"]
        out = np.cumsum(delta)
    elif encoding == "runs":
        starts = parts[""].astype(np.int64)
        if len(starts) and (starts[0] != 0 or np.any(np.diff(starts) <= 0) or starts[-1] >= count):
            raise ValueError("bad run starts")
        out = np.repeat(parts[".value"], np.diff(np.append(starts, count)))
    else:
        raise ValueError(f"unknown encoding {encoding!r}")
    if out.size != count:
        raise ValueError(f"decoded {out.size} values, expected {count}")
    return out.astype(dtype, copy=False).reshape(shape)


# ---- writing --------------------------------------------------------------------------------
def _fields(partition: Partition) -> dict:
    w = partition.world
    fields = {"world.vertices": w.vertices, "world.triangles": w.triangles,
              "world.object_ids": w.object_ids}
    fields.update({name: getattr(partition, name) for name in TREE_FIELDS})
    derived = pvs_codec.DERIVED if "pvs_pack" in partition.extras else ()
    fields.update({f"extras.{name}": value for name, value in sorted(partition.extras.items())
                   if name not in derived})  # the PVS's boxes travel in its pack
    return fields


def _octree_anchor(kind, extras, world):
    """(anchor boxes, anchor level) from which octree cells are rebuilt, or None."""
    if kind == "octree" and "octant" in extras:
        return world.extent[None].astype(np.float64), 0
    if kind == "portal" and "octant" in extras:
        from .grid import cell_boxes

        return cell_boxes([np.asarray(extras[f"grid_{a}"], dtype=np.float64) for a in "xyz"]), 1
    return None


def _derived_bounds(kind, extras, world, child_count, level_start):
    """(N, 2, 3) node_bounds rebuilt from octant codes (levels above the anchor NaN), or None."""
    from .layout import outward_f32
    from .octree import octant_regions

    anchor = _octree_anchor(kind, extras, world)
    if anchor is None:
        return None
    return outward_f32(octant_regions(anchor[0], anchor[1], extras["octant"], child_count,
                                      level_start)), int(level_start[anchor[1]])


def to_bytes(partition: Partition) -> bytes:
    """The .vmp image of a partition (deterministic: same partition, same bytes)."""
    w = partition.world
    sections, blobs, table = [], [], {}
    offset = 0
    derived = _derived_bounds(partition.kind, partition.extras, w, partition.child_count,
                              partition.level_start)
    for name, value in _fields(partition).items():
        value = np.asarray(value)
        if (name == "node_bounds" and derived is not None
                and np.array_equal(derived[0][derived[1]:], value[derived[1]:])):
            # Octree cells follow from the anchor boxes and octant codes: store the top only.
            encoding, parts = "octants", [("", value[:derived[1]].astype("<f4"))]
        else:
            encoding, parts = _encode(value)
        table[name] = {"encoding": encoding, "dtype": value.dtype.str, "shape": list(value.shape),
                       "parts": [name + suffix for suffix, _ in parts]}
        for suffix, array in parts:
            data = np.ascontiguousarray(array).tobytes()
            sections.append({"name": name + suffix, "dtype": array.dtype.str,
                             "count": int(array.size), "offset": offset, "nbytes": len(data),
                             "crc32": zlib.crc32(data)})
            blobs.append(data + b"\0" * (-len(data) % ALIGN))
            offset += len(blobs[-1])
    header = {"format": "vismobile partition", "version": VERSION, "kind": partition.kind,
              "params": partition.params,
              "world": {"digest": w.digest().hex(), "triangles": w.triangle_count,
                        "vertices": len(w.vertices), "name": w.name,
                        "object_names": list(w.object_names),
                        "repair": getattr(w, "repair", None) or "none"},
              "fields": table, "sections": sections}
    text = json.dumps(header, sort_keys=True, separators=(",", ":")).encode("utf-8")
    head = PREFIX.pack(MAGIC, VERSION, len(text), zlib.crc32(text)) + text
    head += b"\0" * (-len(head) % ALIGN)
    # No padding after the last section, so any truncation cuts into data.
    body = b"".join(blobs)
    end = sections[-1]["offset"] + sections[-1]["nbytes"] if sections else 0
    return head + body[:end]


def save_partition(partition: Partition, path) -> None:
    """Write partition to path atomically (temporary file, then rename)."""
    atomic_write_bytes(path, to_bytes(partition))


# ---- reading --------------------------------------------------------------------------------
def load_partition(path, world: World | None = None) -> Partition:
    """Read a .vmp file (memory-mapped); every section's CRC32 and the world digest are checked.

    world : when given, the file must have been built from this world (same digest)
    Raises PartitionError naming the file when it is missing, truncated, corrupt, of another
    format, of a newer version, or built from another world.
    """
    path, buffer = _open_mapped(path)
    try:
        return _parse(path, buffer, world)
    except PartitionError:
        raise
    except (ValueError, KeyError, TypeError, IndexError, OverflowError, AttributeError,
            struct.error, UnicodeDecodeError, RecursionError) as error:
        raise PartitionError(f"{path}: malformed partition file: {error}") from None


def _open_mapped(path):
    """(path, read-only mmap of the file), or PartitionError naming the file."""
    from ..files.limits import regular_file

    path = Path(path)
    regular_file(path, lambda p, why: PartitionError(f"{p}: {why}"))  # a FIFO would block open
    try:
        with open(path, "rb") as handle:
            size = path.stat().st_size
            if size < PREFIX.size:
                raise PartitionError(f"{path}: not a vismobile partition file (too short: {size} bytes)")
            return path, mmap.mmap(handle.fileno(), 0, access=mmap.ACCESS_READ)
    except OSError as error:
        raise PartitionError(f"{path}: cannot read partition file: {error.strerror or error}") from None


def map_partition(path, verify: bool = True) -> Partition:
    """A streamed .vmp (external.build_octree_file: every section raw) with its world and
    references left in the memory-mapped file: nothing world-sized is decoded or copied.

    The world is a mapped.MappedWorld (float32 vertices); node arrays (small) are decoded.
    verify : check every section's CRC32 (one streamed pass over the file); the world digest
             is taken from the header. Raises PartitionError naming the file when it is not a
             mappable partition, or is truncated, corrupt or inconsistent.
    """
    from ..world.mapped import MappedWorld

    path, buffer = _open_mapped(path)
    try:
        header, arrays = _sections(path, buffer, verify)
        fields = {}
        for name, entry in header["fields"].items():
            if entry["encoding"] != "raw" or entry["parts"] != [name]:
                raise PartitionError(f"{path}: section {name} is encoded ({entry['encoding']}); "
                                     f"only streamed partition files can be mapped")
            fields[name] = arrays[name].reshape(tuple(int(n) for n in entry["shape"]))
        info = header["world"]
        world = MappedWorld(fields["world.vertices"], fields["world.triangles"],
                            fields["world.object_ids"], list(info["object_names"]),
                            str(info["name"]), digest=bytes.fromhex(info["digest"]))
        if header["kind"] not in KINDS:
            raise PartitionError(f"{path}: unknown structure kind {header['kind']!r}")
        child_count = fields["child_count"].astype(np.int32)
        first_child = np.where(child_count > 0, 1 + np.cumsum(child_count) - child_count, -1)
        result = Partition(kind=header["kind"], params=header["params"], world=world,
                           node_bounds=fields["node_bounds"].astype(np.float64),
                           first_child=first_child.astype(np.int32), child_count=child_count,
                           ref_start=fields["ref_start"].astype(np.int64),
                           ref_end=fields["ref_end"].astype(np.int64),
                           level_start=fields["level_start"].astype(np.int64),
                           tri_refs=fields["tri_refs"],
                           extras={n[len("extras."):]: v for n, v in fields.items()
                                   if n.startswith("extras.")})
        result.extras.update(pvs_codec.derived_extras(result.extras, world.triangle_count))
    except PartitionError:
        raise
    except (ValueError, KeyError, TypeError, IndexError, OverflowError, AttributeError,
            struct.error, UnicodeDecodeError, RecursionError) as error:
        raise PartitionError(f"{path}: malformed partition file: {error}") from None
    try:
        result.check()
    except ValueError as error:
        raise PartitionError(f"{path}: inconsistent partition file: {error}") from None
    return result


# Header limits: JSON nesting (the format needs 4 levels), decoded size per file byte (runs
# and deltas compress at most this much in files vismobile writes), decoded bytes in all.
MAX_JSON_DEPTH = 16
MAX_EXPANSION = 64
MAX_DECODED_BYTES = 1 << 32
NUMERIC_DTYPES = frozenset(INT_DTYPES + ("|u1", "|i1", "|b1", "<f4", "<f8", "<u8"))
# params a loaded file's readers use (culling/portals.py, culling/pvs.py, partition/pvs.py):
# their JSON types, and for numbers that they are finite and not negative (budget: a number,
# or "none" for exact sets; a file baked before the default budget has none)
PARAM_KINDS = {"thickness": (int, float), "budget": (int, float), "walls": bool, "pvs": str,
               "fly": str}


def _json_depth(text: bytes) -> int:
    """Deepest [ / { nesting of JSON text (brackets inside strings ignored), without recursion."""
    import re

    bare = re.sub(rb'"(?:[^"\\]|\\.)*"', b'""', text)
    codes = np.frombuffer(bare, dtype=np.uint8)
    step = np.isin(codes, (ord("["), ord("{"))).astype(np.int64) - np.isin(
        codes, (ord("]"), ord("}")))
    return int(np.cumsum(step).max(initial=0))


def _header(text: bytes) -> dict:
    """The header as a dict, every value the reader uses of the right type (else ValueError)."""
    if _json_depth(text) > MAX_JSON_DEPTH:
        raise ValueError(f"header nested deeper than {MAX_JSON_DEPTH} levels")
    header = json.loads(text.decode("utf-8"))

    def need(value, kind, what):
        if not isinstance(value, kind) or (kind is int and isinstance(value, bool)):
            raise ValueError(f"header {what} must be {getattr(kind, '__name__', kind)}")
        return value

    need(header, dict, "")
    need(header.get("kind"), str, "kind")
    for key, value in need(header.get("params"), dict, "params").items():
        if key == "budget" and value == "none":  # a conservative bake that kept exact sets
            continue
        if key in PARAM_KINDS:
            kind = PARAM_KINDS[key]
            if kind is not bool and isinstance(value, bool):
                raise ValueError(f"header params.{key} must be a number")
            need(value, kind, f"params.{key}")
            if kind is not bool and kind is not str and not 0 <= value < float("inf"):
                raise ValueError(f"header params.{key} must be finite and not negative")
    info = need(header.get("world"), dict, "world")
    need(info.get("digest"), str, "world.digest")
    need(info.get("name"), str, "world.name")
    for name in need(info.get("object_names"), list, "world.object_names"):
        need(name, str, "object name")
    for sec in need(header.get("sections"), list, "sections"):
        need(sec, dict, "section")
        need(sec.get("name"), str, "section name")
        if need(sec.get("dtype"), str, "section dtype") not in NUMERIC_DTYPES:
            raise ValueError(f"section dtype {sec['dtype'][:20]!r} is not a numeric type")
        for key in ("offset", "nbytes", "count", "crc32"):
            if need(sec.get(key), int, f"section {key}") < 0:
                raise ValueError(f"section {key} is negative")
    for name, entry in need(header.get("fields"), dict, "fields").items():
        need(entry, dict, f"field {name}")
        need(entry.get("encoding"), str, f"field {name} encoding")
        if need(entry.get("dtype"), str, f"field {name} dtype") not in NUMERIC_DTYPES:
            raise ValueError(f"field {name} dtype {entry['dtype'][:20]!r} is not numeric")
        for n in need(entry.get("shape"), list, f"field {name} shape"):
            if need(n, int, f"field {name} shape") < 0:
                raise ValueError(f"field {name} has a negative size")
        for part in need(entry.get("parts"), list, f"field {name} parts"):
            if not need(part, str, f"field {name} part").startswith(name):
                raise ValueError(f"field {name} names a part of another field")
    return header


def _check_sizes(path, header, file_size) -> None:
    """PartitionError when a declared size cannot come from a file this large: sections past
    the end, or decoded arrays over MAX_EXPANSION elements per file byte or MAX_DECODED_BYTES."""
    total = 0
    for name, entry in header["fields"].items():
        count = int(np.prod([int(n) for n in entry["shape"]], dtype=object))
        if count > MAX_EXPANSION * file_size:
            raise PartitionError(f"{path}: corrupt partition file ({name} declares {count:,} "
                                 f"values, more than a {file_size:,} byte file holds)")
        total += count * np.dtype(entry["dtype"]).itemsize
    if total > MAX_DECODED_BYTES:
        raise PartitionError(f"{path}: partition file decodes to {total:,} bytes, over the "
                             f"limit of {MAX_DECODED_BYTES:,}")
    for sec in header["sections"]:
        if sec["count"] * np.dtype(sec["dtype"]).itemsize > file_size:
            raise PartitionError(f"{path}: truncated partition file (section {sec['name']})")


def _sections(path, buffer, verify=True):
    """(header dict, {section name: array viewing the mapped file}) after the magic, version,
    header, size and (verify) section CRC checks."""
    magic, version, header_len, header_crc = PREFIX.unpack_from(buffer, 0)
    if magic != MAGIC:
        raise PartitionError(f"{path}: not a vismobile partition file (bad magic)")
    if version > VERSION:
        raise PartitionError(f"{path}: partition format version {version} is newer than this "
                             f"vismobile reads (version {VERSION}); rebuild it or upgrade")
    if version < 1:
        raise PartitionError(f"{path}: unknown partition format version {version}")
    if PREFIX.size + header_len > len(buffer):
        raise PartitionError(f"{path}: truncated partition file (header)")
    text = bytes(buffer[PREFIX.size:PREFIX.size + header_len])
    if zlib.crc32(text) != header_crc:
        raise PartitionError(f"{path}: corrupt partition file (header checksum mismatch)")
    header = _header(text)
    base = PREFIX.size + header_len
    base += -base % ALIGN
    view = memoryview(buffer)
    _check_sizes(path, header, len(buffer))
    arrays = {}
    for sec in header["sections"]:
        start, nbytes = base + int(sec["offset"]), int(sec["nbytes"])
        dtype = np.dtype(sec["dtype"])
        if start < base or nbytes < 0 or start + nbytes > len(buffer):
            raise PartitionError(f"{path}: truncated partition file (section {sec['name']})")
        if nbytes != int(sec["count"]) * dtype.itemsize:
            raise PartitionError(f"{path}: corrupt partition file (section {sec['name']} size)")
        if verify and _crc(view, start, nbytes) != int(sec["crc32"]):
            raise PartitionError(f"{path}: corrupt partition file (checksum of section "
                                 f"{sec['name']})")
        arrays[sec["name"]] = np.frombuffer(buffer, dtype=dtype, count=int(sec["count"]),
                                            offset=start)
    return header, arrays


def _crc(view, start, nbytes, step=1 << 24) -> int:
    """CRC32 of view[start:start + nbytes], in pieces (a mapped file is paged in as it goes)."""
    crc = 0
    for at in range(start, start + nbytes, step):
        crc = zlib.crc32(view[at:min(at + step, start + nbytes)], crc)
    return crc


def _parse(path, buffer, world):
    header, arrays = _sections(path, buffer)
    fields = {}
    for name, entry in header["fields"].items():
        if entry["encoding"] == "octants":
            continue
        parts = {part[len(name):]: arrays[part] for part in entry["parts"]}
        fields[name] = _decode(entry["encoding"], parts, np.dtype(entry["dtype"]),
                               tuple(int(n) for n in entry["shape"]))
    info = header["world"]
    loaded = World(fields["world.vertices"], fields["world.triangles"],
                   fields["world.object_ids"], list(info["object_names"]), str(info["name"]))
    if loaded.digest().hex() != info["digest"]:
        raise PartitionError(f"{path}: corrupt partition file (world does not match its digest)")
    loaded.repair = info.get("repair", "none")
    if loaded.repair not in ("none", "tjunctions"):
        raise PartitionError(f"{path}: unknown world repair {loaded.repair!r}")
    if world is not None and world.digest() != loaded.digest():
        given = getattr(world, "repair", None) or "none"
        if given != loaded.repair:
            raise PartitionError(f"{path}: built from the world with --repair {loaded.repair}, "
                                 f"given with --repair {given} (triangle ids differ); load "
                                 f"the world with repair={loaded.repair!r} or rebuild")
        raise PartitionError(f"{path}: built from another world (digest differs from "
                             f"{world.name}); rebuild the partition")
    kind = header["kind"]
    if kind not in KINDS:
        raise PartitionError(f"{path}: unknown structure kind {kind!r}")
    child_count = fields["child_count"].astype(np.int32)
    extras = {name[len("extras."):]: value for name, value in fields.items()
              if name.startswith("extras.")}
    try:
        extras.update(pvs_codec.derived_extras(extras, loaded.triangle_count))
    except ValueError as error:
        raise PartitionError(f"{path}: inconsistent partition file: {error}") from None
    if header["fields"]["node_bounds"]["encoding"] == "octants":
        shape = tuple(int(n) for n in header["fields"]["node_bounds"]["shape"])
        if shape != (len(child_count), 2, 3) or "octant" not in extras:
            raise ValueError("octant-coded bounds do not match the tree")
        level_start = np.asarray(fields["level_start"], dtype=np.int64)
        if (len(level_start) < 2 or level_start[0] != 0 or level_start[-1] != len(child_count)
                or np.any(np.diff(level_start) <= 0)
                or int(child_count.astype(np.int64).sum()) != len(child_count) - 1):
            raise ValueError("tree levels do not match the node count")
        bounds, top = _derived_bounds(kind if kind in KINDS else "", extras, loaded, child_count,
                                      level_start)
        bounds[:top] = arrays[header["fields"]["node_bounds"]["parts"][0]].reshape(-1, 2, 3)
        fields["node_bounds"] = bounds
    first_child = np.where(child_count > 0, 1 + np.cumsum(child_count) - child_count, -1)
    result = Partition(kind=kind, params=header["params"], world=world or loaded,
                       node_bounds=fields["node_bounds"], first_child=first_child.astype(np.int32),
                       child_count=child_count, ref_start=fields["ref_start"],
                       ref_end=fields["ref_end"], level_start=fields["level_start"],
                       tri_refs=fields["tri_refs"], extras=extras)
    try:
        result.check()
    except ValueError as error:
        raise PartitionError(f"{path}: inconsistent partition file: {error}") from None
    return result

"""OBJ input: a line-level validator for clear errors, then trimesh for the parsing itself."""
from __future__ import annotations

import io
import itertools
import math
import re
from pathlib import Path

import numpy as np

from ..errors import WorldError
from .limits import MAX_COORDINATE, quiet_parser, read_input

# Statements of the OBJ format (geometry, grouping, display and free-form); anything else is garbage.
KNOWN_STATEMENTS = frozenset(
    "v vt vn vp f l p o g s mtllib usemtl usemap maplib shadow_obj trace_obj lod bevel "
    "c_interp d_interp ctech stech cstype deg bmat step curv curv2 surf parm trim hole "
    "scrv sp end con mg call csh".split())
# Limits that keep a small file from costing minutes or gigabytes downstream: coordinates whose
# squares and cross products stay finite in float64, polygons trimesh fans out cheaply, and
# groups (each a trimesh mesh of its own).
MAX_CORNERS = 256
MAX_GROUPS = 4096
# Characters trimesh and str.split treat differently (non-ASCII white space, line separators,
# control characters), a lone carriage return, and a backslash line continuation trimesh joins.
_AMBIGUOUS = re.compile(r"[\x00-\x08\x0b\x0c\x0e-\x1f\x7f-\xa0\u1680\u2000-\u200b\u2028\u2029"
                        r"\u202f\u205f\u3000\ufeff]|\r(?!\n)|\\\r?\n")
_NUMBER = r"[+-]?(?:\d{1,400}(?:\.\d{0,400})?|\.\d{1,400})(?:[eE][+-]?\d{1,4})?"
_INDEX = r"-?\d{1,12}"  # longer indices cannot be in range of a 1 GiB file
# Statements trimesh finds only at the start of a line and followed by one space.
_STRICT = ("v", "vt", "vn", "f", "o", "g")
_STATEMENT = re.compile(r"^([ \t]*)([^\s#]\S*)(.?)", re.MULTILINE)


def _bad_statement(indent, keyword, after) -> bool:
    """True for an unknown keyword, or one trimesh finds only at the start of a line followed
    by a space, given otherwise."""
    return keyword not in KNOWN_STATEMENTS or (keyword in _STRICT and (indent or after != " "))


_DATA_LINE = {key: re.compile(rf"^{key} (?![ \t]*{_NUMBER}(?:[ \t]+{_NUMBER})*[ \t]*$).*$",
                              re.MULTILINE) for key in ("v", "vt", "vn")}
_NOT_NUMERIC = re.compile(r"[^0-9eE+\-. \t]")
# Corner forms: v, v/t, v//n, v/t/n; every face of a file uses one.
_FORMS = {"v": _INDEX, "v/t": rf"{_INDEX}/{_INDEX}", "v//n": rf"{_INDEX}//{_INDEX}",
          "v/t/n": rf"{_INDEX}/{_INDEX}/{_INDEX}"}


def _form_of(corner):
    for name, pattern in _FORMS.items():
        if re.fullmatch(pattern, corner):
            return name
    return None


def _line(text, position):
    return text.count("\n", 0, position) + 1


def validate_obj(path: Path, text: str) -> str:
    """The text as trimesh will read it (CRLF -> LF), or WorldError at the first line that
    trimesh would misread or silently drop, or that would cost far more than its size.

    Checks: only ASCII white space, no control characters or line continuations; v, vt, vn, f,
    o, g at the start of their line and followed by a space; vertex lines of 3 to 7 plain
    decimal numbers (the same count on every line), finite and within MAX_COORDINATE; faces of
    3 to MAX_CORNERS corners of one form throughout the file (v, v/t, v//n or v/t/n), indices
    within the elements defined so far (negative ones relative, and only once all are defined,
    where trimesh resolves them the same way); at most MAX_GROUPS o/g names holding faces.
    Vectorised: regular expressions and numpy over the whole text, no per-line Python.
    """
    found = _AMBIGUOUS.search(text)
    if found is not None:
        char = found.group()[0]
        what = ("backslash line continuation" if char == "\\" else
                f"character {char!r} (control, non-ASCII white space or line separator)")
        raise WorldError(path, f"unsupported {what}", _line(text, found.start()))
    text = text.replace("\r\n", "\n")
    # One pass over every statement: (indent, keyword, the character after it).
    starts = set(_STATEMENT.findall(text))
    if any(_bad_statement(*start) for start in starts):
        found = next(m for m in _STATEMENT.finditer(text) if _bad_statement(*m.groups()))
        keyword = found.group(2)
        message = (f"unparsable statement {keyword[:20]!r}" if keyword not in KNOWN_STATEMENTS
                   else f"{keyword!r} must start its line and be followed by a space")
        raise WorldError(path, message, _line(text, found.start()))
    positions, values = {}, {}
    for key in ("v", "vt", "vn"):
        starts = [m.start() for m in re.finditer(rf"^{key} ", text, re.M)]
        positions[key] = np.array(starts, dtype=np.int64)
        values[key] = _data_lines(path, text, key, starts)
    _check_vertices(path, text, positions["v"], values["v"])
    _check_faces(path, text, positions)
    return text


def _data_lines(path, text, key, starts):
    """The value text of each `key` line; WorldError at the first that is not plain numbers."""
    ends = [text.find("\n", s) for s in starts]
    lines = [text[s + len(key) + 1:e if e >= 0 else len(text)] for s, e in zip(starts, ends)]
    joined = " ".join(lines)
    try:
        if _NOT_NUMERIC.search(joined) is None:
            np.array(joined.split(), dtype=np.float64)
            return lines
    except ValueError:
        pass
    bad = _DATA_LINE[key].search(text)  # the slow, exact check finds the line
    what = "vertex" if key == "v" else key
    raise WorldError(path, f"{what} coordinate is not a plain decimal number",
                     _line(text, bad.start()) if bad else None)


def _check_vertices(path, text, starts, lines):
    if not len(starts):
        return
    widths = np.array([len(line.split()) for line in lines])
    wrong = np.flatnonzero((widths < 3) | (widths > 7) | (widths != widths[0]))
    if len(wrong):
        i = wrong[0]
        expected = "3 to 7" if widths[i] < 3 or widths[i] > 7 else f"{widths[0]} like line {_line(text, starts[0])}"
        raise WorldError(path, f"vertex has {widths[i]} values, expected {expected}",
                         _line(text, starts[i]))
    with np.errstate(over="ignore"):
        values = np.array(" ".join(lines).split(), dtype=np.float64).reshape(len(lines), -1)
    bad = ~np.isfinite(values).all(axis=1)
    if bad.any():
        raise WorldError(path, "vertex coordinate is NaN or infinite",
                         _line(text, starts[np.argmax(bad)]))
    bad = (np.abs(values[:, :3]) > MAX_COORDINATE).any(axis=1)
    if bad.any():
        raise WorldError(path, f"vertex coordinate beyond +-{MAX_COORDINATE:g}",
                         _line(text, starts[np.argmax(bad)]))


def _check_faces(path, text, positions):
    matches = list(re.finditer(r"^f (.*)$", text, re.M))
    if not matches:
        return
    starts = np.array([m.start() for m in matches], dtype=np.int64)
    corners = [m.group(1).split() for m in matches]
    counts = np.array([len(c) for c in corners])
    few, many = counts < 3, counts > MAX_CORNERS
    if few.any() or many.any():
        i = int(np.argmax(few | many))
        message = ("face has fewer than 3 corners" if few[i] else
                   f"face has {counts[i]} corners, over the limit of {MAX_CORNERS}")
        raise WorldError(path, message, _line(text, starts[i]))
    form = _form_of(corners[0][0])
    if form is None:
        raise WorldError(path, f"face index {corners[0][0][:20]!r} is not an integer",
                         _line(text, starts[0]))
    pattern = re.compile(_FORMS[form])
    distinct = set(itertools.chain.from_iterable(corners))  # corners repeat: test each once
    if not all(pattern.fullmatch(c) for c in distinct):
        i = next(i for i, line in enumerate(corners)
                 if not all(pattern.fullmatch(c) for c in line))
        bad = next(c for c in corners[i] if not pattern.fullmatch(c))
        message = (f"face corner {bad[:20]!r} mixes forms (v, v/t, v//n, v/t/n) with "
                   "earlier faces" if _form_of(bad) else
                   f"face index {bad[:20]!r} is not an integer")
        raise WorldError(path, message, _line(text, starts[i]))
    flat = " ".join(" ".join(c) for c in corners).replace("/", " ")
    values = np.array(flat.split(), dtype=np.int64).reshape(int(counts.sum()), -1)
    line_of = np.repeat(np.arange(len(matches)), counts)
    keys = {"v": ("v", 0, "face index"), "v/t": ("vt", 1, "texture index"),
            "v//n": ("vn", 1, "normal index"), "v/t/n": ("vt", 1, "texture index")}
    checks = [("v", 0, "face index")] + ([keys[form]] if form != "v" else [])
    if form == "v/t/n":
        checks.append(("vn", 2, "normal index"))
    for key, column, what in checks:
        index = values[:, column]
        defined = np.searchsorted(positions[key], starts)[line_of]
        total = len(positions[key])
        resolved = np.where(index < 0, index + defined + 1, index)
        bad = (resolved < 1) | (resolved > defined) | ((index < 0) & (defined != total))
        if bad.any():
            i = int(np.argmax(bad))
            reason = ("before all elements are defined (unsupported)"
                      if index[i] < 0 and defined[i] != total and 1 <= resolved[i] <= defined[i]
                      else f"out of range (1..{defined[i]} defined)")
            raise WorldError(path, f"{what} {index[i]} {reason}",
                             _line(text, starts[line_of[i]]))
    _check_groups(path, text, starts)


def _check_groups(path, text, face_starts):
    """At most MAX_GROUPS distinct (o, g) names hold faces (trimesh makes a mesh of each)."""
    names, held = [None, None], set()
    statements = list(re.finditer(r"^([og]) (.*)$", text, re.M))
    bounds = [m.start() for m in statements] + [len(text)]
    if face_starts[0] < bounds[0]:
        held.add((None, None))
    for k, match in enumerate(statements):
        names[match.group(1) == "g"] = match.group(2).strip()
        first = np.searchsorted(face_starts, bounds[k])
        if first < len(face_starts) and face_starts[first] < bounds[k + 1]:
            held.add(tuple(names))
            if len(held) > MAX_GROUPS:
                raise WorldError(path, f"more than {MAX_GROUPS} objects/groups hold faces",
                                 _line(text, match.start()))


def read_text(path: Path) -> str:
    """File contents as text (a .gz file decompressed), or WorldError for missing, unreadable,
    empty or binary files."""
    if path.is_dir():
        raise WorldError(path, "is a directory, not an OBJ file")
    data = read_input(path)  # a regular file; a .gz inflated with a running limit
    if b"\x00" in data:
        raise WorldError(path, "binary content, not an OBJ text file",
                         data[: data.index(b"\x00")].count(b"\n") + 1)
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as error:
        try:
            return data.decode("latin-1")
        except UnicodeDecodeError:  # pragma: no cover - latin-1 decodes every byte
            raise WorldError(path, "not text", data[: error.start].count(b"\n") + 1) from None


def load_obj(path) -> tuple:
    """Parse an OBJ with trimesh: (vertices (V,3) f8, triangles (T,3) i4, object_ids (T,) i4, names).

    Polygons are triangulated and coincident vertices welded by trimesh; missing .mtl and
    texture files are ignored. Raises WorldError with file and line on bad input.
    """
    import trimesh

    path = Path(path)
    text = read_text(path)
    if not text.strip():
        raise WorldError(path, "file holds only white space")
    text = validate_obj(path, text)
    try:
        # trimesh reads the very text validated above, not the file again.
        stream = io.BytesIO(text.encode("utf-8"))
        # trimesh names ungrouped faces after the file ("cow.obj" for cow.obj and cow.obj.gz)
        stream.name = path.name[:-3] if path.suffix.lower() == ".gz" else path.name
        with quiet_parser():
            scene = trimesh.load(stream, file_type="obj", force="scene", split_objects=True,
                                 split_groups=True, group_material=False, process=True,
                                 skip_materials=True)
    except Exception as error:  # trimesh raises assorted types on malformed input
        raise WorldError(path, f"unparsable OBJ ({type(error).__name__}: {error})") from None
    meshes = [(name, geometry) for name, geometry in scene.geometry.items()
              if isinstance(geometry, trimesh.Trimesh) and len(geometry.faces)]
    if not meshes:
        raise WorldError(path, "no faces")
    vertices, triangles, ids, names = [], [], [], []
    offset = 0
    for name, mesh in sorted(meshes, key=lambda item: item[0]):
        mesh.merge_vertices()
        vertices.append(np.asarray(mesh.vertices, dtype=np.float64))
        triangles.append(np.asarray(mesh.faces, dtype=np.int64) + offset)
        ids.append(np.full(len(mesh.faces), len(names), dtype=np.int32))
        names.append(str(name))
        offset += len(mesh.vertices)
    return (np.concatenate(vertices), np.concatenate(triangles).astype(np.int32),
            np.concatenate(ids), names)

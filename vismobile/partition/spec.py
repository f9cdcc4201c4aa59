"""Structure specs, the one grammar every command uses: `KIND[:N][,key=value...]`.

`octree:5` (depth 5), `grid:8` (8 slabs per axis), `portal:2`, `bsp`, `bsp:min_leaf=4,seed=1`,
`grid:slabs=4x1x4` (per axis), `kdtree`, `kdtree:split=median,max_depth=12,min_leaf=8`, `none`. A bare number sets the kind's main parameter.
"""
from __future__ import annotations

KINDS = ("grid", "octree", "portal", "bsp", "kdtree")

# The parameter a bare number sets, per kind.
MAIN_PARAMETER = {"octree": "depth", "portal": "depth", "grid": "slabs", "bsp": "max_depth",
                  "kdtree": "max_depth"}
NONE = ("", "none")
HELP = ("none, " + ", ".join(f"{k}[:N]" for k in KINDS) + " or KIND:key=value,... "
        "(N: octree depth 1..8, portal depth 1..3, grid slabs per axis, bsp/kdtree max depth)")


def parse_value(text: str):
    """'5' -> 5, '0.5' -> 0.5, 'true' -> True, '4x1x4' -> (4, 1, 4); anything else stays text."""
    text = text.strip()
    if text.lower() in ("true", "false"):
        return text.lower() == "true"
    parts = text.lower().split("x")
    if len(parts) == 3 and all(p.isdigit() for p in parts):
        return tuple(int(p) for p in parts)
    for cast in (int, float):
        try:
            return cast(text)
        except ValueError:
            pass
    return text


def parse_spec(text) -> tuple:
    """'octree:5' -> ('octree', {'depth': 5}); 'none' -> (None, {}).

    Raises ValueError naming the valid kinds on an unknown kind, and on a parameter given twice.
    Unknown parameter names are left to partition(), which lists the valid ones.
    """
    text = str(text).strip()
    if text.lower() in NONE:
        return None, {}
    kind, _, rest = text.partition(":")
    kind = kind.strip().lower()
    if kind not in KINDS:
        raise ValueError(f"unknown structure {kind!r} in {text!r}; valid: {HELP}")
    params = {}
    for item in filter(None, (p.strip() for p in rest.split(","))):
        key, eq, value = item.partition("=")
        key, value = (key.strip(), value) if eq else (MAIN_PARAMETER[kind], item)
        if key in params:
            raise ValueError(f"{key} given twice in {text!r}")
        params[key] = parse_value(value)
    return kind, params


def format_spec(kind, params) -> str:
    """Canonical text of a spec: the main parameter as a bare number, the rest key=value."""
    if kind is None:
        return "none"
    main = MAIN_PARAMETER.get(kind)
    bare = isinstance(params.get(main), int) and not isinstance(params.get(main), bool)
    items = [str(params[main])] if bare else []
    for key, value in params.items():
        if key == main and bare:
            continue
        if isinstance(value, (tuple, list)) and all(isinstance(v, int) for v in value):
            value = "x".join(map(str, value))
        items.append(f"{key}={value}")
    return kind + (":" + ",".join(items) if items else "")

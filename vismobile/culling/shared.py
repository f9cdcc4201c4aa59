"""Tables a culling stage derives from a whole world or partition, computed once per object:
cullers made again over the same partition (a study's runs, the tuner's trials) share them
instead of recomputing (on W2 octree 5 a culler with occlusion and cones took 0.45 s to make,
most of a 30-frame run). Shared arrays are never written: stages keep their scratch apart."""
from __future__ import annotations

import weakref

_TABLES: dict = {}  # id(owner) -> {name: table}


def per_object(owner, name, compute):
    """compute() the first time (owner, name) is asked for while owner lives, then that same
    result. Exact (it is compute()'s result); an owner without weak references is not cached."""
    tables = _TABLES.get(id(owner))
    if tables is None:
        try:
            weakref.finalize(owner, _TABLES.pop, id(owner), None)  # all its tables go with it
        except TypeError:
            return compute()
        tables = _TABLES[id(owner)] = {}
    if name not in tables:
        tables[name] = compute()
    return tables[name]

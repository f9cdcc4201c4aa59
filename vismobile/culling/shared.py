"""Tables a culling stage derives from a whole world or partition, computed once per object:
cullers made again over the same partition (a study's runs, the tuner's trials) share them
instead of recomputing (on W2 octree 5 a culler with occlusion and cones took 0.45 s to make,
most of a 30-frame run). Shared arrays are never written: stages keep their scratch apart."""
from __future__ import annotations

import weakref

_TABLES: dict = {}


def per_object(owner, name, compute):
    """compute() the first time (owner, name) is asked for while owner lives, then that same
    result. Exact (it is compute()'s result); an owner without weak references is not cached."""
    key = (id(owner), name)
    if key in _TABLES:
        return _TABLES[key]
    try:
        weakref.ref(owner)
    except TypeError:
        return compute()
    value = compute()
    if not any(k[0] == key[0] for k in _TABLES):  # the owner's first table: drop all with it
        weakref.finalize(owner, _forget, key[0])
    _TABLES[key] = value
    return value


def _forget(ident: int) -> None:
    for key in [k for k in _TABLES if k[0] == ident]:
        del _TABLES[key]

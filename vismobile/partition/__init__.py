"""The offline partitioner: `partition(world, kind, **params)` builds a Partition (base.py
layout) as a grid, octree, portal octree, BSP tree or kd-tree; `save_partition` writes a .vmp
file and `load_partition` reads one."""
from __future__ import annotations

import sys
import types

from .base import KINDS, Partition
from .store import load_partition, save_partition

__all__ = ["partition", "load_partition", "save_partition", "Partition", "KINDS"]


def partition(world, kind: str, progress=None, **params) -> Partition:
    """Partition a World.

    kind     : "grid" (slabs=..., auto=, cells=), "octree" (depth=1..8, default 5),
               "portal" (depth=1..3, slabs=, cells=, thickness=, samples=) or
               "bsp" (min_leaf=, max_depth=, candidates=, balance=, straddle_weight=, seed=)
               or "kdtree" (split=sah|median, ratio=, bins=, min_leaf=, max_depth=); or the
               CLI's structure text ("octree:4", "grid:8", "bsp:min_leaf=4"), whose
               parameters keyword params override;
               pvs="conservative" (any kind) bakes the view cells' visible sets (pvs.py);
               with pvs_doors=True (an AnimatedWorld), also what each of its doors shut
               hides from each cell (the bake walks again per door a cell's lines cross);
               with fly="on" too, fly-over cells over an outdoor world's street cells
               (pvs_fly.py); budget=F: the sets coarsened (cells merged, sets only grow)
               until the PVS takes at most F x the OBJ's bytes (pvs_coarsen.py); not given
               (None), pvs_coarsen.DEFAULT_BUDGET (0.25); budget="none" keeps the exact sets.
               A conservative bake's params record it: the share, or "none". The bake
               takes the world as given: one with T-junctions (whose creases' cracks join
               its rooms) bakes far tighter sets loaded with repair="tjunctions", which
               `vismobile partition` does itself (--repair auto, docs/partition.md)
    progress : optional callable(done, total) for long builds
    An AnimatedWorld (world/animated.py) gives a dynamic.AnimatedPartition: its static
    triangles partitioned as asked (none: a one-node octree), its moving objects left to the
    Culler's dynamic BVH.
    Raises ValueError on an unknown kind or parameter, or a parameter out of range.
    """
    from . import bsp, grid, kdtree, octree, portal
    from .spec import parse_spec

    if hasattr(world, "static_world"):  # an AnimatedWorld: its static triangles partitioned
        from .dynamic import AnimatedPartition

        static = world.static_world()
        if not static.triangle_count:  # everything moves: an empty static half (one node)
            return AnimatedPartition(world, partition(static, "octree", progress, depth=1))
        params = dict(params)
        if params.pop("pvs_doors", False):  # per view cell, what each shut door hides (pvs.py)
            from ..world.doors import find_doors

            base = world.world
            _, doors = find_doors(base.object_names, base.object_ids, base.corners,
                                  world.moving_object_ids)
            params["pvs_door_boxes"] = doors
        return AnimatedPartition(world, partition(static, kind, progress, **params))

    if isinstance(kind, str) and ":" in kind:
        kind, given = parse_spec(kind)
        params = {**given, **params}

    builders = {"grid": grid.build, "octree": octree.build, "portal": portal.build,
                "bsp": bsp.build, "kdtree": kdtree.build}
    if kind not in builders:
        raise ValueError(f"unknown partition kind {kind!r}; expected one of {', '.join(KINDS)}")
    build = builders[kind]
    params = dict(params)
    pvs_mode = params.pop("pvs", None)
    fly = params.pop("fly", None)
    budget = params.pop("budget", None)
    pvs_doors = params.pop("pvs_door_boxes", None)  # door boxes (D, 2, 3) of an AnimatedWorld
    known = set(build.__code__.co_varnames[1:build.__code__.co_argcount]) - {"progress"}
    unknown = sorted(set(params) - known)
    if unknown:
        raise ValueError(f"unknown parameter(s) for {kind}: {', '.join(unknown)}; "
                         f"expected {', '.join(sorted(known | {'pvs'}))}")
    if str(pvs_mode).startswith("sampled"):
        raise ValueError(f"pvs={pvs_mode} renders item buffers: bake it with "
                         "vismobile.render.pvs_sampled.bake_sampled(partition, N, profile), or "
                         "with the partition command (--structure KIND,pvs=sampled:N)")
    if pvs_mode is not None:
        from .pvs import MODES

        if pvs_mode not in MODES:
            raise ValueError(f"unknown pvs mode {pvs_mode!r}; valid: {', '.join(MODES)}")
    if fly is not None:
        from .pvs import fly_option

        if fly_option(fly) and pvs_mode != "conservative":
            raise ValueError("fly=on bakes fly-over cells into a conservative PVS: give "
                             "pvs=conservative too")
    if budget is not None and pvs_mode != "conservative":
        raise ValueError("budget= coarsens a conservative PVS to a share of the OBJ's "
                         "bytes: give pvs=conservative too")
    if pvs_mode == "conservative":  # the default budget when none is given (pvs_coarsen.py)
        from .pvs_coarsen import budget_param

        budget = budget_param(budget)
    result = build(world, progress=progress, **params)
    if fly is not None and fly_option(fly):
        result.params["fly"] = "on"
    if budget is not None:
        result.params["budget"] = budget
    if pvs_mode is not None:
        from .pvs import bake

        extras, _ = bake(result, pvs_mode, progress=progress, doors=pvs_doors)
        result.extras.update(extras)
        result.params["pvs"] = pvs_mode
    return result


class _CallableModule(types.ModuleType):
    """`vismobile.partition` is both this package and the function: importing the package
    rebinds the attribute on `vismobile`, so the package itself must be callable."""

    def __call__(self, *args, **kwargs):
        return partition(*args, **kwargs)


sys.modules[__name__].__class__ = _CallableModule

"""The anchored walk tried for issue 29 (docs/partition.md, "What each crack adds"): the bake's
union-box flow against one that keeps, per portal crossing, the last crack crossed before it (or
the source's first portal) as an anchor whose separators with the crossing clip what follows.

    .venv/bin/python tools/pvs_anchored.py [--world w1] [--sources 2] [--split] [--crack K]
                                           [--budget 8000000]

Per source (the largest view cells): the share of the world each walk marks, its walks and
seconds. --crack K opens only the K-th crack portal (others closed, as tools/pvs_crack_share.py
does for one crack); --split uses the sealed cells (pvs_refine). Past --budget walks the
anchored walk stops (printed as 'over budget', with what it had marked by then). Measured on W1
(docs/partition.md): one crack open 81.6% -> 13.8%, every crack open 99.3% -> 99.9% in 1,000
times the walks: a diagnostic, not a bake.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
from numba import njit, types
from numba.typed import Dict

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from vismobile.partition import pvs, pvs_cracks  # noqa: E402
from vismobile.partition.pvs_cells import view_grid  # noqa: E402
from vismobile.partition.pvs_kernels import (MAX_PLANES, MAX_VERTS, _crack_candidate,  # noqa: E402
                                             _flat_rectangle, _grown_quad, _mark, box_vertices,
                                             common_face, exit_candidate, grow_box, separators)
from vismobile.scenes import build_world  # noqa: E402


@njit(cache=True)
def _static(portal_quads, p, is_crack, src, grow, slope, tol, cell_bounds, portal_cells, out):
    """out[:n] <- a convex set holding every point where a line from src may cross portal p."""
    if is_crack:
        common = np.empty((2, 3))
        common_face(cell_bounds, portal_cells, p, common)
        planes = np.empty((1, 4))
        n = _crack_candidate(portal_quads, p, src, grow, slope, planes, 0, tol, common[0],
                             common[1], out)
        if n == 0:
            return 0
        lo, hi = out[0].copy(), out[1].copy()
        return _flat_rectangle(lo, hi, out)
    _grown_quad(portal_quads, p, grow, out)
    return 4


@njit(cache=True)
def flow_anchored(source, src_lo, src_hi, cell_bounds, portal_cells, portal_quads,
                  cell_portal_start, cell_portals, cell_ref_start, cell_ref_end, tri_refs,
                  corners, grow, tol, budget, visible, crack, slope, blocked):
    """pvs_kernels.flow_from_cell (no doors) with a state per (anchor, crossing): the anchor is
    the last crack crossed before the crossing, or else the source's first portal (Quake's
    source portal), and the entered cell is clipped by the separators of (anchor's static box,
    crossing box) as well as (source, crossing box). Sound by the same induction (the anchor's
    crossing point lies before the crossing's on the line). Returns walks, or -1 past budget."""
    P2 = 2 * len(portal_cells)
    cap = 1024
    box = np.empty((cap, 2, 3))
    skey = np.empty(cap, dtype=np.int64)
    queued = np.zeros(cap, dtype=np.bool_)
    queue = np.empty(cap, dtype=np.int64)
    slot = Dict.empty(key_type=types.int64, value_type=types.int64)
    used = 0
    head, size = 0, 0
    src = np.empty((8, 3))
    box_vertices(src_lo - grow, src_hi + grow, src)
    entry = np.empty((8, 3))
    anc = np.empty((MAX_VERTS, 3))
    planes = np.empty((MAX_PLANES, 4))
    scratch = np.empty((MAX_VERTS, 3))
    cand = np.empty((MAX_VERTS, 3))
    common = np.empty((2, 3))
    done = np.zeros(len(cell_bounds), dtype=np.bool_)
    for r in range(cell_ref_start[source], cell_ref_end[source]):
        visible[tri_refs[r]] = True
    walks = 0
    current = -1
    while True:
        if current < 0:
            cell, count, came, anchor = source, 0, -1, -1
        else:
            key = skey[current]
            anchor = key // P2 - 1
            d = key % P2
            p = d // 2
            cell = portal_cells[p, 1] if d % 2 == 0 else portal_cells[p, 0]
            came = p
            ne = _flat_rectangle(box[current, 0], box[current, 1], entry)
            count = separators(src, 8, True, entry, ne, planes, 0, ne == 8)
            if anchor >= 0:
                na = _static(portal_quads, anchor, crack[anchor], src, grow, slope, tol,
                             cell_bounds, portal_cells, anc)
                if na > 0:
                    count = separators(anc, na, na == 8, entry, ne, planes, count, ne == 8)
            if not done[cell]:
                done[cell] = _mark(cell, cell_ref_start, cell_ref_end, tri_refs, corners,
                                   planes, count, tol, visible, cell_bounds[cell, 0],
                                   cell_bounds[cell, 1], src)
        for q in range(cell_portal_start[cell], cell_portal_start[cell + 1]):
            p = cell_portals[q]
            if p == came or blocked[p]:
                continue
            forward = portal_cells[p, 0] == cell
            m = portal_cells[p, 1] if forward else portal_cells[p, 0]
            if m == source:
                continue
            n = exit_candidate(portal_quads, p, crack[p], cell_bounds, portal_cells, src, grow,
                               slope, planes, count, tol, common, scratch, cand)
            if n == 0:
                continue
            new_anchor = came if (came >= 0 and (crack[came] or anchor < 0)) else anchor
            key = (new_anchor + 1) * P2 + 2 * p + (0 if forward else 1)
            if key in slot:
                s = slot[key]
            else:
                if used == cap:
                    cap2 = 2 * cap
                    b2 = np.empty((cap2, 2, 3))
                    b2[:cap] = box
                    box = b2
                    k2 = np.empty(cap2, dtype=np.int64)
                    k2[:cap] = skey
                    skey = k2
                    q2 = np.zeros(cap2, dtype=np.bool_)
                    q2[:cap] = queued
                    queued = q2
                    qq = np.empty(cap2, dtype=np.int64)
                    for i in range(size):
                        qq[i] = queue[(head + i) % cap]
                    queue = qq
                    head = 0
                    cap = cap2
                s = used
                used += 1
                slot[key] = s
                skey[s] = key
                for a in range(3):
                    box[s, 0, a] = np.inf
                    box[s, 1, a] = -np.inf
            if grow_box(box, s, cand, n) and not queued[s]:
                queued[s] = True
                queue[(head + size) % cap] = s
                size += 1
        if size == 0:
            return walks
        current = queue[head]
        head = (head + 1) % cap
        size -= 1
        queued[current] = False
        walks += 1
        if walks > budget:
            return -1


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--world", default="w1")
    parser.add_argument("--sources", type=int, default=2, help="largest view cells walked from")
    parser.add_argument("--split", action="store_true", help="the sealed cells (pvs_refine)")
    parser.add_argument("--crack", type=int, default=-1, help="open only this crack portal")
    parser.add_argument("--budget", type=int, default=8_000_000)
    args = parser.parse_args(argv)
    world = build_world(args.world)
    grow = pvs.bake_grow(world)
    g = view_grid(world, grow=grow, split=args.split)
    tol = pvs.TOLERANCE * float(np.ptp(world.extent, axis=0).max()) + grow
    bounds, start = g["cell_bounds"], g["cell_start"]
    quads = np.asarray(g["portal_vertices"], dtype=np.float64).reshape(-1, 4, 3)
    pcells = g["portal_cells"]
    crack = np.zeros(len(pcells), dtype=bool)
    crack[len(pcells) - int(g.get("cracks", 0)):] = True
    blocked = np.zeros(len(pcells), dtype=bool)
    if args.crack >= 0:
        blocked = crack.copy()
        blocked[np.flatnonzero(crack)[args.crack]] = False
    print(f"{args.world}{' sealed' if args.split else ''}: {len(bounds)} cells, "
          f"{int(crack.sum())} cracks, {'crack ' + str(args.crack) if args.crack >= 0 else 'all'}"
          " open", flush=True)
    volume = np.prod(bounds[:, 1] - bounds[:, 0], axis=1)
    for s in np.argsort(-volume)[:args.sources]:
        common = (int(s), bounds[s, 0], bounds[s, 1], bounds, pcells, quads,
                  g["cell_portal_start"], g["cell_portals"], start[:-1], start[1:],
                  g["cell_tris"], world.corners, grow, tol)
        line = f"  source {s} {bounds[s].round(2).tolist()}:"
        for kind in ("union", "anchored"):
            visible = np.zeros(world.triangle_count, dtype=bool)
            began = time.perf_counter()
            if kind == "union":
                walks = pvs_kernels_flow(common, args.budget, visible, crack, blocked)
            else:
                walks = flow_anchored(*common, args.budget, visible, crack,
                                      pvs_cracks.CRACK_SLOPE, blocked)
            line += (f" {kind} {100 * visible.mean():.1f}% "
                     f"({'over budget' if walks < 0 else f'{walks} walks'}, "
                     f"{time.perf_counter() - began:.1f} s);")
        print(line, flush=True)
    return 0


def pvs_kernels_flow(common, budget, visible, crack, blocked):
    """The bake's own walk (pvs_kernels.flow_from_cell) on the same arguments."""
    from vismobile.partition.pvs_kernels import flow_from_cell

    return flow_from_cell(*common, budget, visible, np.zeros(len(common[3]), dtype=bool), crack,
                          pvs_cracks.CRACK_SLOPE, blocked, np.zeros(len(crack), dtype=bool))


if __name__ == "__main__":
    sys.exit(main())

"""Per-sequence portal walks (Teller and Sequin 1991; Quake's vis): a tighter second opinion on
the union-box walk (pvs_kernels.flow_in_slab) of each view cell.

The union walk keeps one box per portal crossing, the union of every sequence's crossing
points, so a line entering a room through one door is clipped as if it might have come through
any. Here sequences from the source are enumerated depth first, each crossing keeping its own
polygon clipped by the separators of (source, previous crossing), (first crossing, previous)
and (the one before, previous), on the view cells joined across wholly open faces (a walk
crosses a room once, not once per order of its grid pieces). A crossing's first `exact`
arrivals are walked so; later ones widen its union state (the boxes of the crossing, of the
crossings before it and of the sequences' first crossings, walked again when they grow), so
the walk ends like the union flow. Both walks keep every line from the source, so what both
mark is a conservative set too (pvs.bake_cells keeps the intersection; W1 repaired, rooms:
20.6-28.1% of the world -> 14.3-15.5%).
"""
from __future__ import annotations

import numpy as np
from numba import njit

from .pvs_cracks import CRACK_SLOPE
from .pvs_kernels import (MAX_PLANES, MAX_VERTS, _flat_rectangle, _mark, box_vertices,
                          exit_candidate, grow_box, separators)

MAX_ROUNDS = 64  # merge_cells: passes, each joining disjoint pairs of cells


def _roots(parent):
    for i in range(len(parent)):
        r = i
        while parent[r] != r:
            r = parent[r]
        parent[i] = r
    return parent


def merge_cells(g, eps) -> dict:
    """The view grid g (pvs_cells.view_grid, with cracks) with cells joined across wholly open
    faces: the same keys, plus 'member' (C,) int64, the joined cell of each of g's cells; eps:
    how far coordinates may differ and still coincide.

    Two cells whose boxes share a whole face with portals (not cracks) covering all of it hold
    nothing between them that blocks a line: their union is one box of free space with the
    same boundary, and a sequence walk crosses it once instead of once per order of its pieces.
    Cracks inside a joined cell go (a line crosses it freely), duplicates of one segment between
    one joined pair are kept once, and a crack's crossing box is cut to the joined cells'
    common face or line, which holds the pieces'."""
    bounds = np.asarray(g["cell_bounds"], dtype=np.float64).copy()
    count = len(bounds)
    pcells = np.asarray(g["portal_cells"], dtype=np.int64).reshape(-1, 2)
    quads = np.asarray(g["portal_vertices"], dtype=np.float64).reshape(-1, 4, 3)
    cracks = int(g.get("cracks", 0))
    plain = len(pcells) - cracks
    span = np.ptp(quads[:plain], axis=1)
    area = np.sort(span, axis=1)[:, 1:].prod(axis=1)  # each portal rectangle's area
    parent = np.arange(count)
    box = bounds.copy()
    for _ in range(MAX_ROUNDS):
        root = _roots(parent)
        a, b = root[pcells[:plain, 0]], root[pcells[:plain, 1]]
        keep = a != b
        if not keep.any():
            break
        lo, hi = np.minimum(a[keep], b[keep]), np.maximum(a[keep], b[keep])
        pairs, inverse = np.unique(np.stack([lo, hi], axis=1), axis=0, return_inverse=True)
        open_area = np.bincount(inverse.ravel(), weights=area[keep], minlength=len(pairs))
        merged = np.zeros(count, dtype=bool)
        joined = False
        for (x, y), opened in zip(pairs, open_area):
            if merged[x] or merged[y]:
                continue
            same = np.abs(box[x] - box[y]) <= eps  # (2, 3)
            flat = [ax for ax in range(3) if not (same[0, ax] and same[1, ax])]
            if len(flat) != 1:
                continue
            ax = flat[0]
            if not (abs(box[x, 1, ax] - box[y, 0, ax]) <= eps
                    or abs(box[y, 1, ax] - box[x, 0, ax]) <= eps):
                continue
            others = [k for k in range(3) if k != ax]
            face = float(np.prod(box[x, 1, others] - box[x, 0, others]))
            if opened < face * (1.0 - 1e-9) - eps:
                continue
            box[x, 0] = np.minimum(box[x, 0], box[y, 0])
            box[x, 1] = np.maximum(box[x, 1], box[y, 1])
            parent[y] = x
            merged[x] = merged[y] = True
            joined = True
        if not joined:
            break
    root = _roots(parent)
    ids, member = np.unique(root, return_inverse=True)
    member = member.ravel().astype(np.int64)
    new_bounds = box[ids]
    # cell -> triangles: the union of the pieces' lists
    start, tris = g["cell_start"], g["cell_tris"]
    sizes = np.diff(start)
    owner = np.repeat(member, sizes)
    pairs = np.unique(np.stack([owner, np.asarray(tris, dtype=np.int64)], axis=1), axis=0)
    cell_start = np.concatenate([[0], np.cumsum(np.bincount(pairs[:, 0],
                                                            minlength=len(ids)))]).astype(np.int64)
    # portals between different joined cells, cracks last
    ends = member[pcells]
    keep = ends[:, 0] != ends[:, 1]
    is_crack = np.arange(len(pcells)) >= plain
    cracked = np.flatnonzero(keep & is_crack)
    if len(cracked):  # pieces of one segment between the same joined pair: once
        key = np.concatenate([np.sort(ends[cracked], axis=1).astype(np.float64),
                              np.round(quads[cracked, :2].reshape(-1, 6) / max(eps, 1e-300))],
                             axis=1)
        cracked = cracked[np.sort(np.unique(key, axis=0, return_index=True)[1])]
    order = np.concatenate([np.flatnonzero(keep & ~is_crack), cracked])
    new_pcells = ends[order]
    verts = quads[order].reshape(-1, 3)
    e = np.concatenate([new_pcells[:, 0], new_pcells[:, 1]])
    pid = np.tile(np.arange(len(new_pcells)), 2)
    srt = np.lexsort((pid, e))
    cps = np.concatenate([[0], np.cumsum(np.bincount(e, minlength=len(ids)))]).astype(np.int64)
    return {**g, "cell_bounds": new_bounds, "cell_start": cell_start,
            "cell_tris": pairs[:, 1].copy(), "portal_cells": new_pcells,
            "portal_start": np.arange(0, 4 * len(new_pcells) + 1, 4), "portal_vertices": verts,
            "cell_portal_start": cps, "cell_portals": pid[srt].astype(np.int64),
            "cracks": len(cracked), "member": member}


@njit(cache=True)
def sequences(source, src_lo, src_hi, cell_bounds, portal_cells, portal_quads,
              cell_portal_start, cell_portals, cell_ref_start, cell_ref_end, tri_refs, corners,
              grow, tol, budget, visible, crack, slope, blocked, exact, max_cracks):
    """Mark visible[t] for the triangles lines from the box [src_lo, src_hi] (grown by grow)
    may reach through portal sequences (module docstring): a directed crossing's first `exact`
    arrivals are walked as sequences, later ones widen its union state; sequences through more
    than max_cracks cracks are dropped (max_cracks < 0: none; a cap is not conservative).
    Returns the crossings walked, or -1 past budget (visible then holds a part)."""
    cells = len(cell_bounds)
    states = 2 * len(portal_cells)
    cap = cells + 2
    src = np.empty((8, 3))
    box_vertices(src_lo - grow, src_hi + grow, src)
    planes = np.empty((cap, MAX_PLANES, 4))
    counts = np.zeros(cap, dtype=np.int64)
    poly = np.empty((cap, MAX_VERTS, 3))
    nverts = np.zeros(cap, dtype=np.int64)
    isbox = np.zeros(cap, dtype=np.bool_)
    first = np.empty((cap, MAX_VERTS, 3))
    nfirst = np.zeros(cap, dtype=np.int64)
    fbox = np.zeros(cap, dtype=np.bool_)
    cracks = np.zeros(cap, dtype=np.int64)
    at = np.empty(cap, dtype=np.int64)
    came = np.empty(cap, dtype=np.int64)
    nxt = np.empty(cap, dtype=np.int64)
    on_path = np.zeros(cells, dtype=np.bool_)
    done = np.zeros(cells, dtype=np.bool_)
    visits = np.zeros(states, dtype=np.int64)
    union = np.empty((3, states, 2, 3))  # widened states: the crossing, before it, first
    for w in range(3):
        for d in range(states):
            for a in range(3):
                union[w, d, 0, a] = np.inf
                union[w, d, 1, a] = -np.inf
    dirty = np.zeros(states, dtype=np.bool_)
    queue = np.empty(max(states, 1), dtype=np.int64)
    head, size = 0, 0
    scratch = np.empty((MAX_VERTS, 3))
    cand = np.empty((MAX_VERTS, 3))
    common = np.empty((2, 3))
    lo = np.empty(3)
    hi = np.empty(3)
    for r in range(cell_ref_start[source], cell_ref_end[source]):
        visible[tri_refs[r]] = True
    done[source] = True
    walks = 0
    root = -1
    while True:
        if root < 0:  # level 0: the source
            at[0], came[0], nxt[0], counts[0], nverts[0], cracks[0] = (
                source, -1, cell_portal_start[source], 0, 0, 0)
            on_path[source] = True
            base = 0
        else:  # a widened crossing: level 0 holds what came before it, level 1 the crossing
            p = root // 2
            m = portal_cells[p, 1] if root % 2 == 0 else portal_cells[p, 0]
            nverts[0] = _flat_rectangle(union[1, root, 0], union[1, root, 1], poly[0])
            isbox[0] = nverts[0] == 8
            nverts[1] = _flat_rectangle(union[0, root, 0], union[0, root, 1], poly[1])
            isbox[1] = nverts[1] == 8
            nfirst[1] = _flat_rectangle(union[2, root, 0], union[2, root, 1], first[1])
            fbox[1] = nfirst[1] == 8
            c = separators(src, 8, True, poly[1], nverts[1], planes[1], 0, isbox[1])
            c = separators(poly[0], nverts[0], isbox[0], poly[1], nverts[1], planes[1], c,
                           isbox[1])
            c = separators(first[1], nfirst[1], fbox[1], poly[1], nverts[1], planes[1], c,
                           isbox[1])
            counts[1] = c
            if not done[m]:
                done[m] = _mark(m, cell_ref_start, cell_ref_end, tri_refs, corners, planes[1],
                                c, tol, visible, cell_bounds[m, 0], cell_bounds[m, 1], src)
            at[1], came[1], nxt[1], cracks[1] = m, p, cell_portal_start[m], 0
            on_path[m] = True
            base = 1
        k = base
        while k >= base:
            cell = at[k]
            if nxt[k] >= cell_portal_start[cell + 1] or k + 1 >= cap:
                on_path[cell] = False
                k -= 1
                continue
            p = cell_portals[nxt[k]]
            nxt[k] += 1
            if p == came[k] or blocked[p]:
                continue
            forward = portal_cells[p, 0] == cell
            m = portal_cells[p, 1] if forward else portal_cells[p, 0]
            if on_path[m] or m == source:
                continue
            if max_cracks >= 0 and cracks[k] + crack[p] > max_cracks:
                continue
            n = exit_candidate(portal_quads, p, crack[p], cell_bounds, portal_cells, src, grow,
                               slope, planes[k], counts[k], tol, common, scratch, cand)
            if n == 0:
                continue
            walks += 1
            if walks > budget:
                return -1
            j = k + 1
            cracks[j] = cracks[k] + crack[p]
            if crack[p]:  # a crossing box: its corners (flat when in the common face)
                for a in range(3):
                    lo[a] = min(cand[0, a], cand[1, a])
                    hi[a] = max(cand[0, a], cand[1, a])
                nverts[j] = _flat_rectangle(lo, hi, poly[j])
                isbox[j] = nverts[j] == 8
            else:
                for i in range(n):
                    poly[j, i] = cand[i]
                nverts[j] = n
                isbox[j] = False
            for i in range(nverts[j] if k == 0 else nfirst[k]):  # the sequence's first
                first[j, i] = poly[j, i] if k == 0 else first[k, i]
            nfirst[j] = nverts[j] if k == 0 else nfirst[k]
            fbox[j] = isbox[j] if k == 0 else fbox[k]
            d = 2 * p + (0 if forward else 1)
            if visits[d] >= exact:  # widen into the crossing's union state
                grew = grow_box(union[0], d, poly[j], nverts[j])
                if k >= 1:
                    grew |= grow_box(union[1], d, poly[k], nverts[k])
                    grew |= grow_box(union[2], d, first[j], nfirst[j])
                else:
                    grew |= grow_box(union[1], d, src, 8)
                    grew |= grow_box(union[2], d, src, 8)
                if grew and not dirty[d]:
                    dirty[d] = True
                    queue[(head + size) % states] = d
                    size += 1
                continue
            visits[d] += 1
            c = separators(src, 8, True, poly[j], nverts[j], planes[j], 0, isbox[j])
            if k >= 1:
                c = separators(poly[k], nverts[k], isbox[k], poly[j], nverts[j], planes[j], c,
                               isbox[j])
                c = separators(first[j], nfirst[j], fbox[j], poly[j], nverts[j], planes[j], c,
                               isbox[j])
            counts[j] = c
            if not done[m]:
                done[m] = _mark(m, cell_ref_start, cell_ref_end, tri_refs, corners, planes[j],
                                c, tol, visible, cell_bounds[m, 0], cell_bounds[m, 1], src)
            at[j], came[j], nxt[j] = m, p, cell_portal_start[m]
            on_path[m] = True
            k = j
        if size == 0:
            return walks
        root = queue[head]
        head = (head + 1) % states
        size -= 1
        dirty[root] = False


def crack_flags(g):
    """(P,) bool: the view grid's crack portals (pvs_cracks appends them last)."""
    crack = np.zeros(len(g["portal_cells"]), dtype=np.bool_)
    crack[len(crack) - int(g.get("cracks", 0)):] = True
    return crack


# Per source: crossings walked as sequences before the walk gives up (the union walk's set
# stands alone then), and arrivals per crossing walked exactly before it widens.
SEQUENCE_BUDGET = 5_000
EXACT = 64


def sequence_grid(g, eps) -> dict:
    """The view grid g without its face-plane portals (pvs_planes appends them last: walked
    only in their slab), its cells joined across wholly open faces (merge_cells)."""
    keep = len(g["portal_cells"]) - int(g.get("planes", 0))
    pcells = np.asarray(g["portal_cells"], dtype=np.int64).reshape(-1, 2)[:keep]
    quads = np.asarray(g["portal_vertices"], dtype=np.float64).reshape(-1, 4, 3)[:keep]
    return merge_cells({**g, "portal_cells": pcells, "portal_vertices": quads, "planes": 0},
                       eps)


def walk_args(world, g, cell, lo, hi, grow, tol) -> tuple:
    """The leading arguments of sequences (and pvs_kernels.flow_from_cell) for the source box
    [lo, hi] in cell of the grid g."""
    start = g["cell_start"]
    return (int(cell), np.asarray(lo, dtype=np.float64), np.asarray(hi, dtype=np.float64),
            g["cell_bounds"], g["portal_cells"],
            np.asarray(g["portal_vertices"], dtype=np.float64).reshape(-1, 4, 3),
            g["cell_portal_start"], g["cell_portals"], start[:-1], start[1:], g["cell_tris"],
            world.corners, grow, tol)


def sequence_set(world, joined, cell, lo, hi, grow, tol):
    """(T,) bool what the sequences from the box [lo, hi] of the view cell `cell` (of the grid
    joined was made from) reach, or None past SEQUENCE_BUDGET crossings."""
    crack = crack_flags(joined)
    visible = np.zeros(world.triangle_count, dtype=np.bool_)
    walks = sequences(*walk_args(world, joined, joined["member"][cell], lo, hi, grow, tol),
                      SEQUENCE_BUDGET, visible, crack, CRACK_SLOPE,
                      np.zeros(len(crack), dtype=np.bool_), EXACT, -1)
    return None if walks < 0 else visible

"""T-junction repair: split triangles so that every vertex lying inside another triangle's edge
becomes a corner of that triangle too (Quake's qbsp, tjunc.c, "fix T-junctions").

Why: two triangles meeting along an edge with the same two corners never leave a gap (GL's
fill rule), but a triangle whose edge runs past another's corner (a wall standing on a floor
with its own vertices, a slab meeting a wall) may leave a pixel open along that crease, and
the item buffer shows what lies behind it (docs/partition.md, the PVS's crack portals). After
the repair such edges are shared corner to corner, with bit-identical floats, so the
rasteriser's coverage of the crease is watertight.

Contract of `repair_tjunctions(world, tolerance=TOLERANCE)`:
- A vertex p is a T-junction of edge (a, b) when p is not at a or b, its projection onto the
  line lies strictly inside the segment by more than `tol`, and its distance from the line is
  at most `tol` = tolerance x the world box's diagonal. Every such (edge, vertex) pair is found
  (a spatial hash over the vertices, a numba walk along each edge: no O(n^2) pass).
- Each triangle with k junctions on its edges is replaced, in place (its pieces take its
  position in the triangle order), by k + 1 triangles over its corners and junctions, the
  fewest that cover it (ear_clip: no new vertex, none degenerate). The junction's corner in a
  piece is the SAME vertex (same floats) as the existing vertex, so the edges along the crease
  are now shared.
- Winding is kept (each piece faces as its parent did); the pieces' areas sum to the parent's
  up to the junctions' distance from the line (0 when they lie exactly on it, as in the thesis
  worlds); object ids follow the parent; per-corner UVs (`world.textures`) are interpolated.
- Vertices within `tol` of an edge's end (near-coincident vertices) are not welded, and
  triangles crossing each other are not split: only T-junctions are repaired.
- Triangle ids change: `Repair.parent[i]` is the original id of new triangle i. A partition
  (.vmp) stores the world it was built from, so a file baked on a repaired world carries the
  repaired geometry and its header says so (partition/store.py: world.repair).
"""
from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

TOLERANCE = 1e-9  # of the world box's diagonal: how far off an edge a junction may lie
MAX_AXIS_CELLS = 1 << 20  # hash cells per axis at most (keys fit in int64)


@dataclass(eq=False)
class Repair:
    """What repair_tjunctions did.

    parent    : (T',) int64 original triangle id of each new triangle (non-decreasing)
    bary      : (T', 3, 3) float64 barycentric coordinates of each new corner in its parent
    junctions : (edge, vertex) pairs found; split : triangles replaced
    """

    parent: np.ndarray
    bary: np.ndarray
    junctions: int
    split: int


@numba.njit(cache=True)
def _cell(p, lo, h, n):
    i = min(max(int((p[0] - lo[0]) / h), 0), n[0] - 1)
    j = min(max(int((p[1] - lo[1]) / h), 0), n[1] - 1)
    k = min(max(int((p[2] - lo[2]) / h), 0), n[2] - 1)
    return i, j, k


@numba.njit(cache=True)
def _walk(points, edges, keys, starts, order, lo, h, n, tol):
    """(edge, vertex, t) junctions: each edge is sampled every h, and the 27 hash cells around
    each sample's cell are searched (a vertex within tol < h/2 of the edge lies within h/2 +
    tol < h of a sample, so in one of them)."""
    size = 1024
    out_e, out_v, out_t = np.empty(size, np.int64), np.empty(size, np.int64), np.empty(size)
    found = 0
    for e in range(len(edges)):
        a, b = edges[e, 0], edges[e, 1]
        d = points[b] - points[a]
        length2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2]
        length = np.sqrt(length2)
        if length <= 2.0 * tol:
            continue
        steps = int(np.ceil(length / h)) + 1
        last = (-1, -1, -1)
        for s in range(steps + 1):
            q = points[a] + d * (s / steps)
            ci, cj, ck = _cell(q, lo, h, n)
            if (ci, cj, ck) == last:
                continue
            last = (ci, cj, ck)
            for di in range(-1, 2):
                for dj in range(-1, 2):
                    for dk in range(-1, 2):
                        i, j, k = ci + di, cj + dj, ck + dk
                        if i < 0 or j < 0 or k < 0 or i >= n[0] or j >= n[1] or k >= n[2]:
                            continue
                        key = (i * n[1] + j) * n[2] + k
                        slot = np.searchsorted(keys, key)
                        if slot >= len(keys) or keys[slot] != key:
                            continue
                        for m in range(starts[slot], starts[slot + 1]):
                            v = order[m]
                            if v == a or v == b:
                                continue
                            w = points[v] - points[a]
                            t = (w[0] * d[0] + w[1] * d[1] + w[2] * d[2]) / length2
                            if t * length <= tol or (1.0 - t) * length <= tol:
                                continue
                            r = w - d * t
                            if r[0] * r[0] + r[1] * r[1] + r[2] * r[2] > tol * tol:
                                continue
                            if found == size:  # grow the output (doubling)
                                size *= 2
                                grown = np.empty(size, np.int64)
                                grown[:found] = out_e
                                out_e = grown
                                grown = np.empty(size, np.int64)
                                grown[:found] = out_v
                                out_v = grown
                                grown_t = np.empty(size)
                                grown_t[:found] = out_t
                                out_t = grown_t
                            out_e[found], out_v[found], out_t[found] = e, v, t
                            found += 1
    return out_e[:found], out_v[:found], out_t[:found]


def ear_clip(lines) -> list:
    """Triangles (index triples into the ring, its winding kept) covering a triangle's ring of
    corners and junctions: lines[i] holds the ids of the triangle's edges ring vertex i lies on
    (two for a corner, one for a junction). len(lines) - 2 triangles (a convex polygon's
    fewest), none with its three vertices on one edge (degenerate): an ear is cut where its
    three vertices share no edge and the ring left is not all on one edge (then the cut
    vertex was the only one off it), so the ring left is a convex polygon again and an ear
    remains until three vertices do."""
    ring, out = list(range(len(lines))), []
    while len(ring) > 3:
        for pos in range(len(ring)):
            u, v, w = ring[pos - 1], ring[pos], ring[(pos + 1) % len(ring)]
            if lines[u] & lines[v] & lines[w]:
                continue
            rest = ring[:pos] + ring[pos + 1:]
            if set.intersection(*(lines[r] for r in rest)):
                continue
            out.append((u, v, w))
            ring = rest
            break
        else:  # cannot happen for a triangle's ring (docstring); fail loudly, never silently
            raise AssertionError(f"no ear in a ring of {len(ring)}")
    out.append(tuple(ring))
    return out


def find_tjunctions(points, edges, tol) -> tuple:
    """(edge (K,) int64, vertex (K,) int64, t (K,) float64) unique pairs: vertex `points[v]`
    lies within tol of edge e = (points[edges[e, 0]], points[edges[e, 1]]), strictly inside
    by more than tol, at parameter t along it. points (P, 3) float64 distinct positions,
    edges (E, 2) int64 indices into points."""
    points = np.ascontiguousarray(points, np.float64)
    edges = np.ascontiguousarray(edges, np.int64)
    empty = np.zeros(0, np.int64)
    if not len(edges) or len(points) < 3:
        return empty, empty, np.zeros(0)
    lo, hi = points.min(axis=0), points.max(axis=0)
    lengths = np.linalg.norm(points[edges[:, 1]] - points[edges[:, 0]], axis=1)
    span = float(np.ptp(points, axis=0).max())
    # cells about an edge long (so an edge meets few), at least 4 tol (so tol < h/2) and at
    # most 2^20 per axis
    h = max(float(np.median(lengths)), 4.0 * tol, span / (MAX_AXIS_CELLS - 1), 1e-300)
    n = np.minimum(np.floor((hi - lo) / h).astype(np.int64) + 1, MAX_AXIS_CELLS)
    cells = np.minimum(np.floor((points - lo) / h).astype(np.int64), n - 1)
    key = (cells[:, 0] * n[1] + cells[:, 1]) * n[2] + cells[:, 2]
    order = np.argsort(key, kind="stable")
    keys, starts = np.unique(key[order], return_index=True)
    starts = np.append(starts, len(order)).astype(np.int64)
    out_e, out_v, out_t = _walk(points, edges, keys, starts, order.astype(np.int64), lo, h, n,
                                float(tol))
    _, first = np.unique(np.stack([out_e, out_v], axis=1), axis=0, return_index=True)
    return out_e[first], out_v[first], out_t[first]


def repair_tjunctions(world, tolerance: float = TOLERANCE) -> tuple:
    """(World, Repair): `world` with every T-junction split (module docstring: the contract).
    A world without any is returned as a new World with the same arrays (parent = identity)."""
    from .world import World

    tri = np.asarray(world.triangles, np.int64)
    vertices = np.asarray(world.vertices, np.float64)
    count = len(tri)
    diagonal = float(np.linalg.norm(np.ptp(world.extent, axis=0)))
    tol = float(tolerance) * diagonal
    # distinct positions; each keeps the first vertex index holding it
    points, first, inv = np.unique(vertices, axis=0, return_index=True, return_inverse=True)
    inv = inv.ravel()
    canon = inv[tri]  # (T, 3) position ids
    directed = np.stack([canon, np.roll(canon, -1, axis=1)], axis=2).reshape(-1, 2)  # (3T, 2)
    undirected = np.sort(directed, axis=1)
    edges, edge_of = np.unique(undirected, axis=0, return_inverse=True)
    edge_of = edge_of.ravel()
    hit_e, hit_v, hit_t = find_tjunctions(points, edges, tol)
    parent = np.arange(count, dtype=np.int64)
    bary = np.broadcast_to(np.eye(3), (count, 3, 3)).copy()
    if not len(hit_e):
        return _rebuilt(world, vertices, tri, parent, bary, 0, 0, World)
    # junctions per directed triangle edge (slot = 3 x triangle + corner), t along its direction
    by_edge = np.argsort(hit_e, kind="stable")
    hit_e, hit_v, hit_t = hit_e[by_edge], hit_v[by_edge], hit_t[by_edge]
    lo_hit = np.searchsorted(hit_e, edge_of, "left")
    hi_hit = np.searchsorted(hit_e, edge_of, "right")
    flipped = directed[:, 0] != edges[edge_of, 0]
    touched = np.unique(np.flatnonzero(hi_hit > lo_hit) // 3)
    pieces, piece_bary, piece_parent = [], [], []
    for t_id in touched:
        corners = tri[t_id]
        ring, ring_bary, lines = [], [], []
        for k in range(3):
            slot = 3 * t_id + k
            ring.append(corners[k])
            ring_bary.append(np.eye(3)[k])
            lines.append({(k + 2) % 3, k})  # a corner lies on the edges before and after it
            lo_k, hi_k = lo_hit[slot], hi_hit[slot]
            ts = hit_t[lo_k:hi_k]
            ts = 1.0 - ts if flipped[slot] else ts
            for j in np.argsort(ts, kind="stable"):
                s = ts[j]
                ring.append(first[hit_v[lo_k + j]])  # the existing vertex: same floats
                b = np.zeros(3)
                b[k], b[(k + 1) % 3] = 1.0 - s, s
                ring_bary.append(b)
                lines.append({k})
        pick = np.asarray(ear_clip(lines), np.int64)
        pieces.append(np.asarray(ring, np.int64)[pick])
        piece_bary.append(np.asarray(ring_bary)[pick])
        piece_parent.append(np.full(len(pick), t_id, np.int64))
    keep = np.ones(count, bool)
    keep[touched] = False
    kept = np.flatnonzero(keep)
    all_parent = np.concatenate([kept] + piece_parent)
    order = np.argsort(all_parent, kind="stable")  # pieces take their parent's place
    new_tri = np.concatenate([tri[kept]] + pieces)[order]
    new_bary = np.concatenate([bary[kept]] + piece_bary)[order]
    return _rebuilt(world, vertices, new_tri, all_parent[order], new_bary, len(hit_e),
                    len(touched), World)


def _rebuilt(world, vertices, triangles, parent, bary, junctions, split, World):
    out = World(vertices, triangles, np.asarray(world.object_ids)[parent],
                list(world.object_names), world.name)
    textures = getattr(world, "textures", None)
    if textures is not None:
        from dataclasses import replace

        uv = np.einsum("tij,tjk->tik", bary, textures.uv[parent].astype(np.float64))
        out.textures = replace(textures, uv=uv.astype(np.float32))
    elif hasattr(world, "textures"):
        out.textures = None
    out.repair = "tjunctions"
    if hasattr(world, "obj_source_bytes"):  # a PVS budget stays a share of the OBJ given
        out.obj_source_bytes = world.obj_source_bytes
    return out, Repair(parent, bary, junctions, split)

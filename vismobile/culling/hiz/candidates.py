"""Occluder candidates of the tiled depth buffer (numba, cached on disk): which triangles to
rasterise. A frustum walk around the eye taking each small or leaf node's list of largest
triangles (gather_candidates, in distance shells: gather_shell_candidates), their ranking by
estimated solid angle and the facing test. Only chooses occluders: never affects safety, except
facing_occluders, which errs toward False (an occluder must certainly face the eye).
"""
from __future__ import annotations

import numpy as np
from numba import njit

from ..facing import frontfacing
from ..occluder_rows import solid_angle


@njit(cache=True, nogil=True, inline="always")
def _take(t, bits):
    """True the first time id t is taken since bits were cleared (sets its bit)."""
    word, bit = t >> 6, np.uint64(1) << np.uint64(t & 63)
    if bits[word] & bit:
        return False
    bits[word] |= bit
    return True


@njit(cache=True, nogil=True, inline="always")
def _box_gap2(lo, hi, node, eye):
    """Squared distance from the eye to the node's box (0 inside) and its squared diagonal."""
    dist2 = 0.0
    diag2 = 0.0
    for a in range(3):
        diag2 += (hi[node, a] - lo[node, a]) ** 2
        gap = max(lo[node, a] - eye[a], eye[a] - hi[node, a], 0.0)
        dist2 += gap * gap
    return dist2, diag2


@njit(cache=True, nogil=True)
def gather_shell_candidates(lo, hi, first_child, child_count, nonempty, roots, planes, tol, eye,
                            detail, lists, history, skip, bits, out, stack, later, reach,
                            limit, growth):
    """gather_candidates from `roots` in shells of distance to the eye: nodes nearer than
    `reach` first; while fewer than `limit` ids came from node lists, the reach grows by
    `growth` and the walk resumes at the nodes it set aside (each node visited once). Only
    chooses candidates (never affects safety). Returns (count in out, nodes visited, the last
    shell's reach, or inf when the whole frustum was walked).
    skip, bits : as in gather_candidates;  stack, later : scratch of >= N + len(roots) entries"""
    for k in range(len(skip)):
        _take(skip[k], bits)
    count = 0
    for k in range(len(history)):
        t = history[k]
        if _take(t, bits):
            out[count] = t
            count += 1
    offered = 0
    visited = 0
    top = 0
    for k in range(len(roots) - 1, -1, -1):
        stack[top] = roots[k]
        top += 1
    while True:
        reach2 = reach * reach
        aside = 0
        while top > 0:
            top -= 1
            node = stack[top]
            if not nonempty[node]:
                continue
            dist2, diag2 = _box_gap2(lo, hi, node, eye)
            if dist2 > reach2:
                later[aside] = node  # beyond this shell: the next one starts here
                aside += 1
                continue
            visited += 1
            outside = False
            for p in range(len(planes)):
                nx, ny, nz, d = planes[p, 0], planes[p, 1], planes[p, 2], planes[p, 3]
                px = hi[node, 0] if nx >= 0 else lo[node, 0]
                py = hi[node, 1] if ny >= 0 else lo[node, 1]
                pz = hi[node, 2] if nz >= 0 else lo[node, 2]
                if nx * px + ny * py + nz * pz + d < -tol:
                    outside = True
                    break
            if outside:
                continue
            n = child_count[node]
            if n == 0 or diag2 < detail * detail * dist2:
                for j in range(lists.shape[1]):
                    t = lists[node, j]
                    if t >= 0 and _take(t, bits):
                        out[count] = t
                        count += 1
                        offered += 1
                continue
            first = first_child[node]
            for c in range(n - 1, -1, -1):
                stack[top] = first + c
                top += 1
        if aside == 0 or offered >= limit:
            break
        for k in range(aside - 1, -1, -1):
            stack[top] = later[k]
            top += 1
        reach *= growth
    for k in range(count):
        bits[out[k] >> 6] = 0
    for k in range(len(skip)):
        bits[skip[k] >> 6] = 0
    return count, visited, (np.inf if aside == 0 else reach)


@njit(cache=True, nogil=True)
def gather_candidates(lo, hi, first_child, child_count, nonempty, roots, planes, tol, eye,
                      detail, lists, history, skip, bits, out, stack):
    """Occluder candidates around the eye: a frustum walk from roots that takes a node's list of
    largest triangles (lists (N, k)) once the node is a leaf or small as seen from the eye
    (diagonal < detail x distance to the box), plus the `history` ids; each id once and none of
    `skip` (bits (T // 64 + 1,) uint64 scratch, zero on entry and on return, so the cost
    follows the candidates, not the world). Returns (count in out, nodes visited): one shell
    of gather_shell_candidates that reaches everything (so nothing is set aside in `later`)."""
    count, visited, _ = gather_shell_candidates(lo, hi, first_child, child_count, nonempty,
                                                roots, planes, tol, eye, detail, lists, history,
                                                skip, bits, out, stack, stack, np.inf, 0, 2.0)
    return count, visited


@njit(cache=True, nogil=True)
def lod_ancestors(nodes, parent, lo, hi, eye, detail, mark, frame, out):
    """Each node replaced by its highest ancestor still small as seen from the eye (diagonal
    < detail x distance to the box), each once; a climb stops where an earlier one passed
    (mark (N,) int64 scratch stamped with frame). Returns the count written to out."""
    count = 0
    for k in range(len(nodes)):
        node = nodes[k]
        if mark[node] == frame:
            continue
        mark[node] = frame
        while True:
            p = parent[node]
            if p >= 0:
                dist2 = 0.0
                diag2 = 0.0
                for a in range(3):
                    diag2 += (hi[p, a] - lo[p, a]) ** 2
                    gap = max(lo[p, a] - eye[a], eye[a] - hi[p, a], 0.0)
                    dist2 += gap * gap
                small = diag2 < detail * detail * dist2
            else:
                small = False
            if not small:
                out[count] = node
                count += 1
                break
            if mark[p] == frame:
                break  # an earlier climb passed here and emitted the same ancestor
            mark[p] = frame
            node = p
    return count


@njit(cache=True, nogil=True)
def score_candidates(ids, normals, v0, centroids, radius, areas, planes, eye, grazing):
    """(n,) float64 estimated solid angle A |n.d| / |d|^3 of each candidate (d eye to centroid);
    0 when it faces away, is seen more edge-on than `grazing` or its bounding sphere is outside
    a frustum plane (only ranks candidates: the facing test that matters comes after)."""
    out = np.zeros(len(ids))
    for k in range(len(ids)):
        t = ids[k]
        out[k] = solid_angle(normals[t, 0], normals[t, 1], normals[t, 2], v0[t, 0], v0[t, 1],
                             v0[t, 2], centroids[t, 0], centroids[t, 1], centroids[t, 2],
                             radius[t], areas[t], planes, eye, grazing)
    return out


@njit(cache=True, nogil=True)
def facing_occluders(ids, vertices, triangles, rows, normals, v0, centroids, eye, delta, gamma8,
                     grazing):
    """(n,) bool: triangle ids[k] certainly faces the eye, also after any move of its corners
    and the eye by up to delta per coordinate (facing.frontfacing: errs toward False by that
    bound), and is seen less edge-on than `grazing`: n.(e - v0) > grazing |d| (d eye to
    centroid, as score_candidates computes them) from its row rows[k] of normals, v0 and
    centroids."""
    out = frontfacing(ids, vertices, triangles, eye, delta, gamma8)
    for k in range(len(ids)):
        if not out[k]:
            continue
        t = rows[k]
        dx, dy, dz = centroids[t, 0] - eye[0], centroids[t, 1] - eye[1], centroids[t, 2] - eye[2]
        towards = (normals[t, 0] * (eye[0] - v0[t, 0]) + normals[t, 1] * (eye[1] - v0[t, 1])
                   + normals[t, 2] * (eye[2] - v0[t, 2]))
        out[k] = towards > grazing * np.sqrt(dx * dx + dy * dy + dz * dz)
    return out

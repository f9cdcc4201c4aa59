"""Crack slivers for `portals` (issue 25): what a sight line may see through the rasteriser's
cracks beyond the cells the portal flood reaches.

Two triangles meeting along an edge with the same two corners leave no gap (the fill rule);
an edge no other triangle shares by both corners (a T-junction, a crease where a wall meets a
ceiling with vertices of its own) may leave pixels open along it (partition/pvs_cracks.py). A
portal cell's face is closed by the walls lying in it, so where a ceiling's face meets a wall's
face along such an edge, a line through the crack leaves the cell where no portal is: W7's
path frame 580 over wall cells sees one pixel of the upper storey's floor (and, with back faces
culled, of a wall of the room above) through the crease of a ceiling and a wall.

Per frame, for each unshared edge lying in a cell the flood reached (its part within the
widest crack of that cell, and within that cell's screen rectangle), every line through the
crack lies in a thin wedge from the eye: the rays within angle delta of the ones through the
edge, sin(delta) = (grow / dmin + CRACK_SLOPE) / (1 - CRACK_SLOPE) (pvs_cracks' contract:
the gap lies within grow + CRACK_SLOPE x distance of the edge; dmin the edge's nearest
distance from the eye). Its sliver is four planes through the eye (two within delta of the
edge's plane, two past its ends by 2 delta, each pushed by the device's move like the cells'
rectangles), the plane beyond the edge, and the near and far planes. The sliver floods the
cells from the crack's across their faces (sliver_cells), keeping per cell the part of the
edge whose rays may reach it, and crossing a face whose walls stop the line (any wall when
back faces are drawn, a wall seen from the front when they are culled: front_closed_faces)
only through its portals; each cell it reaches is walked with the planes of its part of the
edge (its triangles and moving objects there are kept). A line that passes one crack stays
in the wedge of the first crack it passed, whatever it crosses after (more cracks, back faces
with back-face culling, portals), and reaches that first crack through portals only: so the
slivers of the cracks in reached cells hold what the item buffer shows through any number of
cracks. Cost: a walk per crack in view and cell it reaches (W7's path: ~1,000 a frame).

Only unshared edges where a crack can lead out of a cell are kept: those lying in an interior
grid plane (a cell face or edge; a crack inside a cell leads into the same cell, whose portals
the flood already follows) and those of closed outward solids (a solid crossing a cell face
closes its part of the face: a line through a crack in its surface may cross there). Errs
toward keeping: a sliver as wide as the cell's rectangle when the edge spans near 180 degrees
seen from the eye.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from ..partition.pvs_cracks import CRACK_SLOPE, clip_segments, unshared_edge_triangles
from ..partition.solids import outward_solid_faces

# Digits of a coordinate (relative to the world's size) that name a line when merging pieces.
LINE_DIGITS = 9
# Widest half-angle (radians) of an edge seen from the eye plus its margin for a sliver; wider
# ones take their cell's rectangle.
MAX_HALF_ANGLE = 1.4


def crack_pieces(world, cell_bounds, grid_edges, thickness: float, reach: float) -> tuple:
    """The cracks each cell holds: (start (C + 1,) int64 CSR offsets by cell, pieces (K, 2, 3)
    float64 segments), each unshared edge lying in an interior grid plane or on a closed
    outward solid clipped to every cell box grown by `reach` (the widest crack) that it meets;
    collinear axis-aligned pieces of one cell merged into their bounding segment.

    cell_bounds : (C, 2, 3) float64;  grid_edges : three ascending boundary arrays
    thickness   : a point within it of a grid plane lies in that plane
    """
    bounds = np.asarray(cell_bounds, dtype=np.float64)
    count = len(bounds)
    seg, tri = unshared_edge_triangles(world)
    keep = np.zeros(len(seg), dtype=bool)
    for axis in range(3):
        planes = np.asarray(grid_edges[axis], dtype=np.float64)[1:-1]
        if not len(planes):
            continue
        ends = seg[:, :, axis]
        at = np.clip(np.searchsorted(planes, ends[:, 0]), 0, len(planes) - 1)
        best = np.where(np.abs(planes[np.maximum(at - 1, 0)] - ends[:, 0])
                        < np.abs(planes[at] - ends[:, 0]), np.maximum(at - 1, 0), at)
        keep |= (np.abs(ends - planes[best][:, None]) <= thickness).all(axis=1)
    if len(seg):
        keep |= outward_solid_faces(world)[tri]
    seg = seg[keep]
    cells, parts = [], []
    lo_b, hi_b = bounds[:, 0] - reach, bounds[:, 1] + reach
    for s in range(0, len(seg), 1024):
        part = seg[s:s + 1024]
        slo, shi = part.min(axis=1), part.max(axis=1)
        e, c = np.nonzero(((slo[:, None] <= hi_b[None]) & (shi[:, None] >= lo_b[None])).all(-1))
        t0, t1 = clip_segments(part[e], lo_b[c], hi_b[c], 0.0)
        ok = t0 <= t1
        p, d = part[e[ok], 0], part[e[ok], 1] - part[e[ok], 0]
        cells.append(c[ok])
        parts.append(np.stack([p + t0[ok, None] * d, p + t1[ok, None] * d], axis=1))
    cell = np.concatenate(cells) if cells else np.zeros(0, dtype=np.int64)
    piece = np.concatenate(parts) if parts else np.zeros((0, 2, 3))
    cell, piece = _merge_lines(cell, piece, float(np.ptp(world.extent, axis=0).max()))
    order = np.argsort(cell, kind="stable")
    start = np.concatenate([[0], np.cumsum(np.bincount(cell, minlength=count))])
    return start.astype(np.int64), np.ascontiguousarray(piece[order])


def _merge_lines(cell, piece, size):
    """Collinear axis-aligned pieces of one cell as their bounding segment; others as they are."""
    d = np.abs(piece[:, 1] - piece[:, 0])
    moving = d > 1e-12 * max(size, 1e-300)
    aligned = moving.sum(axis=1) == 1
    if not aligned.any():
        return cell, piece
    axis = np.argmax(moving[aligned], axis=1)
    sub = piece[aligned]
    quantum = 10.0 ** -LINE_DIGITS * max(size, 1e-300)
    fixed = np.round(sub[:, 0] / quantum).astype(np.int64)
    fixed[np.arange(len(axis)), axis] = 0
    key = np.column_stack([cell[aligned], axis, fixed])
    _, inverse = np.unique(key, axis=0, return_inverse=True)
    inverse = inverse.ravel()
    groups = inverse.max() + 1
    lo = np.full((groups, 3), np.inf)
    hi = np.full((groups, 3), -np.inf)
    np.minimum.at(lo, inverse, sub.min(axis=1))
    np.maximum.at(hi, inverse, sub.max(axis=1))
    first = np.unique(inverse, return_index=True)[1]
    merged_cell = cell[aligned][first]
    return (np.concatenate([cell[~aligned], merged_cell]),
            np.concatenate([piece[~aligned], np.stack([lo, hi], axis=1)]))


def _clip_to_planes(a, b, planes, offsets):
    """(t0, t1) (K,) of segments a + t (b - a), t in [0, 1], inside planes (K, P, 4) each moved
    out by offsets (K, P); t0 > t1: nothing inside."""
    fa = np.einsum("kpi,ki->kp", planes[:, :, :3], a) + planes[:, :, 3] + offsets
    fb = np.einsum("kpi,ki->kp", planes[:, :, :3], b) + planes[:, :, 3] + offsets
    t0, t1 = np.zeros(len(a)), np.ones(len(a))
    with np.errstate(divide="ignore", invalid="ignore"):
        cross = fa / (fa - fb)
    entering = (fa < 0) & (fb >= 0)
    leaving = (fa >= 0) & (fb < 0)
    t0 = np.maximum(t0, np.where(entering, cross, 0.0).max(axis=1))
    t1 = np.minimum(t1, np.where(leaving, cross, 1.0).min(axis=1))
    outside = ((fa < 0) & (fb < 0)).any(axis=1)
    return t0, np.where(outside, -1.0, t1)


def sliver_planes(eye, a, b, grow: float, push: float, limits, angle: bool = False):
    """(planes (K, 7, 4) float64, wide (K,) bool) of the wedges of lines from the eye through
    the cracks along segments a, b (K, 3) beyond them (module docstring); wide: the edge spans
    too large an angle (its planes are meaningless: callers use the cell's rectangle instead).
    limits : (2, 4) near and far planes;  angle: also return sin(delta) (K,)."""
    count = len(a)
    planes = np.empty((count, 7, 4))
    wide = np.empty(count, dtype=np.bool_)
    sin_delta = np.empty(count)
    _sliver_rows(np.asarray(eye, dtype=np.float64), np.ascontiguousarray(a, dtype=np.float64),
                 np.ascontiguousarray(b, dtype=np.float64), float(grow), float(push),
                 np.ascontiguousarray(limits, dtype=np.float64), planes, wide, sin_delta)
    return (planes, wide, sin_delta) if angle else (planes, wide)


@njit(cache=True, nogil=True, inline="always")
def _dot(u, v):
    return u[0] * v[0] + u[1] * v[1] + u[2] * v[2]


@njit(cache=True, nogil=True, inline="always")
def _cross(u, v):
    return np.array([u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2],
                     u[0] * v[1] - u[1] * v[0]])


@njit(cache=True, nogil=True, inline="always")
def _normalised(v):
    length = np.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
    return v / length if length > 1e-300 else v * 0.0


@njit(cache=True, nogil=True)
def _sliver_rows(eye, a, b, grow, push, limits, planes, wide, sin_out):
    """sliver_planes' rows (its arguments; outputs written in place)."""
    for r in range(len(a)):
        va, vb, d = a[r] - eye, b[r] - eye, b[r] - a[r]
        la, lb = np.sqrt(_dot(va, va)), np.sqrt(_dot(vb, vb))
        ua, ub = _normalised(va), _normalised(vb)
        dd = _dot(d, d)
        t = min(max(-_dot(va, d) / dd, 0.0), 1.0) if dd > 1e-300 else 0.0
        across = va + t * d  # from the eye to the edge's nearest point
        dmin = np.sqrt(_dot(across, across))
        sin_delta = min(1.0, (grow / max(dmin, 1e-300) + CRACK_SLOPE)
                        / (1.0 - CRACK_SLOPE) * 1.05 + 1e-12)
        delta = np.arcsin(sin_delta)
        n = _cross(va, vb)
        if np.sqrt(_dot(n, n)) <= 1e-12 * la * lb:
            # an edge pointing at the eye: any plane through its ray
            helper = np.zeros(3)
            helper[np.argmin(np.abs(ua))] = 1.0
            n = _cross(ua, helper)
        n = _normalised(n)
        cos_ab = min(max(_dot(ua, ub), -1.0), 1.0)
        half = np.arccos(cos_ab) / 2.0
        m = _normalised(ua + ub)
        wide[r] = half + 2.0 * delta > MAX_HALF_ANGLE or sin_delta >= 0.5
        sin_out[r] = sin_delta
        k = np.sin(delta) / max(np.cos(half + delta), 1e-300)
        # in-plane directions from each end toward the other (an edge at the eye: opposite)
        pa, pb = _normalised(_cross(n, ua)), _normalised(_cross(ub, n))
        c2, s2 = np.cos(2.0 * delta), np.sin(2.0 * delta)
        normals = (_normalised(k * m - n), _normalised(k * m + n), pa * c2 + ua * s2,
                   pb * c2 + ub * s2)
        for p in range(4):
            planes[r, p, :3] = normals[p]
            planes[r, p, 3] = -_dot(normals[p], eye) + push
        planes[r, 4:6] = limits
        # beyond the crack: the plane through the edge facing away from the eye, moved toward
        # it by the gap's width (a line through a gap y within w of the edge lies beyond it
        # past y)
        width = grow + CRACK_SLOPE * max(la, lb)
        ud = _normalised(d)
        beyond = across - _dot(across, ud) * ud
        line = np.sqrt(_dot(beyond, beyond))  # the eye's distance to the edge's line
        if line > 2.0 * width:
            beyond = beyond / line
            planes[r, 6, :3] = beyond
            planes[r, 6, 3] = -_dot(beyond, a[r]) + width + push
        else:
            planes[r, 6, :3] = 0.0
            planes[r, 6, 3] = 1.0


def front_closed_faces(world, extras, thickness: float) -> np.ndarray:
    """(C, 3) int8: how the face on each cell's high side along each axis lets a line through.
    0: anywhere (a closed solid near the face: its closed part may be solid space); else the
    face's closed part is walls lying in it (portal.py closes only walls and solids), so a line
    crosses it only through the face's portals when back faces are drawn (they stop it too),
    and with back faces culled when it meets their fronts: 1 every triangle lying in the face
    faces -axis (a line moving toward +axis meets fronts), 2 every one faces +axis, 3 both
    ways (a line may cross anywhere). Errs toward crossing."""
    edges = [np.asarray(extras[f"grid_{a}"], dtype=np.float64) for a in "xyz"]
    shape = tuple(len(e) - 1 for e in edges)
    count = int(np.prod(shape))
    closed = np.zeros((count, 3), dtype=np.int8)
    corners, normals, bounds = world.corners, world.normals, world.bounds
    solid = outward_solid_faces(world) if len(corners) else np.zeros(0, dtype=bool)
    for axis in range(3):
        u_axis, v_axis = (axis + 1) % 3, (axis + 2) % 3
        for b in range(1, shape[axis]):
            plane = edges[axis][b]
            near = (bounds[:, 0, axis] <= plane + thickness) & (bounds[:, 1, axis] >= plane - thickness)
            flat = near & (np.abs(corners[:, :, axis] - plane) <= thickness).all(axis=1)
            facing = np.zeros((shape[u_axis], shape[v_axis], 2), dtype=bool)  # (-axis, +axis)
            spoiled = np.zeros((shape[u_axis], shape[v_axis]), dtype=bool)
            for rows, mark in ((np.flatnonzero(flat), None), (np.flatnonzero(near & solid), 1)):
                if not len(rows):
                    continue
                bu, bv = edges[u_axis], edges[v_axis]
                lo_u, hi_u = bounds[rows, 0, u_axis], bounds[rows, 1, u_axis]
                lo_v, hi_v = bounds[rows, 0, v_axis], bounds[rows, 1, v_axis]
                # the faces each box overlaps with area (grown by thickness for solids)
                grow = thickness if mark else -thickness
                i0 = np.searchsorted(bu, lo_u - grow, side="right") - 1
                i1 = np.searchsorted(bu, hi_u + grow, side="left")
                j0 = np.searchsorted(bv, lo_v - grow, side="right") - 1
                j1 = np.searchsorted(bv, hi_v + grow, side="left")
                for r in range(len(rows)):
                    su = slice(max(i0[r], 0), min(i1[r], shape[u_axis]))
                    sv = slice(max(j0[r], 0), min(j1[r], shape[v_axis]))
                    if mark:
                        spoiled[su, sv] = True
                    else:
                        facing[su, sv, int(normals[rows[r], axis] > 0)] = True
            idx = np.meshgrid(np.arange(shape[u_axis]), np.arange(shape[v_axis]), indexing="ij")
            cell_idx = [None, None, None]
            cell_idx[u_axis], cell_idx[v_axis] = idx
            cell_idx[axis] = np.full(idx[0].shape, b - 1)
            low = np.ravel_multi_index(cell_idx, shape)
            ok = ~spoiled
            code = np.where(facing[..., 0] & ~facing[..., 1], 1,
                            np.where(facing[..., 1] & ~facing[..., 0], 2, 3))
            closed[low, axis] = np.where(ok, code, 0)
    return closed


@njit(cache=True, nogil=True)
def _meets(lo, hi, planes, s, c, tol):
    for p in range(planes.shape[1]):
        v = planes[s, p, 3]
        for i in range(3):
            n = planes[s, p, i]
            v += n * (hi[c, i] if n >= 0.0 else lo[c, i])
        if v < -tol:
            return False
    return True


@njit(cache=True, nogil=True)
def _box_meets(lo, hi, planes, s, tol):
    """The box [lo, hi] (3,) is not wholly more than tol behind a plane of planes[s]."""
    for p in range(planes.shape[1]):
        v = planes[s, p, 3]
        for i in range(3):
            n = planes[s, p, i]
            v += n * (hi[i] if n >= 0.0 else lo[i])
        if v < -tol:
            return False
    return True


@njit(cache=True, nogil=True)
def _polygon_meets(vertices, first, last, planes, s, tol):
    """The polygon vertices[first:last] is not wholly more than tol behind a plane of
    planes[s]."""
    for p in range(planes.shape[1]):
        behind = True
        for k in range(first, last):
            v = planes[s, p, 3]
            for i in range(3):
                v += planes[s, p, i] * vertices[k, i]
            if v >= -tol:
                behind = False
                break
        if behind:
            return False
    return True


@njit(cache=True, nogil=True)
def _narrow(t0, t1, a, b, eye, axis, plane, lo, hi, spread, grow):
    """The part [t0', t1'] of [t0, t1] whose rays from the eye through a + t b (the crack: a
    the edge's end less the eye, b its length) meet the rectangle lo..hi (3,) lying in the
    plane x[axis] = plane, grown by grow plus spread x its farthest corner's distance (the
    rays of the gap within the sliver's angle). Unchanged when the rays meet the plane on
    neither side or near parallel (errs toward the whole interval)."""
    c = plane - eye[axis]
    at0, at1 = a[axis] + t0 * b[axis], a[axis] + t1 * b[axis]
    scale = abs(a[axis]) + abs(b[axis]) + abs(c)
    if not (at0 * c > 0.0 and at1 * c > 0.0) or min(abs(at0), abs(at1)) <= 1e-9 * scale:
        return t0, t1
    sgn = 1.0 if at0 > 0.0 else -1.0
    reach = 0.0
    for k in range(8):
        d2 = 0.0
        for i in range(3):
            d = (hi[i] if k & (1 << i) else lo[i]) - eye[i]
            d2 += d * d
        reach = max(reach, np.sqrt(d2))
    margin = grow + spread * reach
    for u in range(3):
        if u == axis:
            continue
        for bound, side in ((lo[u] - margin - eye[u], 1.0), (hi[u] + margin - eye[u], -1.0)):
            # side * (hit_u - eye_u - bound) >= 0 with hit - eye = c (a + t b) / alpha(t)
            p = side * sgn * (c * a[u] - bound * a[axis])
            q = side * sgn * (c * b[u] - bound * b[axis])
            if q > 0.0:
                t0 = max(t0, -p / q)
            elif q < 0.0:
                t1 = min(t1, -p / q)
            elif p < 0.0:
                return 1.0, 0.0
    return t0, t1


@njit(cache=True, nogil=True)
def sliver_cells(lo, hi, shape, closed, back_culled, planes, ends, spread, eye, grow, tol,
                 stamp, span, out_cell, out_set, out_span, cell_portal_start, cell_portals,
                 portal_cells, portal_start, portal_vertices, pstates):
    """The cells each sliver's lines may cross beyond its crack, flooded like the portals
    (portals.flood_cells) but across cell faces, each cell with the interval of the crack
    (t in [0, 1] along ends[s, 0] -> ends[s, 1]) whose rays may reach it: from the cells the
    sliver meets within the crack's box (ends grown by the gap) with [0, 1], into each
    neighbouring cell the sliver planes meet through their common face, the interval
    narrowed to the rays meeting that face (_narrow, spread[s] the sliver's angular
    reach), or only its portals' rectangles (not a shut door's: pstates 1) where the face's
    walls stop a line crossing it that way (closed, front_closed_faces: any wall when back
    faces are drawn, only fronts when back_culled).
    Writes (cell, sliver, interval) to out_cell, out_set, out_span (>= S C,); stamp (C,)
    int64 and span (C, 2) scratch (stamp < 0 at first). Returns the count."""
    count = 0
    cells = lo.shape[0]
    stack = np.empty(4 * cells + 16, dtype=np.int64)
    face_lo, face_hi = np.empty(3), np.empty(3)
    ny, nz = shape[1], shape[2]
    for s in range(planes.shape[0]):
        top = 0
        a = ends[s, 0] - eye
        b = ends[s, 1] - ends[s, 0]
        for c in range(cells):
            inside = True
            for i in range(3):
                if lo[c, i] > max(ends[s, 0, i], ends[s, 1, i]) + spread[s, 1] + tol or \
                        hi[c, i] < min(ends[s, 0, i], ends[s, 1, i]) - spread[s, 1] - tol:
                    inside = False
            if inside and _meets(lo, hi, planes, s, c, tol):
                stamp[c] = s
                span[c, 0], span[c, 1] = 0.0, 1.0
                out_cell[count] = c
                out_set[count] = s
                count += 1
                stack[top] = c
                top += 1
        while top > 0:
            top -= 1
            c = stack[top]
            ix, iy, iz = c // (ny * nz), (c // nz) % ny, c % nz
            for axis in range(3):
                step = ny * nz if axis == 0 else (nz if axis == 1 else 1)
                at = ix if axis == 0 else (iy if axis == 1 else iz)
                for sign in (-1, 1):
                    if at + sign < 0 or at + sign >= shape[axis]:
                        continue
                    n = c + sign * step
                    # the face between c and n lies on the high side of the lower of them
                    face = closed[c, axis] if sign > 0 else closed[n, axis]
                    if not _meets(lo, hi, planes, s, n, tol):
                        continue
                    plane = hi[c, axis] if sign > 0 else lo[c, axis]
                    r0, r1 = 1.0, 0.0
                    if (face != 0 and not back_culled) or (sign > 0 and face == 1) \
                            or (sign < 0 and face == 2):
                        # through the portals between c and n only
                        for q in range(cell_portal_start[c], cell_portal_start[c + 1]):
                            p = cell_portals[q]
                            if pstates[p] == 1 or (portal_cells[p, 0] != n
                                                   and portal_cells[p, 1] != n) \
                                    or not _polygon_meets(portal_vertices, portal_start[p],
                                                          portal_start[p + 1], planes, s, tol):
                                continue
                            for i in range(3):
                                face_lo[i], face_hi[i] = np.inf, -np.inf
                            for k in range(portal_start[p], portal_start[p + 1]):
                                for i in range(3):
                                    face_lo[i] = min(face_lo[i], portal_vertices[k, i])
                                    face_hi[i] = max(face_hi[i], portal_vertices[k, i])
                            a0, a1 = _narrow(span[c, 0], span[c, 1], a, b, eye, axis, plane,
                                             face_lo, face_hi, spread[s, 0], grow + tol)
                            if a0 <= a1:
                                r0, r1 = min(r0, a0), max(r1, a1)
                    else:
                        for i in range(3):
                            face_lo[i] = max(lo[c, i], lo[n, i])
                            face_hi[i] = min(hi[c, i], hi[n, i])
                        if not _box_meets(face_lo, face_hi, planes, s, tol):
                            continue
                        r0, r1 = _narrow(span[c, 0], span[c, 1], a, b, eye, axis, plane,
                                         face_lo, face_hi, spread[s, 0], grow + tol)
                    if r0 > r1:
                        continue
                    if stamp[n] != s:
                        stamp[n] = s
                        span[n, 0], span[n, 1] = r0, r1
                        out_cell[count] = n
                        out_set[count] = s
                        count += 1
                    elif r0 < span[n, 0] or r1 > span[n, 1]:
                        span[n, 0], span[n, 1] = min(span[n, 0], r0), max(span[n, 1], r1)
                    else:
                        continue
                    if top == len(stack):
                        bigger = np.empty(2 * len(stack), dtype=np.int64)
                        bigger[:top] = stack
                        stack = bigger
                    stack[top] = n
                    top += 1
        # the final intervals of this sliver's cells
        for k in range(count - 1, -1, -1):
            if out_set[k] != s:
                break
            # rounding of the narrowing: 1e-9 of the crack's length either side
            out_span[k, 0] = max(span[out_cell[k], 0] - 1e-9, 0.0)
            out_span[k, 1] = min(span[out_cell[k], 1] + 1e-9, 1.0)
    return count


class CrackSlivers:
    """The cracks of a portal partition's cells (crack_pieces) and each frame's slivers."""

    def __init__(self, world, extras, thickness: float, reach: float):
        bounds = np.asarray(extras["cell_bounds"], dtype=np.float64)
        edges = [np.asarray(extras[f"grid_{a}"], dtype=np.float64) for a in "xyz"]
        self.start, self.pieces = crack_pieces(world, bounds, edges, thickness, reach)
        self.shape = np.array([len(e) - 1 for e in edges], dtype=np.int64)
        self.closed = front_closed_faces(world, extras, thickness)
        self.stamp = np.full(len(bounds), -1, dtype=np.int64)
        self.span = np.zeros((len(bounds), 2))
        self.lo = np.ascontiguousarray(bounds[:, 0])
        self.hi = np.ascontiguousarray(bounds[:, 1])

    def frame(self, camera, ids, cell_planes, grow: float, push: float, tol: float, portals,
              back_culled: bool = True):
        """This frame's slivers from the reached cells ids (V,) and their planes (V, 6, 4)
        (rect_planes): (planes (S, 7, 4), cells (Q,) int64 and their sets (Q,) int64: the cells
        each sliver meets). Cracks seen through no cell's rectangle make none.
        portals : (cell_portal_start, cell_portals, portal_cells, portal_start,
        portal_vertices, prects, pstates) of the
        partition and this frame (portals.portal_rects, shut doors' portals state 1).
        back_culled : the device culls back faces (a line passes walls seen from behind)."""
        start = self.start
        counts = start[ids + 1] - start[ids]
        total = int(counts.sum())
        if not total:
            return np.zeros((0, 6, 4)), np.zeros(0, np.int64), np.zeros(0, np.int64)
        owner = np.repeat(np.arange(len(ids)), counts)
        rows = np.arange(total) - np.repeat(np.cumsum(counts) - counts, counts) \
            + np.repeat(start[ids], counts)
        a, b = self.pieces[rows, 0], self.pieces[rows, 1]
        eye = camera.eye
        far = np.maximum(np.linalg.norm(a - eye, axis=1), np.linalg.norm(b - eye, axis=1))
        # the widest gap along the piece: a gap point y within grow + CRACK_SLOPE |y - eye| of
        # an edge point x no farther than `far` lies within width of it
        width = (grow + CRACK_SLOPE * far) / (1.0 - CRACK_SLOPE)
        offsets = np.repeat(width[:, None], 5, axis=1)  # 4 sides and the near plane
        t0, t1 = _clip_to_planes(a, b, cell_planes[owner, :5], offsets)
        # and to the cell's box grown by the widest gap: the line passes it in the cell
        u0, u1 = clip_segments(np.stack([a, b], axis=1), self.lo[ids[owner]],
                               self.hi[ids[owner]], width)
        t0, t1 = np.maximum(t0, u0), np.minimum(t1, u1)
        seen = t0 <= t1
        a, b, owner, t0, t1 = a[seen], b[seen], owner[seen], t0[seen], t1[seen]
        d = b - a
        a, b = a + t0[:, None] * d, a + t1[:, None] * d
        planes, wide, sin_delta = sliver_planes(eye, a, b, grow, push, cell_planes[0, 4:],
                                                angle=True)
        planes[wide, :6] = cell_planes[owner[wide]]
        planes[wide, 6] = [0.0, 0.0, 0.0, 1.0]
        out_cell = np.empty(len(planes) * len(self.lo), dtype=np.int64)
        out_set = np.empty_like(out_cell)
        out_span = np.empty((len(out_cell), 2))
        far = np.maximum(np.linalg.norm(a - eye, axis=1), np.linalg.norm(b - eye, axis=1))
        spread = np.column_stack([np.tan(np.minimum(np.arcsin(sin_delta), 1.5)),
                                  grow + CRACK_SLOPE * far])  # angle, and the widest gap
        self.stamp[:] = -1
        found = sliver_cells(self.lo, self.hi, self.shape, self.closed, back_culled, planes,
                             np.ascontiguousarray(np.stack([a, b], axis=1)), spread, eye, grow,
                             tol, self.stamp, self.span, out_cell, out_set, out_span, *portals)
        cell, sets, span = out_cell[:found], out_set[:found], out_span[:found]
        # each cell's own sliver: the part of the crack whose rays reach it
        d = b[sets] - a[sets]
        sub, sub_wide = sliver_planes(eye, a[sets] + span[:, :1] * d, a[sets] + span[:, 1:] * d,
                                      grow, push, cell_planes[0, 4:])
        keep = ~(sub_wide | wide[sets])
        sub[~keep] = planes[sets[~keep]]
        return sub, cell, np.arange(found)

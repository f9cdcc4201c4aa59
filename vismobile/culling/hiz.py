"""Compiled kernels of the `occlusion` stage: a conservative hierarchical (tiled) depth buffer in
the style of Masked Occlusion Culling (Hasselgren, Andersson, Akenine-Moller 2016) and the
hierarchical Z-buffer (Greene 1993), numba, cached on disk.

Screen. Camera space: x right, y up, z depth along the view direction (positive in front);
pixel coordinates px = (x / (z tx) + 1) W / 2, py = (y / (z ty) + 1) H / 2, pixel (i, j) is
[i, i+1] x [j, j+1]. The buffer holds per pixel a depth bound D: every point of the pixel is
covered by an occluder whose depth there is <= D (inf: no such bound). Tiles of tw x th pixels
hold the maximum (farthest) D of their pixels and whether any pixel is covered; a tested
rectangle is first compared with its tiles' maxima and only partly covered tiles, whose maximum
fails, are read pixel by pixel (the exact maximum over the rectangle).

Rasteriser (conservative: a pixel counts only when wholly covered; depth is the farthest).
Occluders are world triangles that certainly face the eye, clipped to depth >= clip (the part
nearer than the GPU's near plane is not drawn and hides nothing), grouped by exact plane. Within
a group a pixel lies inside the union of the group's (clipped) triangles when its centre is in
one of them and no piece of the union's boundary meets it. The boundary lies on the edge pieces
without a reverse partner among the group's chosen triangles (partners hold both corners of
the edge: the GPU fills such shared edges without cracks, but not T-junctions, which stay
boundaries) and on the near-plane cuts; a pixel covered by the group gets the group plane's
farthest depth over its four corner rays (1/z is affine over a pixel). Groups are merged by
the pointwise minimum (each bounds the nearest surface there); across a crease (an edge shared
by two groups) a pixel takes the larger of the two groups' depths (rasterise).

Screen border. Occluder points just off screen may shift onto it: a border pixel is covered and
bounded over its square taken GUARD_PX wider off screen, and a tested point within the shift
minus GUARD_PX of the border (the local shift over its tiles, when tile_shifts' table is built)
is never hidden by the buffer: it would need pixels farther off screen.

Tests. A box (8 corners) or triangle (3 corners), each corner moved by up to `move` per
coordinate (device rounding), gives a pixel rectangle grown by SLACK_PX plus `shift` and a
nearest depth zmin; it is hidden when every corner is beyond `near` and the rectangle is off
screen or zmin > D + margin D^2 + recede for the largest D over the rectangle.

With the device's screen (sw x sh, sampled at pixel centres only) the GPU writes a triangle only
at the centres its moved corners' hull covers, and an occluder point at depth z moves on screen
by at most shift(z), so a test reads only the buffer pixels within the local shift of the centres
under the moved rectangle (_centre_rect): the largest shift over the tiles the wide rectangle
meets, from the nearest rasterised occluder depth over each tile (stamp_near, tile_shifts).
No centre under it: nothing is drawn. Each pixel's D bounds its whole square, so reading fewer
pixels stays conservative at that resolution (issue 10: w2x7 sent 249.5 -> 176.8 a frame).
"""
from __future__ import annotations

import numpy as np
from numba import njit

from .facing import frontfacing
from .kernels import _box_planes
from ..partition.occluders import node_candidates  # noqa: F401 (re-exported)
from .occluder_rows import solid_angle

SLACK_PX = 0.01     # pixels: boundaries and rectangles grown by this (GPU snapping is 1/1024)
DEPTH_SLACK = 1e-9  # relative: occluder depths pushed back, tested depths pulled forward
SAMPLE_SLACK_PX = 1.0 / 64  # screen pixels: GPU vertex snapping (8 subpixel bits) is 1/512
# Buffer pixels: a border pixel is covered (and bounded) over its square taken this much wider
# off screen, so a test may read it for occluder points up to this far off the screen.
GUARD_PX = 1.0
# With a screen, node boxes whose rectangle spans up to this many pixels (width + height, buffer
# pixels) are tested at the centres (cull_nodes): on w2x7 wider ones cost more than they cull.
CENTRE_SPAN = 24.0


@njit(cache=True, nogil=True)
def _to_camera(p, eye, rot, out):
    x, y, z = p[0] - eye[0], p[1] - eye[1], p[2] - eye[2]
    for r in range(3):
        out[r] = rot[r, 0] * x + rot[r, 1] * y + rot[r, 2] * z


@njit(cache=True, nogil=True, inline="always")
def _box_to_camera(lo, hi, node, eye, rot, corner, cam):
    """Node's 8 box corners into cam (8, 3) in camera space; returns their nearest depth."""
    zmin = np.inf
    for k in range(8):
        corner[0] = hi[node, 0] if k & 1 else lo[node, 0]
        corner[1] = hi[node, 1] if k & 2 else lo[node, 1]
        corner[2] = hi[node, 2] if k & 4 else lo[node, 2]
        _to_camera(corner, eye, rot, cam[k])
        zmin = min(zmin, cam[k, 2])
    return zmin


@njit(cache=True, nogil=True)
def _clip_triangle(tri, clip, poly, cut):
    """Sutherland-Hodgman clip of a (3, 3) camera-space triangle to z >= clip into poly (4, 3);
    cut[k] is True for points made by the cut. Returns the point count (0 or 3..4)."""
    n = 0
    for k in range(3):
        a, b = tri[k], tri[(k + 1) % 3]
        ina, inb = a[2] >= clip, b[2] >= clip
        if ina:
            poly[n, 0], poly[n, 1], poly[n, 2] = a[0], a[1], a[2]
            cut[n] = False
            n += 1
        if ina != inb:
            t = (clip - a[2]) / (b[2] - a[2])
            poly[n, 0] = a[0] + t * (b[0] - a[0])
            poly[n, 1] = a[1] + t * (b[1] - a[1])
            poly[n, 2] = clip
            cut[n] = True
            n += 1
    return n if n >= 3 else 0


@njit(cache=True, nogil=True, inline="always")
def _clipped_occluder(t, points, tri_points, eye, rot, clip, tri, poly, cut):
    """Occluder t's corners (points[tri_points[t]]) into camera space (tri) and clipped to
    z >= clip into poly (_clip_triangle); returns the point count. The rasteriser and
    stamp_near read the same polygon. Contract: exact (the same arithmetic everywhere)."""
    for c in range(3):
        _to_camera(points[tri_points[t, c]], eye, rot, tri[c])
    return _clip_triangle(tri, clip, poly, cut)


@njit(cache=True, nogil=True)
def _mark_segment(ax, ay, bx, by, width, height, mask, bit):
    """Sets `bit` in mask on every pixel a -> b (pixel coordinates) passes within SLACK_PX of,
    a border pixel's square taken GUARD_PX wider off screen (errs toward more pixels)."""
    steep = abs(by - ay) > abs(bx - ax)
    if steep:
        ax, ay, bx, by = ay, ax, by, bx
        major, minor = height, width
    else:
        major, minor = width, height
    if ax > bx:
        ax, ay, bx, by = bx, by, ax, ay
    if bx + SLACK_PX < -GUARD_PX or ax - SLACK_PX >= major + GUARD_PX:
        return
    c0 = min(max(np.floor(ax - SLACK_PX), 0.0), major - 1.0)
    c1 = min(max(np.floor(bx + SLACK_PX), 0.0), major - 1.0)
    if not c0 <= c1:
        return
    dx = bx - ax
    slope = (by - ay) / dx if dx > 0 else 0.0
    for c in range(int(c0), int(c1) + 1):
        lo = max(c - SLACK_PX - (GUARD_PX if c == 0 else 0.0), ax)
        hi = min(c + 1 + SLACK_PX + (GUARD_PX if c == major - 1 else 0.0), bx)
        ylo = ay + (lo - ax) * slope
        yhi = ay + (hi - ax) * slope
        y0, y1 = min(ylo, yhi) - SLACK_PX, max(ylo, yhi) + SLACK_PX
        if y1 < -GUARD_PX or y0 >= minor + GUARD_PX:
            continue
        r0 = min(max(np.floor(y0), 0.0), minor - 1.0)
        r1 = min(max(np.floor(y1), 0.0), minor - 1.0)
        if not r0 <= r1:
            continue
        for r in range(int(r0), int(r1) + 1):
            if steep:
                mask[c * width + r] |= bit
            else:
                mask[r * width + c] |= bit


@njit(cache=True, nogil=True, inline="always")
def _guarded_low(a, i, n):
    """min of a x over pixel i's span [i, i + 1] of n, GUARD_PX wider at the borders."""
    lo = i - GUARD_PX if i == 0 else float(i)
    hi = i + 1 + GUARD_PX if i == n - 1 else i + 1.0
    return min(a * lo, a * hi)


# Group scratch bits per pixel: centre inside a triangle of the group, met by a boundary piece
# (no reverse partner among this call's triangles) or a near-plane cut, met by a crease piece
# (reverse partner in another group of this call).
_CENTRE, _BOUNDARY, _CREASE = 1, 2, 4


@njit(cache=True, nogil=True)
def rasterise(ids, groups, tri_points, points, normals, offsets, piece_start, piece_end,
              piece_a, piece_b, partner, partner_any, stamp, frame, eye, rot, clip, tx, ty,
              width, height, depth, mask, centre, crease_far):
    """Rasterise occluder triangles `ids` (sorted by group) into depth (H * W,) float64 by the
    pointwise minimum; returns (nearest rasterised depth (inf if none), pixels written).

    Contract: errs toward "not covered" and "farther": a pixel is written only when wholly inside
    the union of the triangles clipped to depth >= clip, with a depth >= every point of that
    union over the pixel (x (1 + DEPTH_SLACK)); a border pixel's square is taken GUARD_PX wider
    off screen. Either one plane group covers it (its centre in a triangle of the group, no
    unpaired piece of the group near it: that plane's farthest depth), or its centre is in some
    triangle and only crease pieces (paired across groups) come near it: the largest of the
    farthest depths of the groups whose pieces come near.
    groups     : (T,) int64 exact-plane label;  tri_points : (T, 3) int64 into points (P, 3)
    normals    : (T, 3), offsets (T,) float64 exact planes n.x = offset; ids must face the eye
    piece_start, piece_end : (T,) int64 ranges of edge pieces a -> b (occlusion.occluder_mesh)
    partner    : (S,) int64 triangle holding the reverse piece in the same group, or -1
    partner_any: (S,) int64 triangle holding the reverse piece in any group, or -1
    stamp      : (T,) int64 scratch; stamp[t] == frame marks this call's triangles (set here)
    eye (3,), rot (3, 3) rows right, up, forward
    mask, centre : (H * W,) uint8 scratch, zero on entry and on return
    crease_far : (H * W,) float64 scratch, 0 on entry and on return (inf: a crease pixel with
                 no bound; -1: met by a boundary)
    """
    for k in range(len(ids)):
        stamp[ids[k]] = frame
    tri = np.empty((3, 3))
    poly = np.empty((4, 3))
    cut = np.empty(4, dtype=np.bool_)
    pa = np.empty(3)
    pb = np.empty(3)
    xs = np.empty(4)
    ys = np.empty(4)
    cn = np.empty(3)
    row_l = np.empty(height)  # per row: leftmost and rightmost crossing of the triangle
    row_r = np.empty(height)
    sx, sy = 0.5 * width / tx, 0.5 * height / ty
    nearest = np.inf
    written = 0
    creases = False
    start = 0
    while start < len(ids):
        g = groups[ids[start]]
        stop = start
        while stop < len(ids) and groups[ids[stop]] == g:
            stop += 1
        # Box of everything the group marks: its projected points, one pixel wider.
        bx0, bx1, by0, by1 = np.inf, -np.inf, np.inf, -np.inf
        # 1. Pixel centres inside any triangle of the group.
        for k in range(start, stop):
            t = ids[k]
            n = _clipped_occluder(t, points, tri_points, eye, rot, clip, tri, poly, cut)
            if n == 0:
                continue
            for c in range(n):
                nearest = min(nearest, poly[c, 2])
                xs[c] = poly[c, 0] / poly[c, 2] * sx + 0.5 * width
                ys[c] = poly[c, 1] / poly[c, 2] * sy + 0.5 * height
                bx0, bx1 = min(bx0, xs[c]), max(bx1, xs[c])
                by0, by1 = min(by0, ys[c]), max(by1, ys[c])
            r0 = max(np.ceil(ys[:n].min() - 0.5), 0.0)
            r1 = min(np.floor(ys[:n].max() - 0.5), height - 1.0)
            if not r0 <= r1:
                continue
            ir0, ir1 = int(r0), int(r1)
            for rr in range(ir0, ir1 + 1):
                row_l[rr] = np.inf
                row_r[rr] = -np.inf
            for c in range(n):  # each edge over the rows it may cross (one row of margin)
                d = c + 1 if c + 1 < n else 0
                ya, yb, xa, xb = ys[c], ys[d], xs[c], xs[d]
                e0 = max(np.ceil(min(ya, yb) - 0.5) - 1.0, r0)
                e1 = min(np.floor(max(ya, yb) - 0.5) + 1.0, r1)
                if not e0 <= e1:
                    continue
                for rr in range(int(e0), int(e1) + 1):
                    yc = rr + 0.5
                    if (ya <= yc <= yb) or (yb <= yc <= ya):
                        if ya == yb:
                            row_l[rr] = min(row_l[rr], xa, xb)
                            row_r[rr] = max(row_r[rr], xa, xb)
                        else:
                            x = xa + (yc - ya) * (xb - xa) / (yb - ya)
                            row_l[rr] = min(row_l[rr], x)
                            row_r[rr] = max(row_r[rr], x)
            for rr in range(ir0, ir1 + 1):
                c0 = max(np.ceil(row_l[rr] - 0.5), 0.0)
                c1 = min(np.floor(row_r[rr] - 0.5), width - 1.0)
                if not c0 <= c1:
                    continue
                # Only centres are marked yet (mask is zero where each group starts): a fill.
                base = rr * width
                mask[base + int(c0):base + int(c1) + 1] = _CENTRE
        gx0 = int(max(np.floor(bx0) - 1.0, 0.0)) if bx0 < np.inf else width
        gx1 = int(min(np.floor(bx1) + 1.0, width - 1.0)) if bx1 > -np.inf else -1
        gy0 = int(max(np.floor(by0) - 1.0, 0.0)) if by0 < np.inf else height
        gy1 = int(min(np.floor(by1) + 1.0, height - 1.0)) if by1 > -np.inf else -1
        if gx1 < gx0 or gy1 < gy0:
            start = stop
            continue
        # 2. Pixels unpaired pieces, crease pieces or near-plane cuts pass near.
        for k in range(start, stop):
            t = ids[k]
            for s in range(piece_start[t], piece_end[t]):
                q = partner[s]
                if q >= 0 and stamp[q] == frame:
                    continue  # the reverse piece's triangle is on the other side
                q = partner_any[s]
                bit = _CREASE if q >= 0 and stamp[q] == frame else _BOUNDARY
                _to_camera(points[piece_a[s]], eye, rot, pa)
                _to_camera(points[piece_b[s]], eye, rot, pb)
                if pa[2] < clip and pb[2] < clip:
                    continue
                if pa[2] < clip or pb[2] < clip:
                    u = (clip - pa[2]) / (pb[2] - pa[2])
                    cx = pa[0] + u * (pb[0] - pa[0])
                    cy = pa[1] + u * (pb[1] - pa[1])
                    if pa[2] < clip:
                        pa[0], pa[1], pa[2] = cx, cy, clip
                    else:
                        pb[0], pb[1], pb[2] = cx, cy, clip
                _mark_segment(pa[0] / pa[2] * sx + 0.5 * width,
                              pa[1] / pa[2] * sy + 0.5 * height,
                              pb[0] / pb[2] * sx + 0.5 * width,
                              pb[1] / pb[2] * sy + 0.5 * height, width, height, mask, bit)
            n = _clipped_occluder(t, points, tri_points, eye, rot, clip, tri, poly, cut)
            for c in range(n):
                d = (c + 1) % n
                if cut[c] and cut[d]:  # the near-plane side of a cut triangle
                    _mark_segment(poly[c, 0] / clip * sx + 0.5 * width,
                                  poly[c, 1] / clip * sy + 0.5 * height,
                                  poly[d, 0] / clip * sx + 0.5 * width,
                                  poly[d, 1] / clip * sy + 0.5 * height, width, height, mask,
                                  _BOUNDARY)
        # 3. The group's plane, farthest over each pixel's corners: covered pixels take it,
        # crease pixels keep the largest over groups; scratch cleared.
        t = ids[start]
        nx, ny, nz = normals[t, 0], normals[t, 1], normals[t, 2]
        for r in range(3):  # camera-space n away from the eye, d > 0: n.x = d on the plane
            cn[r] = -(rot[r, 0] * nx + rot[r, 1] * ny + rot[r, 2] * nz)
        dd = nx * eye[0] + ny * eye[1] + nz * eye[2] - offsets[t]
        a = b = c0_ = low = 0.0
        if dd > 0:
            a = cn[0] * tx * 2.0 / width / dd
            b = cn[1] * ty * 2.0 / height / dd
            c0_ = (cn[2] - cn[0] * tx - cn[1] * ty) / dd
            low = min(a, 0.0) + min(b, 0.0)
        for rr in range(gy0, gy1 + 1):
            for i in range(gx0, gx1 + 1):
                p = rr * width + i
                m = mask[p]
                if m == 0:
                    continue
                mask[p] = 0
                if m & _CENTRE:
                    centre[p] = 1
                if m & _BOUNDARY:
                    crease_far[p] = -1.0
                    continue
                z = np.inf
                if dd > 0:
                    inv = a * i + b * rr + c0_ + low
                    if i == 0 or rr == 0 or i == width - 1 or rr == height - 1:
                        inv = _guarded_low(a, i, width) + _guarded_low(b, rr, height) + c0_
                    if inv > 0:
                        z = (1.0 + DEPTH_SLACK) / inv
                if m & _CREASE:
                    creases = True
                    if crease_far[p] >= 0:
                        crease_far[p] = max(crease_far[p], z)
                elif z < depth[p]:
                    if depth[p] == np.inf:
                        written += 1
                    depth[p] = z
        start = stop
    # 4. Crease pixels: centre in some triangle, met by no boundary, every group near bounded.
    if creases:
        for p in range(width * height):
            f = crease_far[p]
            if f > 0 and f < depth[p] and centre[p]:
                if depth[p] == np.inf:
                    written += 1
                depth[p] = f
    centre[:] = 0
    crease_far[:] = 0.0
    return nearest, written


@njit(cache=True, nogil=True)
def stamp_near(ids, tri_points, points, eye, rot, clip, tx, ty, width, height, tw, th,
               tile_near):
    """Lowers tile_near (tiles of tw x th pixels) to the nearest depth of each triangle `ids`
    clipped to depth >= clip over every tile its projected bounding box meets (clamped to the
    screen: points off it count at the border). Contract: errs toward nearer and more tiles:
    every point of a rasterised occluder lies over a tile whose value is <= its depth."""
    cols = (width + tw - 1) // tw
    tri = np.empty((3, 3))
    poly = np.empty((4, 3))
    cut = np.empty(4, dtype=np.bool_)
    sx, sy = 0.5 * width / tx, 0.5 * height / ty
    for k in range(len(ids)):
        t = ids[k]
        n = _clipped_occluder(t, points, tri_points, eye, rot, clip, tri, poly, cut)
        if n == 0:
            continue
        x0, x1, y0, y1, z = np.inf, -np.inf, np.inf, -np.inf, np.inf
        for c in range(n):
            z = min(z, poly[c, 2])
            x = poly[c, 0] / poly[c, 2] * sx + 0.5 * width
            y = poly[c, 1] / poly[c, 2] * sy + 0.5 * height
            x0, x1, y0, y1 = min(x0, x), max(x1, x), min(y0, y), max(y1, y)
        c0 = int(min(max(np.floor(x0 - SLACK_PX), 0.0), width - 1.0)) // tw
        c1 = int(min(max(np.floor(x1 + SLACK_PX), 0.0), width - 1.0)) // tw
        r0 = int(min(max(np.floor(y0 - SLACK_PX), 0.0), height - 1.0)) // th
        r1 = int(min(max(np.floor(y1 + SLACK_PX), 0.0), height - 1.0)) // th
        for r in range(r0, r1 + 1):
            for c in range(c0, c1 + 1):
                tile_near[r * cols + c] = min(tile_near[r * cols + c], z)


@njit(cache=True, nogil=True, inline="always")
def _levels(n):
    """floor(log2(n)) + 1 for n >= 1: the sparse table's levels over n entries."""
    k = 1
    while (1 << k) <= n:
        k += 1
    return k


def shift_table_size(rows: int, cols: int) -> int:
    """Entries of tile_shifts' table for rows x cols tiles."""
    return _levels(rows) * _levels(cols) * rows * cols


@njit(cache=True, nogil=True)
def tile_shifts(tile_near, reach, tangent, rows, cols, out):
    """out: a 2D sparse table of the largest screen shift (x / z units) of an occluder point
    over each tile of tile_near (rows * cols,): reach / z (1 + tangent near / z + reach / z),
    z = near - reach, for reach = sqrt(3) move (inf when z <= 0, 0 over tiles no occluder
    meets); level (a, b) at ((a * levels(cols) + b) * rows + r) * cols + c holds the maximum
    over rows r..r+2^a-1 and columns c..c+2^b-1 (tile_shift_bound). Exact."""
    la, lb = _levels(rows), _levels(cols)
    for k in range(rows * cols):
        near = tile_near[k]
        s = 0.0
        if near < np.inf:
            z = near - reach
            s = reach / z * (1.0 + (tangent * near / z + reach / z)) if z > 0 else np.inf
        out[k] = s
    for a in range(la):
        for b in range(lb):
            if a == 0 and b == 0:
                continue
            base = (a * lb + b) * rows * cols
            if b > 0:  # from level (a, b - 1): two column halves
                src, step, rstep = (a * lb + b - 1) * rows * cols, 1 << (b - 1), 0
            else:      # from level (a - 1, 0): two row halves
                src, step, rstep = ((a - 1) * lb) * rows * cols, 0, 1 << (a - 1)
            for r in range(rows - (1 << a) + 1):
                for c in range(cols - (1 << b) + 1):
                    k = r * cols + c
                    out[base + k] = max(out[src + k], out[src + k + rstep * cols + step])


@njit(cache=True, nogil=True, inline="always")
def tile_shift_bound(c0, c1, r0, r1, table, rows, cols):
    """The largest per-tile value of tile_shifts' table over tiles c0..c1 x r0..r1 (inclusive,
    non-empty): four look-ups. Exact."""
    a, b = _levels(r1 - r0 + 1) - 1, _levels(c1 - c0 + 1) - 1
    base = (a * _levels(cols) + b) * rows * cols
    r2, c2 = r1 - (1 << a) + 1, c1 - (1 << b) + 1
    return max(max(table[base + r0 * cols + c0], table[base + r0 * cols + c2]),
               max(table[base + r2 * cols + c0], table[base + r2 * cols + c2]))


@njit(cache=True, nogil=True)
def build_tiles(depth, width, height, tw, th, tile_max, tile_any, tile_min):
    """Per tile of tw x th pixels: tile_max the largest depth bound (inf when any pixel is not
    covered), tile_any whether any pixel is covered, tile_min the smallest bound. Exact."""
    cols = (width + tw - 1) // tw
    rows = (height + th - 1) // th
    for ty_ in range(rows):
        for tx_ in range(cols):
            m, low = -np.inf, np.inf
            for r in range(ty_ * th, min((ty_ + 1) * th, height)):
                for c in range(tx_ * tw, min((tx_ + 1) * tw, width)):
                    v = depth[r * width + c]
                    m = max(m, v)
                    low = min(low, v)
            tile_max[ty_ * cols + tx_] = m
            tile_any[ty_ * cols + tx_] = low < np.inf
            tile_min[ty_ * cols + tx_] = low


@njit(cache=True, nogil=True, inline="always")
def _projected_bounds(cam, m, tx, ty, reach):
    """(umin, umax, vmin, vmax, grow): tangent-space bounds of the m camera-space points of cam
    each taken `reach` nearer, and the largest growth of their projection under that move.
    Contract: the arithmetic _rect and _centre_rect test with (shared so they agree bit for bit)."""
    umin, umax, vmin, vmax, grow = np.inf, -np.inf, np.inf, -np.inf, 0.0
    for k in range(m):
        z = cam[k, 2] - reach
        u, v = cam[k, 0] / (z * tx), cam[k, 1] / (z * ty)
        umin, umax, vmin, vmax = min(umin, u), max(umax, u), min(vmin, v), max(vmax, v)
        lateral = max(abs(cam[k, 0]), abs(cam[k, 1])) + reach
        grow = max(grow, reach / z * (1.0 + lateral / z))
    return umin, umax, vmin, vmax, grow


@njit(cache=True, nogil=True)
def _rect(cam, m, near, tx, ty, width, height, move, shift, out):
    """Conservative pixel rectangle of the first m camera-space points of cam (m, 3), each moved
    by up to `move` per coordinate: out (12,) = (x0, x1, y0, y1, zmin, testable, onscreen), errs
    large (grown by SLACK_PX plus `shift` tangents; zmin lowered by sqrt(3) move and
    DEPTH_SLACK); when testable also (umin, umax, vmin, vmax, the move's growth) in tangents.
    onscreen: 0 off screen, 1 on screen, 2 on screen but an occluder point more than GUARD_PX
    off screen may shift over it (or the shift is unbounded): the buffer cannot hide it."""
    reach = np.sqrt(3.0) * move
    zmin = np.inf
    for k in range(m):
        zmin = min(zmin, cam[k, 2] - reach)
    testable = zmin >= near
    out[4], out[5], out[6] = zmin * (1.0 - DEPTH_SLACK), 1.0 if testable else 0.0, 0.0
    if not testable:
        out[0], out[1], out[2], out[3] = 0.0, width - 1.0, 0.0, height - 1.0
        return
    umin, umax, vmin, vmax, grow = _projected_bounds(cam, m, tx, ty, reach)
    out[7], out[8], out[9], out[10], out[11] = umin, umax, vmin, vmax, grow
    grow += shift
    if not grow < np.inf:  # an unbounded shift (nan or inf): the whole screen, not hideable
        out[0], out[1], out[2], out[3], out[6] = 0.0, width - 1.0, 0.0, height - 1.0, 2.0
        return
    gu, gv = grow / tx, grow / ty
    x0 = (umin - gu + 1.0) * 0.5 * width - SLACK_PX
    x1 = (umax + gu + 1.0) * 0.5 * width + SLACK_PX
    y0 = (vmin - gv + 1.0) * 0.5 * height - SLACK_PX
    y1 = (vmax + gv + 1.0) * 0.5 * height + SLACK_PX
    offscreen = x1 < 0 or x0 >= width or y1 < 0 or y0 >= height  # False on nan
    out[6] = 0.0 if offscreen else (2.0 if _reaches_off_screen(out, shift, tx, ty, width,
                                                              height) else 1.0)
    x0, x1, y0, y1 = np.floor(x0), np.floor(x1), np.floor(y0), np.floor(y1)
    out[0], out[1] = min(max(x0, 0.0), width - 1.0), min(max(x1, 0.0), width - 1.0)
    out[2], out[3] = min(max(y0, 0.0), height - 1.0), min(max(y1, 0.0), height - 1.0)


@njit(cache=True, nogil=True, inline="always")
def _reaches_off_screen(out, shift, tx, ty, width, height):
    """True when an occluder point more than GUARD_PX off screen may shift (by up to `shift`
    tangents) onto a point on screen of _rect's moved points (out[7:12]). Errs toward True."""
    sx, sy = shift / tx * 0.5 * width, shift / ty * 0.5 * height
    x0 = (out[7] - out[11] / tx + 1.0) * 0.5 * width - SLACK_PX
    x1 = (out[8] + out[11] / tx + 1.0) * 0.5 * width + SLACK_PX
    y0 = (out[9] - out[11] / ty + 1.0) * 0.5 * height - SLACK_PX
    y1 = (out[10] + out[11] / ty + 1.0) * 0.5 * height + SLACK_PX
    return not (max(x0, 0.0) - sx >= -GUARD_PX and min(x1, width) + sx <= width + GUARD_PX
                and max(y0, 0.0) - sy >= -GUARD_PX and min(y1, height) + sy <= height + GUARD_PX)


@njit(cache=True, nogil=True, inline="always")
def _local_border(r, shift, tx, ty, width, height, tile_shift, cols, tw, th):
    """_rect's onscreen flag r[6] == 2 lowered to 1 when, with the occluders' largest local
    shift over the tiles r[0:4] meets (tile_shifts' table), no occluder point more than
    GUARD_PX off screen reaches the points. Contract: as _reaches_off_screen."""
    local = min(shift, tile_shift_bound(int(r[0]) // tw, int(r[1]) // tw, int(r[2]) // th,
                                        int(r[3]) // th, tile_shift, (height + th - 1) // th,
                                        cols))
    if local < np.inf and not _reaches_off_screen(r, local, tx, ty, width, height):
        r[6] = 1.0


@njit(cache=True, nogil=True)
def _centre_rect(cam, m, tx, ty, width, height, move, rect_move, shift, tile_shift, cols, tw,
                 th, sw, sh, out):
    """Narrows the buffer rectangle out[0:4] (from _rect of the same m testable camera-space
    points of cam (m, 3), with `shift`) to the buffer pixels within the local shift (plus
    SLACK_PX) of a pixel centre of the sw x sh screen that the points, each moved by up to `move`
    per coordinate, may cover: their screen rectangle grown by the move's projection and
    max(SAMPLE_SLACK_PX, SLACK_PX) screen pixels, centres on its boundary included. The local
    shift is the smaller of `shift` and the largest over the tiles out[0:4] meets (tile_shift:
    tile_shifts' table; only looked up when it changes the pixels). Returns False when no centre
    of the screen lies in the grown rectangle (the GPU writes nothing there); out stays as it
    was when the narrowed rectangle would be empty or a bound is nan. rect_move: the move _rect
    took (its projection in out[7:12] is reused when it equals move).
    Contract: errs large: keeps every pixel within the local shift + SLACK_PX of a centre the
    moved points' hull may cover; "no centre" only when none lies within the slack."""
    if move == rect_move:  # _rect's projection (the same arithmetic)
        umin, umax, vmin, vmax, grow = out[7], out[8], out[9], out[10], out[11]
    else:
        reach = np.sqrt(3.0) * move
        umin, umax, vmin, vmax, grow = _projected_bounds(cam, m, tx, ty, reach)
    sx = max(SAMPLE_SLACK_PX, SLACK_PX * sw / width)
    sy = max(SAMPLE_SLACK_PX, SLACK_PX * sh / height)
    i0 = max(np.ceil((umin - grow / tx + 1.0) * 0.5 * sw - sx - 0.5), 0.0)
    i1 = min(np.floor((umax + grow / tx + 1.0) * 0.5 * sw + sx - 0.5), sw - 1.0)
    j0 = max(np.ceil((vmin - grow / ty + 1.0) * 0.5 * sh - sy - 0.5), 0.0)
    j1 = min(np.floor((vmax + grow / ty + 1.0) * 0.5 * sh + sy - 0.5), sh - 1.0)
    if not (i0 <= i1 and j0 <= j1):  # nan: not sure, keep
        return not (i0 > i1 or j0 > j1)
    if not shift >= 0.0:  # nan: keep the rectangle
        return True
    # Buffer coordinates of the outermost centres, SLACK_PX wider.
    cx0, cx1 = (i0 + 0.5) * width / sw - SLACK_PX, (i1 + 0.5) * width / sw + SLACK_PX
    cy0, cy1 = (j0 + 0.5) * height / sh - SLACK_PX, (j1 + 0.5) * height / sh + SLACK_PX
    gx, gy = shift / tx * 0.5 * width, shift / ty * 0.5 * height  # buffer pixels
    if np.floor(cx0 - gx) != np.floor(cx0) or np.floor(cx1 + gx) != np.floor(cx1) \
            or np.floor(cy0 - gy) != np.floor(cy0) or np.floor(cy1 + gy) != np.floor(cy1):
        # The shift matters: the occluders' largest over the tiles the rectangle meets.
        shift = min(shift, tile_shift_bound(int(out[0]) // tw, int(out[1]) // tw,
                                            int(out[2]) // th, int(out[3]) // th, tile_shift,
                                            (height + th - 1) // th, cols))
        if not shift < np.inf:
            return True
        gx, gy = shift / tx * 0.5 * width, shift / ty * 0.5 * height
    x0 = max(np.floor(cx0 - gx), out[0])
    x1 = min(np.floor(cx1 + gx), out[1])
    y0 = max(np.floor(cy0 - gy), out[2])
    y1 = min(np.floor(cy1 + gy), out[3])
    if x0 <= x1 and y0 <= y1:
        out[0], out[1], out[2], out[3] = x0, x1, y0, y1
    return True


@njit(cache=True, nogil=True)
def _behind(x0, x1, y0, y1, zmin, depth, width, tile_max, cols, tw, th, margin, recede):
    """True when zmin > D + margin D^2 + recede for the largest D over the inclusive pixel
    rectangle (tiles first, pixels of partly covered tiles only when their maximum fails)."""
    for ty_ in range(y0 // th, y1 // th + 1):
        for tx_ in range(x0 // tw, x1 // tw + 1):
            d = tile_max[ty_ * cols + tx_]
            if zmin > d + margin * d * d + recede:
                continue
            r0, r1 = max(y0, ty_ * th), min(y1, ty_ * th + th - 1)
            c0, c1 = max(x0, tx_ * tw), min(x1, tx_ * tw + tw - 1)
            if r0 == ty_ * th and r1 == ty_ * th + th - 1 and c0 == tx_ * tw \
                    and c1 == tx_ * tw + tw - 1:
                return False  # the tile lies wholly in the rectangle: its maximum is exact
            for r in range(r0, r1 + 1):
                for c in range(c0, c1 + 1):
                    d = depth[r * width + c]
                    if not zmin > d + margin * d * d + recede:
                        return False
    return True


@njit(cache=True, nogil=True)
def _touches(x0, x1, y0, y1, tile_any, cols, tw, th):
    for ty_ in range(y0 // th, y1 // th + 1):
        for tx_ in range(x0 // tw, x1 // tw + 1):
            if tile_any[ty_ * cols + tx_]:
                return True
    return False


@njit(cache=True, nogil=True, inline="always")
def _box_hidden(cam, near, tx, ty, width, height, move, shift, sample_move, tile_shift, sw, sh,
                depth, tile_max, cols, tw, th, margin, recede, r):
    """The node walks' box test of the 8 camera-space corners cam: True when testable and off
    screen or behind the buffer (_rect into r, _behind), or, with a screen (sw > 0) and a span
    of at most CENTRE_SPAN pixels, when no centre lies under it (_centre_rect narrows r first).
    Contract: errs toward False (kept), as _rect, _centre_rect and _behind do."""
    _rect(cam, 8, near, tx, ty, width, height, move, shift, r)
    if r[5] == 0:
        return False
    if r[6] == 2:
        _local_border(r, shift, tx, ty, width, height, tile_shift, cols, tw, th)
    if sw > 0 and r[6] != 0 and r[1] - r[0] + r[3] - r[2] <= CENTRE_SPAN and not _centre_rect(
            cam, 8, tx, ty, width, height, sample_move, move, shift, tile_shift, cols, tw, th,
            sw, sh, r):
        return True
    return r[6] == 0 or (r[6] == 1 and _behind(int(r[0]), int(r[1]), int(r[2]), int(r[3]),
                                               r[4], depth, width, tile_max, cols, tw, th,
                                               margin, recede))


@njit(cache=True, nogil=True)
def cull_nodes(lo, hi, first_child, child_count, nonempty, parent, roots, draw_mark, up_mark,
               frame, eye, rot, near, tx, ty, width, height, move, shift, margin, recede, depth,
               tile_max, tile_any, tile_shift, tw, th, out, stack, below, nearest_far, from_root,
               sw, sh, sample_move):
    """Occlusion walk over the subtrees of `roots` (the frame's draw nodes), entered from the
    tree's root so that hidden regions go at a coarse level: an ancestor of draw nodes that is
    hidden by the buffer (module docstring) drops every draw node under it; a draw node (or a
    node under one) that is hidden is dropped, a visible inner one whose rectangle meets a
    covered tile (or that is not testable) is replaced by its non-empty children, others are
    kept in out. Errs toward keeping; the result lies within the roots' subtrees.
    lo, hi : (N, 3) box corners;  parent : (N,) int64 (-1 at the root)
    draw_mark, up_mark : (N,) int64 scratch stamped with frame (draw nodes, their ancestors)
    out, stack : (>= N + len(roots),) int64 scratch;  below : same size, uint8 scratch
    nearest_far: a leaf whose nearest corner is not beyond this (the smallest covered depth
                 bound D plus margin D^2 + recede) is kept without its rectangle
    from_root  : enter through the ancestors (else start at the roots themselves)
    sw, sh, sample_move, tile_shift : with a screen (sw > 0) a box whose rectangle spans at
                 most 24 pixels (width + height) is tested over the pixels under its centres
                 only (hidden_triangles; larger ones: the test costs more than it removes)
    returns (kept count, nodes visited, nodes culled)"""
    cols = (width + tw - 1) // tw
    cam = np.empty((8, 3))
    corner = np.empty(3)
    r = np.empty(12)
    for k in range(len(roots)):
        draw_mark[roots[k]] = frame
    top = 0
    for k in range(len(roots)):
        p = parent[roots[k]]
        while p >= 0 and up_mark[p] != frame:
            up_mark[p] = frame
            p = parent[p]
        if parent[roots[k]] < 0 or not from_root:  # entered directly
            stack[top] = roots[k]
            below[top] = 1
            top += 1
    if from_root and len(roots) and up_mark[0] == frame:
        stack[top] = 0
        below[top] = 0
        top += 1
    count = visited = culled = 0
    while top > 0:
        top -= 1
        node, under = stack[top], below[top]
        if not under:
            if draw_mark[node] == frame:
                under = 1
            elif up_mark[node] != frame:
                continue  # outside every draw node's subtree
        if not nonempty[node]:
            continue
        visited += 1
        zmin = _box_to_camera(lo, hi, node, eye, rot, corner, cam)
        n = child_count[node]
        if under and n == 0 and zmin <= nearest_far:
            out[count] = node  # nearer than every covered pixel's bound: cannot be hidden
            count += 1
            continue
        if _box_hidden(cam, near, tx, ty, width, height, move, shift, sample_move, tile_shift,
                       sw, sh, depth, tile_max, cols, tw, th, margin, recede, r):
            culled += 1
            continue
        x0, x1, y0, y1 = int(r[0]), int(r[1]), int(r[2]), int(r[3])
        testable = r[5] > 0
        if not under or (n > 0 and (not testable
                                    or _touches(x0, x1, y0, y1, tile_any, cols, tw, th))):
            first = first_child[node]
            for c in range(n - 1, -1, -1):
                stack[top] = first + c
                below[top] = under
                top += 1
            continue
        out[count] = node
        count += 1
    return count, visited, culled


@njit(cache=True, nogil=True)
def _no_sample(px, py, err, sw, sh, max_samples):
    """True when no pixel centre of an sw x sh screen lies within the triangle (window coords
    px, py (3,)) grown by err pixels; False when unsure or more than max_samples centres lie in
    the grown box. Errs toward False."""
    x0, x1 = min(px[0], px[1], px[2]) - err, max(px[0], px[1], px[2]) + err
    y0, y1 = min(py[0], py[1], py[2]) - err, max(py[0], py[1], py[2]) + err
    big = 4.0 * (sw + sh)
    i0 = int(min(max(np.ceil(min(max(x0, -big), big) - 0.5), 0.0), sw))
    i1 = int(min(max(np.floor(min(max(x1, -big), big) - 0.5), -1.0), sw - 1.0))
    j0 = int(min(max(np.ceil(min(max(y0, -big), big) - 0.5), 0.0), sh))
    j1 = int(min(max(np.floor(min(max(y1, -big), big) - 0.5), -1.0), sh - 1.0))
    nx, ny = max(i1 - i0 + 1, 0), max(j1 - j0 + 1, 0)
    if nx * ny == 0:
        return True
    if nx * ny > max_samples:
        return False
    for j in range(j0, j1 + 1):
        for i in range(i0, i1 + 1):
            sxc, syc = i + 0.5, j + 0.5
            pos = neg = True
            for k in range(3):
                ax, ay = px[k], py[k]
                ex, ey = px[(k + 1) % 3] - ax, py[(k + 1) % 3] - ay
                rx, ry = sxc - ax, syc - ay
                e = ex * ry - ey * rx
                # Moving both ends by <= err changes e by <= err (2 |s - p| + |q - p|) + 2 err^2.
                tol = (err * (2.0 * np.hypot(rx, ry) + np.hypot(ex, ey)) + 2.0 * err * err) \
                    * (1.0 + 1e-9) + 1e-9
                pos = pos and e >= -tol
                neg = neg and e <= tol
            if pos or neg:
                return False
    return True


@njit(cache=True, nogil=True)
def hidden_triangles(ids, vertices, triangles, eye, rot, near, tx, ty, width, height, move,
                     shift, margin, recede, depth, tile_max, tile_shift, tw, th, use_buffer, sw,
                     sh, sample_move, hidden, subpixel, zmin):
    """Per triangle id: hidden[k] when in front of `near` (corners moved) and off screen or behind
    the buffer (use_buffer); else, with a screen (sw > 0), subpixel[k] when it certainly covers
    no pixel centre of that sw x sh screen (corners moved by sample_move, SAMPLE_SLACK_PX);
    zmin[k] its nearest depth (-inf when not testable). With a screen the buffer test reads only
    the pixels within the occluders' local shift of the centres under the triangle's grown
    rectangle (_centre_rect; tile_shift: tile_shifts' table). Contract: errs toward keeping
    (without a screen at any resolution; with one, at that resolution without multisampling)."""
    cols = (width + tw - 1) // tw
    cam = np.empty((3, 3))
    r = np.empty(12)
    px = np.empty(3)
    py = np.empty(3)
    for k in range(len(ids)):
        t = ids[k]
        for c in range(3):
            _to_camera(vertices[triangles[t, c]], eye, rot, cam[c])
        _rect(cam, 3, near, tx, ty, width, height, move, shift, r)
        hidden[k] = False
        subpixel[k] = False
        zmin[k] = r[4] if r[5] > 0 else -np.inf
        if r[5] == 0:
            continue
        if use_buffer and r[6] == 2:
            _local_border(r, shift, tx, ty, width, height, tile_shift, cols, tw, th)
        x0, x1, y0, y1 = int(r[0]), int(r[1]), int(r[2]), int(r[3])
        use = use_buffer and r[6] == 1  # else the buffer cannot hide it
        if r[6] == 0 or (use and _behind(x0, x1, y0, y1, r[4], depth, width, tile_max, cols, tw,
                                         th, margin, recede)):
            hidden[k] = True
            continue
        if use and sw > 0:  # the wide rectangle failed: the pixels under the centres
            if not _centre_rect(cam, 3, tx, ty, width, height, sample_move, move, shift,
                                tile_shift, cols, tw, th, sw, sh, r):
                subpixel[k] = True  # no centre under its rectangle
                continue
            if (int(r[0]) != x0 or int(r[1]) != x1 or int(r[2]) != y0 or int(r[3]) != y1) \
                    and _behind(int(r[0]), int(r[1]), int(r[2]), int(r[3]), r[4], depth, width,
                                tile_max, cols, tw, th, margin, recede):
                hidden[k] = True
                continue
        if sw > 0:
            subpixel[k] = _covers_no_sample(cam, near, tx, ty, sw, sh, sample_move, 16, px, py)


@njit(cache=True, nogil=True)
def _covers_no_sample(cam, near, tx, ty, sw, sh, move, max_samples, px, py):
    """True when the camera-space triangle cam (3, 3), drawn on an sw x sh screen sampled at
    pixel centres (no multisampling), certainly covers no sample: every vertex in front of near
    and no centre within the triangle grown by its vertices' worst screen error (SAMPLE_SLACK_PX
    plus the projection of a move of up to `move` per coordinate). Errs toward False; False too
    when more than max_samples centres lie in the grown box. px, py : (3,) scratch."""
    if min(cam[0, 2], cam[1, 2], cam[2, 2]) < near:
        return False
    ssx, ssy = 0.5 * sw / tx, 0.5 * sh / ty
    err = 0.0
    for c in range(3):
        z = cam[c, 2]
        px[c] = cam[c, 0] / z * ssx + 0.5 * sw
        py[c] = cam[c, 1] / z * ssy + 0.5 * sh
        lateral = max(abs(cam[c, 0]), abs(cam[c, 1]))
        reach = np.sqrt(3.0) * move / z * (1.0 + lateral / z)
        err = max(err, SAMPLE_SLACK_PX + max(ssx, ssy) * reach)
    return _no_sample(px, py, err, sw, sh, max_samples)


@njit(cache=True, nogil=True)
def covers_no_sample(points, near, tx, ty, width, height, move=0.0, max_samples=16):
    """(B,) bool: each camera-space triangle of points (B, 3, 3), drawn on a width x height
    screen sampled at pixel centres, certainly covers no sample (_covers_no_sample); errs
    toward False."""
    out = np.zeros(len(points), dtype=np.bool_)
    px = np.empty(3)
    py = np.empty(3)
    for k in range(len(points)):
        out[k] = _covers_no_sample(points[k], near, tx, ty, width, height, move, max_samples,
                                   px, py)
    return out


def screen_rect(points, near, tx, ty, width, height, move=0.0, shift=0.0) -> tuple:
    """The tests' conservative pixel rectangle of camera-space points (m, 3) (hiz._rect):
    (x0, x1, y0, y1 int inclusive, zmin, testable, onscreen); errs large."""
    out = np.empty(12)
    pts = np.ascontiguousarray(points, dtype=np.float64).reshape(-1, 3)
    _rect(pts, len(pts), near, tx, ty, width, height, float(move), float(shift), out)
    return (int(out[0]), int(out[1]), int(out[2]), int(out[3]), float(out[4]), out[5] > 0,
            out[6] > 0)


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


@njit(cache=True, nogil=True)
def frustum_cull_nodes(lo, hi, first_child, child_count, nonempty, roots, planes, tol, eye, rot,
                       near, tx, ty, width, height, move, shift, margin, recede, depth,
                       tile_max, tile_any, tile_shift, tw, th, out, stack_node, stack_mask,
                       nearest_far, sw, sh, sample_move):
    """One walk from `roots` that rejects a node outside the frustum or hidden by the buffer, so
    neither kind of subtree is entered: the frustum test of kernels.frustum_walk (p/n-vertex
    with plane masks; errs toward keeping by tol: rejects only a box more than tol behind a
    plane) first, then cull_nodes' occlusion test (module docstring; errs toward keeping) on the
    boxes it leaves. A visible inner node is replaced by its non-empty children when it
    straddles a plane, is not testable or its rectangle meets a covered tile; others are kept
    in out. A leaf whose nearest corner is not beyond nearest_far is kept without a rectangle.
    planes : (P, 4) float64 inward (n, d), P <= 62;  stacks : (>= N + len(roots),) int64
    sw, sh, sample_move, tile_shift : the screen's centre test, as in cull_nodes
    returns (kept count, nodes visited, plane tests, outside the frustum, hidden, tested)"""
    cols = (width + tw - 1) // tw
    cam = np.empty((8, 3))
    corner = np.empty(3)
    r = np.empty(12)
    planes_count = planes.shape[0]
    full = (np.int64(1) << planes_count) - 1
    top = 0
    for k in range(len(roots) - 1, -1, -1):
        stack_node[top] = roots[k]
        stack_mask[top] = full
        top += 1
    count = visited = tests = outside_count = hidden = tested = 0
    while top > 0:
        top -= 1
        node, mask = stack_node[top], stack_mask[top]
        if not nonempty[node]:
            continue
        visited += 1
        outside, straddle, planes_tested = _box_planes(
            lo[node, 0], lo[node, 1], lo[node, 2], hi[node, 0], hi[node, 1], hi[node, 2],
            planes, mask, tol)
        tests += planes_tested
        if outside:
            outside_count += 1
            continue
        zmin = _box_to_camera(lo, hi, node, eye, rot, corner, cam)
        n = child_count[node]
        if n == 0 and zmin <= nearest_far:
            out[count] = node  # nearer than every covered pixel's bound: cannot be hidden
            count += 1
            continue
        tested += 1
        if _box_hidden(cam, near, tx, ty, width, height, move, shift, sample_move, tile_shift,
                       sw, sh, depth, tile_max, cols, tw, th, margin, recede, r):
            hidden += 1
            continue
        x0, x1, y0, y1 = int(r[0]), int(r[1]), int(r[2]), int(r[3])
        testable = r[5] > 0
        if n > 0 and (straddle != 0 or not testable
                      or _touches(x0, x1, y0, y1, tile_any, cols, tw, th)):
            first = first_child[node]
            for c in range(n - 1, -1, -1):  # first child on top: depth-first in stored order
                stack_node[top] = first + c
                stack_mask[top] = straddle
                top += 1
            continue
        out[count] = node
        count += 1
    return count, visited, tests, outside_count, hidden, tested

"""The `occlusion` stage's conservative rasteriser (numba, cached on disk): occluder triangles
into the tiled depth buffer's pixels (package docstring: the buffer and its screen).

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
"""
from __future__ import annotations

import numpy as np
from numba import njit

from .edges import add_record, capacity, set_record

SLACK_PX = 0.01     # pixels: boundaries and rectangles grown by this (GPU snapping is 1/1024)
DEPTH_SLACK = 1e-9  # relative: occluder depths pushed back, tested depths pulled forward
# Buffer pixels: a border pixel is covered (and bounded) over its square taken this much wider
# off screen, so a test may read it for occluder points up to this far off the screen.
GUARD_PX = 1.0
# Pixels: with the screen's centres only sampled (occlusion `samples`), a pixel's bound holds over
# this half-size square about its centre (the occluders' shift is kept within it).
SAMPLE_HALF = 0.25


@njit(cache=True, nogil=True)
def _to_camera(p, eye, rot, out):
    x, y, z = p[0] - eye[0], p[1] - eye[1], p[2] - eye[2]
    for r in range(3):
        out[r] = rot[r, 0] * x + rot[r, 1] * y + rot[r, 2] * z


@njit(cache=True, nogil=True)
def _row_to_camera(points, i, eye, rot, out, row):
    """_to_camera of points[i] into out[row] (the same arithmetic). Takes no row views: a view
    costs numba two reference-count updates (atomic), more than the arithmetic here."""
    x, y, z = points[i, 0] - eye[0], points[i, 1] - eye[1], points[i, 2] - eye[2]
    for r in range(3):
        out[row, r] = rot[r, 0] * x + rot[r, 1] * y + rot[r, 2] * z


@njit(cache=True, nogil=True, inline="always")
def _box_to_camera(lo, hi, node, eye, rot, cam):
    """Node's 8 box corners into cam (8, 3) in camera space (corner k takes hi on axis a when
    bit a of k is set); returns their nearest depth. Each row's products are formed once per
    box side: the same products summed in the same order as _to_camera of each corner (bit for
    bit), a quarter of the multiplications (the node walks' largest cost on W2)."""
    xl, xh = lo[node, 0] - eye[0], hi[node, 0] - eye[0]
    yl, yh = lo[node, 1] - eye[1], hi[node, 1] - eye[1]
    zl, zh = lo[node, 2] - eye[2], hi[node, 2] - eye[2]
    for r in range(3):
        ax0, ax1 = rot[r, 0] * xl, rot[r, 0] * xh
        ay0, ay1 = rot[r, 1] * yl, rot[r, 1] * yh
        az0, az1 = rot[r, 2] * zl, rot[r, 2] * zh
        cam[0, r] = ax0 + ay0 + az0
        cam[1, r] = ax1 + ay0 + az0
        cam[2, r] = ax0 + ay1 + az0
        cam[3, r] = ax1 + ay1 + az0
        cam[4, r] = ax0 + ay0 + az1
        cam[5, r] = ax1 + ay0 + az1
        cam[6, r] = ax0 + ay1 + az1
        cam[7, r] = ax1 + ay1 + az1
    zmin = np.inf
    for k in range(8):
        zmin = min(zmin, cam[k, 2])
    return zmin


@njit(cache=True, nogil=True)
def _clip_triangle(tri, clip, poly, cut):
    """Sutherland-Hodgman clip of a (3, 3) camera-space triangle to z >= clip into poly (4, 3);
    cut[k] is True for points made by the cut. Returns the point count (0 or 3..4)."""
    n = 0
    for k in range(3):
        a, b = k, (k + 1) % 3  # rows of tri (no row views: _row_to_camera)
        ina, inb = tri[a, 2] >= clip, tri[b, 2] >= clip
        if ina:
            poly[n, 0], poly[n, 1], poly[n, 2] = tri[a, 0], tri[a, 1], tri[a, 2]
            cut[n] = False
            n += 1
        if ina != inb:
            t = (clip - tri[a, 2]) / (tri[b, 2] - tri[a, 2])
            poly[n, 0] = tri[a, 0] + t * (tri[b, 0] - tri[a, 0])
            poly[n, 1] = tri[a, 1] + t * (tri[b, 1] - tri[a, 1])
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
        _row_to_camera(points, tri_points[t, c], eye, rot, tri, c)
    return _clip_triangle(tri, clip, poly, cut)


@njit(cache=True, nogil=True)
def _mark_segment(ax, ay, bx, by, width, height, mask, bit, row_lo, row_hi, half, piece_of,
                  line, marked):
    """Sets `bit` in mask on every pixel a -> b (pixel coordinates) passes within SLACK_PX of
    the pixel's square of half-size `half` about its centre (0.5: the whole pixel), a border
    pixel's square taken GUARD_PX wider off screen (errs toward more pixels), and widens each
    marked row's span [row_lo, row_hi] (height,) int64 to hold the pixels marked. With bit
    _BOUNDARY and piece_of (H * W,) int32 (or an empty one: not kept): a pixel's first
    boundary mark of the group sets piece_of to `line` (the segment's edge record, or -1),
    any other mark to -1 (hiz.edges: only a pixel one piece meets keeps a record). marked
    (H * W + 1,) int32 lists the group's pixels with a piece mark: marked[0] of them after it,
    each once (its group's first piece mark appends it)."""
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
    whole = half >= 0.5
    if whole:
        c0 = min(max(np.floor(ax - SLACK_PX), 0.0), major - 1.0)
        c1 = min(max(np.floor(bx + SLACK_PX), 0.0), major - 1.0)
    else:  # the columns whose squares the segment's span may meet
        c0 = min(max(np.ceil(ax - SLACK_PX - 0.5 - half), 0.0), major - 1.0)
        c1 = min(max(np.floor(bx + SLACK_PX - 0.5 + half), 0.0), major - 1.0)
    if not c0 <= c1:
        return
    dx = bx - ax
    slope = (by - ay) / dx if dx > 0 else 0.0
    keep = bit == _BOUNDARY and len(piece_of) > 0
    for c in range(int(c0), int(c1) + 1):
        # c + 0.5 -+ 0.5 is c and c + 1 exactly: the whole-pixel bounds are unchanged
        lo = max(c + 0.5 - half - SLACK_PX - (GUARD_PX if c == 0 else 0.0), ax)
        hi = min(c + 0.5 + half + SLACK_PX + (GUARD_PX if c == major - 1 else 0.0), bx)
        if not whole and not lo <= hi:
            continue
        ylo = ay + (lo - ax) * slope
        yhi = ay + (hi - ax) * slope
        y0, y1 = min(ylo, yhi) - SLACK_PX, max(ylo, yhi) + SLACK_PX
        if y1 < -GUARD_PX or y0 >= minor + GUARD_PX:
            continue
        if whole:
            r0 = min(max(np.floor(y0), 0.0), minor - 1.0)
            r1 = min(max(np.floor(y1), 0.0), minor - 1.0)
        else:  # rows whose squares [r + 0.5 - half, r + 0.5 + half] meet [y0, y1]; clamping
            # to the border rows keeps their guard band
            r0 = min(max(np.ceil(y0 - 0.5 - half), 0.0), minor - 1.0)
            r1 = min(max(np.floor(y1 - 0.5 + half), 0.0), minor - 1.0)
        if not r0 <= r1:
            continue
        if steep:  # row c, columns r0..r1
            row_lo[c] = min(row_lo[c], int(r0))
            row_hi[c] = max(row_hi[c], int(r1))
        for r in range(int(r0), int(r1) + 1):
            q = c * width + r if steep else r * width + c
            if not steep:  # column c, rows r0..r1
                row_lo[r] = min(row_lo[r], c)
                row_hi[r] = max(row_hi[r], c)
            # the piece count (hiz.edges: a group's first boundary piece sets it, another
            # clears it), the list of pixels pieces meet, the bit (written out here: an
            # inlined helper taking the arrays costs numba reference counts per pixel)
            m = mask[q]
            if keep:
                if not m & _BOUNDARY:
                    piece_of[q] = line
                elif piece_of[q] != line:
                    piece_of[q] = -1
            if m < _BOUNDARY:
                marked[0] += 1
                marked[marked[0]] = q
            mask[q] = m | bit


@njit(cache=True, nogil=True, inline="always")
def _guarded_low(a, i, n, half=0.5):
    """min of a x over pixel i's span [i + 0.5 - half, i + 0.5 + half] of n (half 0.5: [i, i +
    1]), GUARD_PX wider at the borders."""
    lo = i + 0.5 - half - (GUARD_PX if i == 0 else 0.0)
    hi = i + 0.5 + half + (GUARD_PX if i == n - 1 else 0.0)
    return min(a * lo, a * hi)


# Group scratch bits per pixel: centre inside a triangle of the group, met by a boundary piece
# (no reverse partner among this call's triangles) or a near-plane cut, met by a crease piece
# (reverse partner in another group of this call).
_CENTRE, _BOUNDARY, _CREASE = 1, 2, 4


@njit(cache=True, nogil=True, inline="always")
def _far(a, b, c0_, low, i, rr, width, height, half, dd, num):
    """Step 3's bound of pixel (i, rr) from the group plane's 1 / z = a x + b y + c0_ (low: the
    least of a x + b y over a pixel's square; at the border the guarded square): num / the
    least 1 / z, inf when the plane is not in front (dd <= 0) or that is not positive."""
    if not dd > 0:
        return np.inf
    inv = a * i + b * rr + c0_ + low
    if i == 0 or rr == 0 or i == width - 1 or rr == height - 1:
        inv = _guarded_low(a, i, width, half) + _guarded_low(b, rr, height, half) + c0_
    return num / inv if inv > 0 else np.inf


@njit(cache=True, nogil=True, error_model="numpy")
def _edge_rows(row_l, row_r, e0, e1, xa, ya, xb, yb):
    """Step 1: widens [row_l, row_r] of rows e0..e1 to the crossing of the edge a -> b (ya !=
    yb, buffer pixels) with each row's centre line it crosses. Branch-free (LLVM vectorises
    it); the crossing's arithmetic is the one-by-one loop's (the same bits)."""
    dx, dy = xb - xa, yb - ya
    y0, y1 = min(ya, yb), max(ya, yb)
    ls, rs = row_l[e0:e1 + 1], row_r[e0:e1 + 1]
    for k in range(len(ls)):
        yc = (e0 + k) + 0.5
        x = xa + (yc - ya) * dx / dy
        inside = (y0 <= yc) & (yc <= y1)
        ls[k] = min(ls[k], x) if inside else ls[k]
        rs[k] = max(rs[k], x) if inside else rs[k]


@njit(cache=True, nogil=True, inline="always")
def _covered_pixel(mask, depth, centre, p, a, b, c0_, low, i, rr, width, height, half, dd, num):
    """_covered_run for the one pixel p = (i, rr) (at the border too); returns 1 when written
    for the first time."""
    if mask[p] != _CENTRE:
        return 0  # nothing here, or a pixel a piece meets (step 3 took it from the list)
    centre[p] = 1
    z = _far(a, b, c0_, low, i, rr, width, height, half, dd, num)
    if not z < depth[p]:
        return 0
    first = depth[p] == np.inf
    depth[p] = z
    return 1 if first else 0


@njit(cache=True, nogil=True, error_model="numpy")
def _covered_run(mask, depth, centre, base, j0, j1, a, brow, c0_, low, num):
    """Step 3 over columns [j0, j1) of the row at base (no border pixel; brow = b row): a
    pixel only the group's centres mark (mask == _CENTRE) lowers depth to the plane's bound
    (_far's arithmetic, the same bits), every centre mark sets centre. Branch-free, so LLVM
    vectorises it (numpy's error model: no check of the division). Returns the pixels
    written for the first time."""
    ms = mask[base + j0:base + j1]
    ds = depth[base + j0:base + j1]
    cs = centre[base + j0:base + j1]
    written = 0
    for k in range(len(ds)):
        m = ms[k]
        inv = a * (j0 + k) + brow + c0_ + low
        z = num / inv if inv > 0 else np.inf
        d = ds[k]
        better = (m == _CENTRE) & (z < d)
        written += better & (d == np.inf)
        ds[k] = z if better else d
        cs[k] |= m & _CENTRE
    return written


@njit(cache=True, nogil=True)
def rasterise(ids, groups, tri_points, points, normals, offsets, piece_start, piece_end,
              piece_a, piece_b, partner, partner_any, stamp, frame, eye, rot, clip, tx, ty,
              width, height, depth, mask, centre, crease_far, slack=DEPTH_SLACK, half=0.5):
    """Rasterise occluder triangles `ids` (sorted by group) into depth (H * W,) float64 by the
    pointwise minimum; returns (nearest rasterised depth (inf if none), pixels written).
    A longer depth (hiz.edges.buffer_length) also gets edge records: pixels one boundary piece
    of a group meets keep the group's plane and the piece's line (the part of the square on
    the group's side is covered; hiz.edges), read by the triangle test at the screen's centres.
    half: a pixel's square is [i + 0.5 - half, i + 0.5 + half] about its centre (0.5: the
    whole pixel; less: a sample's neighbourhood, SAMPLE_HALF) for coverage and depth alike.

    Contract: errs toward "not covered" and "farther": a pixel is written only when wholly inside
    the union of the triangles clipped to depth >= clip, with a depth >= every point of that
    union over the pixel (x (1 + slack), slack >= DEPTH_SLACK: the device's depth-order error,
    occlusion.depth_order); a border pixel's square is taken GUARD_PX wider off screen. Either
    one plane group covers it (its centre in a triangle of the group, no unpaired piece of the
    group near it: that plane's farthest depth), or its centre is in some triangle and only
    crease pieces (paired across groups) come near it: the largest of the farthest depths of
    the groups whose pieces come near.
    groups     : (T,) int64 exact-plane label;  tri_points : (T, 3) int64 into points (P, 3)
    normals    : (T, 3), offsets (T,) float64 exact planes n.x = offset; ids must face the eye
    piece_start, piece_end : (T,) int64 ranges of edge pieces a -> b (occluder_mesh.occluder_mesh)
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
    ends = np.empty((2, 3))  # a piece's ends in camera space
    xs = np.empty(4)
    ys = np.empty(4)
    cn = np.empty(3)
    row_l = np.empty(height)  # per row: leftmost and rightmost crossing of the triangle
    row_r = np.empty(height)
    # Per row: the columns this group marked (step 3 visits only them), reset as it goes.
    span_lo = np.full(height, width, dtype=np.int64)
    span_hi = np.full(height, -1, dtype=np.int64)
    # Per triangle of ids: 1 when step 1 cut it at the near plane (step 2 marks the cut side).
    was_cut = np.zeros(len(ids), dtype=np.uint8)
    # Per triangle of ids: the sign of its projected area when uncut (its inside lies to that
    # side of each edge in corner order), else 0 (no edge records).
    orient = np.zeros(len(ids))
    # Per triangle of ids: its corners' buffer pixels when uncut (flat 1; step 2 reads them).
    flat = np.zeros(len(ids), dtype=np.uint8)
    proj = np.empty((len(ids), 3, 2))
    sx, sy = 0.5 * width / tx, 0.5 * height / ty
    nearest = np.inf
    written = 0
    creases = False
    # Edge records (hiz.edges) when depth has room for them; piece_of: per pixel the one
    # boundary piece of the group that meets it (its record), -1 for none or several.
    pixels = width * height
    records = capacity(depth, pixels) > 0
    piece_of = np.empty(pixels if records else 0, dtype=np.int32)
    # The group's pixels a piece meets, and every pixel step 3 touched (crease_far), each
    # once, their count first.
    marked = np.empty(pixels + 1, dtype=np.int32)
    touched = np.empty(pixels + 1, dtype=np.int32)
    touched[0] = 0
    scale = 1.0 / (1.0 + slack)
    num = 1.0 + slack
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
                if cut[c]:
                    was_cut[k] = 1
                nearest = min(nearest, poly[c, 2])
                xs[c] = poly[c, 0] / poly[c, 2] * sx + 0.5 * width
                ys[c] = poly[c, 1] / poly[c, 2] * sy + 0.5 * height
                bx0, bx1 = min(bx0, xs[c]), max(bx1, xs[c])
                by0, by1 = min(by0, ys[c]), max(by1, ys[c])
            if n == 3 and not was_cut[k]:  # poly is the triangle, corners in order
                flat[k] = 1
                for c in range(3):
                    proj[k, c, 0], proj[k, c, 1] = xs[c], ys[c]
                u, v = (xs[1] - xs[0]) * (ys[2] - ys[0]), (ys[1] - ys[0]) * (xs[2] - xs[0])
                if abs(u - v) > 1e-6 * (abs(u) + abs(v)):  # else too thin to orient surely
                    orient[k] = 1.0 if u > v else -1.0
            y_lo, y_hi = ys[0], ys[0]
            for c in range(1, n):
                y_lo, y_hi = min(y_lo, ys[c]), max(y_hi, ys[c])
            r0 = max(np.ceil(y_lo - 0.5), 0.0)
            r1 = min(np.floor(y_hi - 0.5), height - 1.0)
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
                if ya == yb:
                    for rr in range(int(e0), int(e1) + 1):
                        if rr + 0.5 == ya:
                            row_l[rr] = min(row_l[rr], xa, xb)
                            row_r[rr] = max(row_r[rr], xa, xb)
                else:
                    _edge_rows(row_l, row_r, int(e0), int(e1), xa, ya, xb, yb)
            for rr in range(ir0, ir1 + 1):
                c0 = max(np.ceil(row_l[rr] - 0.5), 0.0)
                c1 = min(np.floor(row_r[rr] - 0.5), width - 1.0)
                if not c0 <= c1:
                    continue
                # Only centres are marked yet (mask is zero where each group starts): a fill.
                base = rr * width
                mask[base + int(c0):base + int(c1) + 1] = _CENTRE
                span_lo[rr] = min(span_lo[rr], int(c0))
                span_hi[rr] = max(span_hi[rr], int(c1))
        gx0 = int(max(np.floor(bx0) - 1.0, 0.0)) if bx0 < np.inf else width
        gx1 = int(min(np.floor(bx1) + 1.0, width - 1.0)) if bx1 > -np.inf else -1
        gy0 = int(max(np.floor(by0) - 1.0, 0.0)) if by0 < np.inf else height
        gy1 = int(min(np.floor(by1) + 1.0, height - 1.0)) if by1 > -np.inf else -1
        if gx1 < gx0 or gy1 < gy0:  # nothing marked (the box holds every mark)
            start = stop
            continue
        # The group's plane: 1 / z = a x + b y + c0_ at buffer point (x, y) (when dd > 0).
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
            # the least of a x + b y over the pixel's square (whole: [i, i + 1] x [r, r + 1])
            low = (min(a, 0.0) + min(b, 0.0) if half >= 0.5
                   else 0.5 * (a + b) - half * (abs(a) + abs(b)))
        # 2. Pixels unpaired pieces, crease pieces or near-plane cuts pass near.
        marked[0] = 0
        for k in range(start, stop):
            t = ids[k]
            for s in range(piece_start[t], piece_end[t]):
                q = partner[s]
                if q >= 0 and stamp[q] == frame:
                    continue  # the reverse piece's triangle is on the other side
                q = partner_any[s]
                bit = _CREASE if q >= 0 and stamp[q] == frame else _BOUNDARY
                e = s - piece_start[t]  # the triangle's edge e: corner e -> corner e + 1?
                edge = flat[k] and e < 3 and piece_a[s] == tri_points[t, e] \
                    and piece_b[s] == tri_points[t, (e + 1) % 3]
                if edge:  # step 1's projection of the uncut triangle (the same arithmetic)
                    f = (e + 1) % 3
                    ax, ay, bx, by = proj[k, e, 0], proj[k, e, 1], proj[k, f, 0], proj[k, f, 1]
                else:
                    _row_to_camera(points, piece_a[s], eye, rot, ends, 0)
                    _row_to_camera(points, piece_b[s], eye, rot, ends, 1)
                    if ends[0, 2] < clip and ends[1, 2] < clip:
                        continue
                    if ends[0, 2] < clip or ends[1, 2] < clip:
                        u = (clip - ends[0, 2]) / (ends[1, 2] - ends[0, 2])
                        cx = ends[0, 0] + u * (ends[1, 0] - ends[0, 0])
                        cy = ends[0, 1] + u * (ends[1, 1] - ends[0, 1])
                        w = 0 if ends[0, 2] < clip else 1
                        ends[w, 0], ends[w, 1], ends[w, 2] = cx, cy, clip
                    ax = ends[0, 0] / ends[0, 2] * sx + 0.5 * width
                    ay = ends[0, 1] / ends[0, 2] * sy + 0.5 * height
                    bx = ends[1, 0] / ends[1, 2] * sx + 0.5 * width
                    by = ends[1, 1] / ends[1, 2] * sy + 0.5 * height
                line = -1  # the piece's edge record: uncut triangles' boundary pieces only
                if records and edge and bit == _BOUNDARY and dd > 0 and orient[k] != 0:
                    line = add_record(depth, pixels, half, a * scale, b * scale, c0_ * scale,
                                      ax, ay, bx, by, orient[k])
                _mark_segment(ax, ay, bx, by, width, height, mask, bit, span_lo, span_hi, half,
                              piece_of, line, marked)
            if not was_cut[k]:
                continue  # no near-plane side to mark
            n = _clipped_occluder(t, points, tri_points, eye, rot, clip, tri, poly, cut)
            for c in range(n):
                d = (c + 1) % n
                if cut[c] and cut[d]:  # the near-plane side of a cut triangle
                    _mark_segment(poly[c, 0] / clip * sx + 0.5 * width,
                                  poly[c, 1] / clip * sy + 0.5 * height,
                                  poly[d, 0] / clip * sx + 0.5 * width,
                                  poly[d, 1] / clip * sy + 0.5 * height, width, height, mask,
                                  _BOUNDARY, span_lo, span_hi, half, piece_of, -1, marked)
        # 3. Covered pixels take the plane's farthest over their corners, crease pixels keep
        # the largest over groups, pixels one boundary piece meets its edge record (hiz.edges);
        # scratch cleared. First the pixels pieces meet (listed by step 2), then each row's
        # run of covered pixels (_covered_run, vectorised; the border's one by one).
        for q in range(1, marked[0] + 1):
            p = marked[q]
            m = mask[p]
            rr, i = p // width, p % width
            if m & _CENTRE:
                centre[p] = 1
            if crease_far[p] == 0.0:  # first touched this call: step 4 reads and clears it
                touched[0] += 1
                touched[touched[0]] = p
            if m & _BOUNDARY:
                crease_far[p] = -1.0
                if records and piece_of[p] >= 0 and not m & _CREASE:
                    set_record(depth, pixels, p, piece_of[p], i + 0.5, rr + 0.5)
                continue
            creases = True  # a crease piece meets it, no boundary piece
            if crease_far[p] >= 0:
                crease_far[p] = max(crease_far[p], _far(a, b, c0_, low, i, rr, width, height,
                                                        half, dd, num))
        for rr in range(gy0, gy1 + 1):
            i0, i1 = span_lo[rr], span_hi[rr]  # the row's marked columns (none: i0 > i1)
            span_lo[rr], span_hi[rr] = width, -1
            if i0 > i1:
                continue
            base = rr * width
            j0 = j1 = i1 + 1  # [j0, j1): the run _covered_run takes, the rest one by one
            if dd > 0 and 0 < rr < height - 1:
                j0, j1 = max(i0, 1), max(min(i1 + 1, width - 1), max(i0, 1))
                written += _covered_run(mask, depth, centre, base, j0, j1, a, b * rr, c0_, low,
                                        num)
            for i in range(i0, min(j0, i1 + 1)):  # the border's columns and rows
                written += _covered_pixel(mask, depth, centre, base + i, a, b, c0_, low, i, rr,
                                          width, height, half, dd, num)
            for i in range(max(j1, i0), i1 + 1):
                written += _covered_pixel(mask, depth, centre, base + i, a, b, c0_, low, i, rr,
                                          width, height, half, dd, num)
            mask[base + i0:base + i1 + 1] = 0
        start = stop
    # 4. Crease pixels: centre in some triangle, met by no boundary, every group near bounded
    # (every pixel step 3 touched is listed: their scratch is cleared here).
    for q in range(1, touched[0] + 1):
        p = touched[q]
        f = crease_far[p]
        if creases and f > 0 and f < depth[p] and centre[p]:
            if depth[p] == np.inf:
                written += 1
            depth[p] = f
        crease_far[p] = 0.0
    centre[:] = 0
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

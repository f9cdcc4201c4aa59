"""Screen projection and a conservative low-resolution occluder depth buffer: coverage of the
UNION of the occluders (not of each triangle alone), so shared edges, creases and T-junctions
leave no cracks, after Intel's Masked Occlusion Culling (Hasselgren et al. 2016), with a sparse
table for exact "max depth over a pixel rectangle" queries (in place of Greene's pyramid).

Camera space here: x right, y up, z = depth along the view direction (positive in front).
NDC: u = x / (z tx), v = y / (z ty) with tx, ty the tangents of the half fields of view.
Pixel coordinates: px = (u + 1) W / 2, py = (v + 1) H / 2; pixel (i, j) is [i, i+1] x [j, j+1].

Why the union is covered: a pixel rectangle P lies inside a union U of triangles when its centre
is in U and no piece of U's boundary meets P (else the segment from the centre to a point of P
outside U would cross the boundary inside P). The boundary lies on the triangles' edges minus
the edge pieces that have triangles on both sides; edges are split where another occluder's
vertex lies on them (T-junctions), so pieces match exactly by vertex index. "Centre in U" is a
nonzero winding number of the same chain of edges.
"""
from __future__ import annotations

import numpy as np

from .boxes import box_corners

SLACK_PX = 0.01     # pixels: boundaries and rectangles grown by this (GPU snapping is 1/1024)
DEPTH_SLACK = 1e-9  # relative: occluder depths pushed back, tested depths pulled forward
SAMPLE_SLACK_PX = 1.0 / 64  # screen pixels: GPU vertex snapping (8 subpixel bits) is 1/512


def to_camera(points, eye, rotation) -> np.ndarray:
    """(..., 3) float64 camera-space coordinates of world points.

    points : (..., 3) float64;  eye : (3,);  rotation : (3, 3) rows right, up, forward
    """
    return (np.asarray(points, dtype=np.float64) - eye) @ np.asarray(rotation).T


def split_edges(vertices, triangles) -> tuple:
    """Directed edge pieces of triangles, each edge split at every vertex lying exactly on it
    (axis-parallel edges; others are left whole): (tri (S,) int64, a (S,) int64, b (S,) int64).

    Exact: pieces a -> b follow each triangle's winding and cover exactly its edges; a vertex
    is a split point only when it matches the edge's two fixed coordinates bit for bit.
    vertices  : (V, 3) float64 unique points;  triangles : (T, 3) int64 indices into vertices
    """
    v = np.asarray(vertices, dtype=np.float64)
    tri = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    ea, eb = tri.ravel(), np.roll(tri, -1, axis=1).ravel()  # edge k of triangle t at 3t + k
    owner = np.repeat(np.arange(len(tri)), 3)
    splits_e, splits_p = [np.zeros(0, np.int64)], [np.zeros(0, np.int64)]
    for axis in range(3):
        o1, o2 = [k for k in range(3) if k != axis]
        edges = np.flatnonzero((v[ea, o1] == v[eb, o1]) & (v[ea, o2] == v[eb, o2])
                               & (v[ea, axis] != v[eb, axis]))
        if not len(edges):
            continue
        # Lines keyed by their two fixed coordinates; split points strictly inside each edge.
        keys = np.concatenate([v[:, [o1, o2]], v[ea[edges]][:, [o1, o2]]])
        _, line = np.unique(keys, axis=0, return_inverse=True)
        line = line.ravel()
        vline, eline = line[:len(v)], line[len(v):]
        coords = np.unique(v[:, axis])
        rank = np.searchsorted(coords, v[:, axis])
        lo = np.minimum(v[ea[edges], axis], v[eb[edges], axis])
        hi = np.maximum(v[ea[edges], axis], v[eb[edges], axis])
        step = len(coords) + 1
        vkey = vline * step + rank
        order = np.argsort(vkey, kind="stable")
        start = np.searchsorted(vkey[order], eline * step + np.searchsorted(coords, lo), "right")
        stop = np.searchsorted(vkey[order], eline * step + np.searchsorted(coords, hi), "left")
        count = np.maximum(stop - start, 0)
        if not count.sum():
            continue
        first = np.repeat(start - np.concatenate([[0], np.cumsum(count)[:-1]]), count)
        splits_p.append(order[first + np.arange(count.sum())])
        splits_e.append(np.repeat(edges, count))
    e, p = np.concatenate(splits_e), np.concatenate(splits_p)
    # Order split points along each edge from a to b, then chain a -> p1 -> ... -> b.
    along = np.einsum("ij,ij->i", v[p] - v[ea[e]], v[eb[e]] - v[ea[e]])
    order = np.lexsort((along, e))
    e, p = e[order], p[order]
    counts = np.bincount(e, minlength=len(ea))
    total = len(ea) + len(p)
    slot = np.arange(len(ea)) + np.concatenate([[0], np.cumsum(counts)[:-1]])  # first piece
    points = np.empty(total + len(ea), dtype=np.int64)  # per edge: a, splits..., then b
    pos = slot + np.arange(len(ea))
    points[pos] = ea
    inner = np.repeat(pos, counts) + 1 + (np.arange(len(p)) - np.repeat(
        np.concatenate([[0], np.cumsum(counts)[:-1]]), counts))
    points[inner] = p
    points[pos + counts + 1] = eb
    is_start = np.ones(total + len(ea), dtype=bool)
    is_start[pos + counts + 1] = False  # b ends its edge's chain
    starts = np.flatnonzero(is_start)
    piece_edge = np.repeat(np.arange(len(ea)), counts + 1)
    return owner[piece_edge], points[starts], points[starts + 1]


def union_depth(points, triangles, pieces, groups, planes, near: float, tx: float, ty: float,
                width: int, height: int) -> np.ndarray:
    """(H, W) float64 depth bound of a set of occluder triangles: a pixel is finite only when
    wholly inside their union (clipped to depth >= near), and then holds a depth >= the nearest
    occluder's depth at every point of the pixel; inf elsewhere.

    Errs toward "not covered" (boundaries grown by SLACK_PX) and "farther" (x (1 + DEPTH_SLACK)).
    Depth: within a group of triangles sharing one plane, that plane's farthest point over the
    pixel where the group's union covers it; where only the union of all groups covers it (a
    crease or T-junction between groups), the largest over every occluder whose rectangle meets
    the pixel of its farthest point there (plane over the pixel, capped by its farthest vertex).
    points    : (P, 3) float64 camera-space vertices (each point once: shared values stay exact)
    triangles : (K, 3) int64 indices into points; they must face the eye
    pieces    : (tri (S,), a (S,), b (S,)) int64 directed edge pieces (split_edges), tri in [0, K)
    groups    : (K,) int64 plane label; triangles with one label lie on one plane
    planes    : (K, 4) float64 camera-space planes (n, d) with n.x = d on the triangle, d > 0
    """
    pts = np.asarray(points, dtype=np.float64)
    tri = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    seg_tri, ia, ib = (np.asarray(x, dtype=np.int64) for x in pieces)
    buffer = np.full((height, width), np.inf)
    if not len(tri) or not len(seg_tri):
        return buffer
    _, groups = np.unique(np.asarray(groups), return_inverse=True)
    groups = groups.ravel()
    n_groups = int(groups.max()) + 1
    nv = len(pts)

    # Clip pieces to z >= near; the cut point is computed from the lower vertex index so a piece
    # and its reverse are cut to bit-identical points.
    za, zb = pts[ia, 2], pts[ib, 2]
    ina, inb = za >= near, zb >= near
    lo_i, hi_i = np.minimum(ia, ib), np.maximum(ia, ib)
    o, f = pts[lo_i], pts[hi_i]
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        t = (near - o[:, 2]) / (f[:, 2] - o[:, 2])
        cut = o + t[:, None] * (f - o)  # used only where the piece crosses near
    cut[:, 2] = near
    pa = np.where(ina[:, None], pts[ia], cut)
    pb = np.where(inb[:, None], pts[ib], cut)
    keep = ina | inb
    # The near-plane side of each cut triangle runs from where its boundary leaves the front
    # half-space to where it re-enters (same points as the clipped pieces: the chain closes).
    leave, enter = np.flatnonzero(ina & ~inb), np.flatnonzero(~ina & inb)
    leave = leave[np.argsort(seg_tri[leave], kind="stable")]
    enter = enter[np.argsort(seg_tri[enter], kind="stable")]
    near_a, near_b, near_tri = pb[leave], pa[enter], seg_tri[leave]

    # Chain coefficients per undirected piece (net direction) and boundary pieces (pieces
    # without a reverse partner: a triangle on one side only), within groups and overall.
    k = np.flatnonzero(keep)
    s_tri, s_a, s_b = seg_tri[k], pa[k], pb[k]
    forward = ia[k] < ib[k]
    ukey = lo_i[k] * nv + hi_i[k]
    boundary_group = _one_sided(groups[s_tri] * nv * nv + ukey, forward)
    boundary_all = _one_sided(ukey, forward)
    net_key = groups[s_tri] * nv * nv + ukey
    uniq, inv = np.unique(net_key, return_inverse=True)
    net = np.bincount(inv.ravel(), weights=np.where(forward, 1.0, -1.0), minlength=len(uniq))
    rep = np.zeros(len(uniq), dtype=np.int64)
    rep[inv.ravel()] = np.arange(len(k))
    chain = rep[net != 0]
    # Canonical direction lo -> hi for chain pieces, weight net.
    c_a = np.where(forward[chain, None], s_a[chain], s_b[chain])
    c_b = np.where(forward[chain, None], s_b[chain], s_a[chain])
    c_w = net[net != 0]
    c_g = groups[s_tri[chain]]
    c_a = np.concatenate([c_a, near_a])
    c_b = np.concatenate([c_b, near_b])
    c_w = np.concatenate([c_w, np.ones(len(near_a))])
    c_g = np.concatenate([c_g, groups[near_tri]])

    def px(p):
        return np.stack([(p[:, 0] / (p[:, 2] * tx) + 1.0) * 0.5 * width,
                         (p[:, 1] / (p[:, 2] * ty) + 1.0) * 0.5 * height], axis=1)

    # Pixels whose centre has a nonzero winding number, per group and overall.
    inside_g = _winding_pixels(px(c_a), px(c_b), c_w, c_g, width, height)
    inside_all = np.unique(inside_g % (width * height))
    # Pixels a boundary piece (or a near-plane side) may touch.
    b_a = np.concatenate([s_a[boundary_group], near_a])
    b_b = np.concatenate([s_b[boundary_group], near_b])
    b_g = np.concatenate([groups[s_tri[boundary_group]], groups[near_tri]])
    b_all = np.concatenate([boundary_all[boundary_group], np.ones(len(near_a), dtype=bool)])
    seg_id, pix = _touched_pixels(px(b_a), px(b_b), width, height)
    touched_g = np.unique(b_g[seg_id] * (width * height) + pix)
    touched_all = np.unique(pix[b_all[seg_id]])

    # Group coverage: the group's own plane, farthest over the pixel's corners.
    covered = inside_g[~np.isin(inside_g, touched_g, assume_unique=True)]
    g, p = covered // (width * height), covered % (width * height)
    rep_tri = np.zeros(n_groups, dtype=np.int64)
    rep_tri[groups] = np.arange(len(tri))
    depth = _plane_far(planes[rep_tri[g]], p, tx, ty, width, height)
    np.minimum.at(buffer.ravel(), p, depth)

    # Coverage only by the union of all groups: every occluder meeting the pixel, farthest.
    rest = inside_all[~np.isin(inside_all, touched_all, assume_unique=True)]
    rest = rest[~np.isfinite(buffer.ravel()[rest])]
    if len(rest):
        tri_px = px(np.concatenate([s_a, s_b, near_a, near_b]))
        owner = np.concatenate([s_tri, s_tri, near_tri, near_tri])
        r, q = _rect_pixel_pairs(tri_px, owner, len(tri), rest, width, height)
        far = np.minimum(_plane_far(planes[q], rest[r], tx, ty, width, height),
                         pts[tri[q], 2].max(axis=1) * (1.0 + DEPTH_SLACK))
        worst = np.full(len(rest), -np.inf)
        np.maximum.at(worst, r, far)
        buffer.ravel()[rest] = np.where(np.isfinite(worst), worst, np.inf)
    return buffer


def _rect_pixel_pairs(corner_px, owner, count: int, pixels, width: int, height: int) -> tuple:
    """(r (n,) int64 index into pixels, q (n,) int64 triangle) for every listed flat pixel that
    meets triangle q's screen rectangle grown by SLACK_PX (errs toward more pairs).

    Small rectangles scatter their own pixels; a rectangle larger than the pixel list is tested
    against the list instead, so the cost is about min(rect area, len(pixels)) per triangle.
    corner_px : (m, 2) float64 pixel coords of the triangles' (clipped) boundary points
    owner     : (m,) int64 triangle of each point, in [0, count)
    pixels    : (R,) int64 unique flat pixels
    """
    x0 = np.full(count, np.inf)
    x1, y0, y1 = -x0, x0.copy(), -x0
    np.minimum.at(x0, owner, corner_px[:, 0])
    np.maximum.at(x1, owner, corner_px[:, 0])
    np.minimum.at(y0, owner, corner_px[:, 1])
    np.maximum.at(y1, owner, corner_px[:, 1])
    seen = np.isfinite(x0) & np.isfinite(x1) & np.isfinite(y0) & np.isfinite(y1)
    # Pixel i meets [x0 - s, x1 + s] when i <= x1 + s and i + 1 >= x0 - s.
    with np.errstate(invalid="ignore"):
        i0 = np.clip(np.ceil(np.where(seen, x0, 0.0) - SLACK_PX - 1.0), 0, width)
        i1 = np.clip(np.floor(np.where(seen, x1, -1.0) + SLACK_PX), -1, width - 1)
        j0 = np.clip(np.ceil(np.where(seen, y0, 0.0) - SLACK_PX - 1.0), 0, height)
        j1 = np.clip(np.floor(np.where(seen, y1, -1.0) + SLACK_PX), -1, height - 1)
    i0, i1, j0, j1 = (a.astype(np.int64) for a in (i0, i1, j0, j1))
    nx, ny = np.maximum(i1 - i0 + 1, 0), np.maximum(j1 - j0 + 1, 0)
    area = nx * ny
    pixels = np.asarray(pixels, dtype=np.int64)
    big = np.flatnonzero(area > len(pixels))
    small = np.flatnonzero((area > 0) & (area <= len(pixels)))
    # Large rectangles: every listed pixel against each.
    cx, cy = pixels % width, pixels // width
    meets = ((i0[big][None] <= cx[:, None]) & (i1[big][None] >= cx[:, None])
             & (j0[big][None] <= cy[:, None]) & (j1[big][None] >= cy[:, None]))
    rb, qb = np.nonzero(meets)
    # Small rectangles: scatter their pixels, keep the listed ones.
    a = area[small]
    tri = np.repeat(small, a)
    k = np.arange(a.sum()) - np.repeat(np.cumsum(a) - a, a)
    px_ = i0[tri] + k % nx[tri]
    py_ = j0[tri] + k // nx[tri]
    slot = np.full(width * height, -1, dtype=np.int64)
    slot[pixels] = np.arange(len(pixels))
    rs = slot[py_ * width + px_]
    hit = rs >= 0
    return np.concatenate([rb, rs[hit]]), np.concatenate([big[qb], tri[hit]])


def _one_sided(key, forward) -> np.ndarray:
    """(S,) bool: no piece with the same undirected key runs the other way."""
    uniq, inv = np.unique(key, return_inverse=True)
    inv = inv.ravel()
    fwd = np.bincount(inv, weights=forward, minlength=len(uniq))
    bwd = np.bincount(inv, weights=~forward, minlength=len(uniq))
    return ((fwd == 0) | (bwd == 0))[inv]


def _plane_far(planes, pixels, tx, ty, width, height) -> np.ndarray:
    """(n,) float64 farthest depth of each plane over each flat pixel's four corner rays
    (1/z is affine over the pixel, so extreme at a corner), x (1 + DEPTH_SLACK); inf when the
    plane is not in front at every corner."""
    x, y = pixels % width, pixels // width
    best = np.full(len(pixels), np.inf)
    for dx in (0, 1):
        for dy in (0, 1):
            u = 2.0 * (x + dx) / width - 1.0
            v = 2.0 * (y + dy) / height - 1.0
            inv = (planes[:, 0] * u * tx + planes[:, 1] * v * ty + planes[:, 2]) / planes[:, 3]
            best = np.minimum(best, inv)
    with np.errstate(divide="ignore"):
        return np.where(best > 0, (1.0 + DEPTH_SLACK) / best, np.inf)


def _winding_pixels(a, b, weight, group, width, height) -> np.ndarray:
    """(n,) int64 unique flat keys group * H * W + pixel of pixels whose centre has a nonzero
    winding number for the group's chain of weighted directed segments a -> b (pixel coords).
    Exact up to rounding of crossings that pass within rounding of a centre."""
    ya, yb = a[:, 1], b[:, 1]
    first = np.clip(np.floor(np.minimum(ya, yb) - 0.5), 0, height).astype(np.int64)
    last = np.clip(np.ceil(np.maximum(ya, yb) - 0.5), -1, height - 1).astype(np.int64)
    count = np.maximum(last - first + 1, 0)
    seg = np.repeat(np.arange(len(a)), count)
    row = first[seg] + np.arange(count.sum()) - np.repeat(np.cumsum(count) - count, count)
    yc = row + 0.5
    cross = (ya[seg] > yc) != (yb[seg] > yc)  # half-open: consistent at shared endpoints
    seg, row, yc = seg[cross], row[cross], yc[cross]
    xc = a[seg, 0] + (yc - ya[seg]) * (b[seg, 0] - a[seg, 0]) / (yb[seg] - ya[seg])
    col = np.clip(np.ceil(xc - 0.5), 0, width).astype(np.int64)  # centres left of it count
    w = np.where(yb[seg] > ya[seg], weight[seg], -weight[seg])
    line = group[seg] * height + row
    order = np.lexsort((col, line))
    line, col, w = line[order], col[order], w[order]
    # Each (group, row) sums to zero (closed chains), so a running sum resets between rows;
    # the winding at centres between events i and i+1 of a row is minus the sum up to i.
    run = np.cumsum(w)  # integer-valued: exact
    nxt = np.append(col[1:], width)
    same = np.append(line[1:] == line[:-1], False)
    stop = np.where(same, nxt, width)
    span = np.where(run != 0, np.maximum(stop - col, 0), 0)
    which = np.repeat(np.arange(len(col)), span)
    cols = col[which] + np.arange(span.sum()) - np.repeat(np.cumsum(span) - span, span)
    g, r = line[which] // height, line[which] % height
    return np.unique(g * (height * width) + r * width + cols)


def _touched_pixels(a, b, width, height) -> tuple:
    """(segment (n,) int64, flat pixel (n,) int64) pairs covering every pixel that each segment
    a -> b (pixel coords) passes within SLACK_PX of, clipped to the buffer (errs toward more)."""
    d = b - a
    steep = np.abs(d[:, 1]) > np.abs(d[:, 0])
    # Walk along the major axis one pixel column (or row) at a time.
    p = np.where(steep[:, None], a[:, ::-1], a)
    q = np.where(steep[:, None], b[:, ::-1], b)
    swap = p[:, 0] > q[:, 0]
    p, q = np.where(swap[:, None], q, p), np.where(swap[:, None], p, q)
    major = np.where(steep, height, width)
    minor = np.where(steep, width, height)
    c0 = np.clip(np.floor(p[:, 0] - SLACK_PX), 0, major).astype(np.int64)
    c1 = np.clip(np.floor(q[:, 0] + SLACK_PX), -1, major - 1).astype(np.int64)
    count = np.maximum(c1 - c0 + 1, 0)
    seg = np.repeat(np.arange(len(a)), count)
    col = c0[seg] + np.arange(count.sum()) - np.repeat(np.cumsum(count) - count, count)
    ps, qs = p[seg], q[seg]
    lo_x = np.maximum(col - SLACK_PX, ps[:, 0])
    hi_x = np.minimum(col + 1 + SLACK_PX, qs[:, 0])
    dx = qs[:, 0] - ps[:, 0]
    slope = np.where(dx > 0, (qs[:, 1] - ps[:, 1]) / np.where(dx > 0, dx, 1.0), 0.0)
    ylo = ps[:, 1] + (lo_x - ps[:, 0]) * slope
    yhi = ps[:, 1] + (hi_x - ps[:, 0]) * slope
    y0 = np.floor(np.minimum(ylo, yhi) - SLACK_PX)
    y1 = np.floor(np.maximum(ylo, yhi) + SLACK_PX)
    y0 = np.clip(y0, 0, minor[seg]).astype(np.int64)
    y1 = np.clip(y1, -1, minor[seg] - 1).astype(np.int64)
    rows = np.maximum(y1 - y0 + 1, 0)
    seg2 = np.repeat(np.arange(len(seg)), rows)
    r = y0[seg2] + np.arange(rows.sum()) - np.repeat(np.cumsum(rows) - rows, rows)
    c = col[seg2]
    st = steep[seg[seg2]]
    x, y = np.where(st, r, c), np.where(st, c, r)
    return seg[seg2], y * width + x


def max_table(buffer) -> tuple:
    """2D sparse table of an (H, W) buffer for rect_max: (values (M,), offsets (LY, LX),
    widths (LY, LX)); entry (ky, kx) holds maxima over 2^ky x 2^kx blocks."""
    buf = np.asarray(buffer, dtype=np.float64)
    h, w = buf.shape
    ly, lx = int(np.log2(h)) + 1, int(np.log2(w)) + 1
    tables, offsets, widths, at = [], np.zeros((ly, lx), np.int64), np.zeros((ly, lx), np.int64), 0
    row = buf
    for ky in range(ly):
        if ky:
            step = 1 << (ky - 1)
            row = np.maximum(row[:-step], row[step:])
        col = row
        for kx in range(lx):
            if kx:
                step = 1 << (kx - 1)
                col = np.maximum(col[:, :-step], col[:, step:])
            tables.append(col.ravel())
            offsets[ky, kx], widths[ky, kx] = at, col.shape[1]
            at += col.size
    return np.concatenate(tables), offsets, widths


def rect_max(table, x0, x1, y0, y1) -> np.ndarray:
    """(B,) float64 exact maximum of the buffer over each inclusive pixel rectangle (four
    overlapping power-of-two blocks). table : from max_table; x0 <= x1, y0 <= y1 in range."""
    values, offsets, widths = table
    kx = np.floor(np.log2(x1 - x0 + 1)).astype(np.int64)
    ky = np.floor(np.log2(y1 - y0 + 1)).astype(np.int64)
    base, w = offsets[ky, kx], widths[ky, kx]
    xr, yr = x1 - (1 << kx) + 1, y1 - (1 << ky) + 1
    return np.maximum(np.maximum(values[base + y0 * w + x0], values[base + y0 * w + xr]),
                      np.maximum(values[base + yr * w + x0], values[base + yr * w + xr]))


def point_rects(points, near: float, tx: float, ty: float, width: int, height: int,
                move: float = 0.0, shift: float = 0.0) -> tuple:
    """Conservative screen rectangles of point sets: (x0, x1, y0, y1 (B,) int64 inclusive pixels,
    zmin (B,) float64 nearest depth x (1 - DEPTH_SLACK), testable (B,) bool, onscreen (B,) bool).

    Errs large: the rectangle bounds the projection of every point, also after a move of up to
    `move` per coordinate (zmin is lowered by sqrt(3) move), grown by SLACK_PX pixels plus
    `shift` (in units of x / z, i.e. tangents); testable is False when a point (moved) is
    nearer than `near`; onscreen is False when the grown rectangle misses the buffer (then
    nothing of the convex hull of points in front is seen).
    points : (B, m, 3) float64 camera-space points;  move, shift : float >= 0
    """
    reach = np.sqrt(3.0) * float(move)
    z = points[..., 2] - reach
    zmin = z.min(axis=1)
    testable = zmin >= near
    zsafe = np.where(testable[:, None], z, 1.0)
    u, v = points[..., 0] / (zsafe * tx), points[..., 1] / (zsafe * ty)
    # d(x / z) <= m / z (1 + |x| / z) for moves of each coordinate <= m (z already lowered).
    lateral = np.maximum(np.abs(points[..., 0]), np.abs(points[..., 1])) + reach
    grow = (reach / zsafe * (1.0 + lateral / zsafe)).max(axis=1) + float(shift)
    gu, gv = grow / tx, grow / ty
    x0 = np.floor((u.min(axis=1) - gu + 1.0) * 0.5 * width - SLACK_PX)
    x1 = np.floor((u.max(axis=1) + gu + 1.0) * 0.5 * width + SLACK_PX)
    y0 = np.floor((v.min(axis=1) - gv + 1.0) * 0.5 * height - SLACK_PX)
    y1 = np.floor((v.max(axis=1) + gv + 1.0) * 0.5 * height + SLACK_PX)
    onscreen = (x1 >= 0) & (x0 <= width - 1) & (y1 >= 0) & (y0 <= height - 1)
    x0, x1 = np.clip(x0, 0, width - 1), np.clip(x1, 0, width - 1)
    y0, y1 = np.clip(y0, 0, height - 1), np.clip(y1, 0, height - 1)
    return (x0.astype(np.int64), x1.astype(np.int64), y0.astype(np.int64), y1.astype(np.int64),
            zmin * (1.0 - DEPTH_SLACK), testable, onscreen)


def box_rects(boxes, eye, rotation, near: float, tx: float, ty: float,
              width: int, height: int, move: float = 0.0, shift: float = 0.0) -> tuple:
    """Conservative screen rectangles of boxes: (x0, x1, y0, y1 (B,) int64 inclusive pixels,
    zmin (B,) float64 nearest depth, testable (B,) bool).

    Errs large: the rectangle bounds the projection of all 8 corners (also moved by `move` per
    coordinate), grown by SLACK_PX pixels plus `shift` (point_rects); a box is not testable
    when any corner is nearer than `near` or its rectangle is off screen.
    boxes : (B, 2, 3) float64;  rotation : (3, 3) rows right, up, forward
    """
    cam = to_camera(box_corners(boxes), eye, rotation)  # (B, 8, 3)
    x0, x1, y0, y1, zmin, testable, onscreen = point_rects(cam, near, tx, ty, width, height,
                                                           move, shift)
    return x0, x1, y0, y1, zmin, testable & onscreen


def covers_no_sample(points, near: float, tx: float, ty: float, width: int, height: int,
                     move: float = 0.0, max_samples: int = 16) -> np.ndarray:
    """(B,) bool: each camera-space triangle, rasterised on a width x height screen sampled at
    pixel centres (no multisampling), certainly covers no sample, so it yields no fragment.

    Errs toward False: True only when every vertex is in front of `near` and no pixel centre
    lies within the triangle grown by its vertices' worst screen error (SAMPLE_SLACK_PX for
    subpixel snapping plus the projection of a move of up to `move` per world coordinate);
    triangles whose grown box holds more than max_samples centres are not tested (False).
    points : (B, 3, 3) float64 camera-space triangles;  move : float >= 0 (device rounding)
    """
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 3, 3)
    z = pts[..., 2]
    front = z.min(axis=1) >= near
    zs = np.where(front[:, None], z, 1.0)
    sx, sy = 0.5 * width / tx, 0.5 * height / ty
    x = (pts[..., 0] / zs) * sx + 0.5 * width   # window coordinates, pixel centres at k + 0.5
    y = (pts[..., 1] / zs) * sy + 0.5 * height
    # d(x)/d(point) = sx / z (dx - x/z dz): a move of |d| <= sqrt(3) move shifts it this much.
    lateral = np.maximum(np.abs(pts[..., 0]), np.abs(pts[..., 1]))
    reach = np.sqrt(3.0) * move / zs * (1.0 + lateral / zs)
    err = (SAMPLE_SLACK_PX + max(sx, sy) * reach).max(axis=1)
    x0, x1 = x.min(axis=1) - err, x.max(axis=1) + err
    y0, y1 = y.min(axis=1) - err, y.max(axis=1) + err
    big = 4.0 * (width + height)  # far-off boxes: clipping below keeps the counts small
    i0 = np.clip(np.ceil(np.clip(x0, -big, big) - 0.5), 0, width).astype(np.int64)
    i1 = np.clip(np.floor(np.clip(x1, -big, big) - 0.5), -1, width - 1).astype(np.int64)
    j0 = np.clip(np.ceil(np.clip(y0, -big, big) - 0.5), 0, height).astype(np.int64)
    j1 = np.clip(np.floor(np.clip(y1, -big, big) - 0.5), -1, height - 1).astype(np.int64)
    nx, ny = np.maximum(i1 - i0 + 1, 0), np.maximum(j1 - j0 + 1, 0)
    count = np.where(front, nx * ny, max_samples + 1)
    none = count == 0
    few = np.flatnonzero((count > 0) & (count <= max_samples))
    if len(few):
        c = count[few]
        t = np.repeat(few, c)
        k = np.arange(c.sum()) - np.repeat(np.cumsum(c) - c, c)
        s = np.stack([i0[t] + k % nx[t] + 0.5, j0[t] + k // nx[t] + 0.5], axis=1)
        p = np.stack([x[t], y[t]], axis=2)  # (n, 3 vertices, 2)
        q = np.roll(p, -1, axis=1)
        edge = q - p
        rel = s[:, None, :] - p
        e = edge[..., 0] * rel[..., 1] - edge[..., 1] * rel[..., 0]  # (n, 3) edge functions
        # Moving both ends by <= m changes e by <= m (2 |s - p| + |q - p|) + 2 m^2.
        m = err[t][:, None]
        tol = (m * (2.0 * np.hypot(rel[..., 0], rel[..., 1]) + np.hypot(edge[..., 0], edge[..., 1]))
               + 2.0 * m * m) * (1.0 + 1e-9) + 1e-9
        maybe = ((e >= -tol).all(axis=1) | (e <= tol).all(axis=1))
        hit = np.zeros(len(pts), dtype=bool)
        hit[t[maybe]] = True
        none[few] = ~hit[few]
    return front & none

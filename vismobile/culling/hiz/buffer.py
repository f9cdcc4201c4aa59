"""The tiled depth buffer's tests (numba, cached on disk): the conservative pixel rectangle of
tested points, the comparison with the buffer (its blocks, tiles and pixels: tiles.py holds
those tables and the occluders' screen shift per tile), and the per-triangle test (package
docstring: the buffer and its screen).

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
A triangle's shape test then reads each pixel only at those centres (_pixel_centres_behind):
its fragments exist only there, so its plane's depth is bounded over each centre (grown by its
own move) rather than over the pixel's square (issue 32: W2 sent 1.474x -> 1.444x visible).
"""
from __future__ import annotations

import numpy as np
from numba import njit

from .edges import edge_bound
from .raster import DEPTH_SLACK, GUARD_PX, SLACK_PX, _to_camera
from .tiles import BLOCK_COLS, BLOCK_ROWS, tile_max_size, tile_shift_bound

SAMPLE_SLACK_PX = 1.0 / 64  # screen pixels: GPU vertex snapping (8 subpixel bits) is 1/512
# Relative to the corners' largest 1 / z: the plane's 1 / z fitted in float64 from a projection
# no thinner than _triangle_edges allows (conditioning <= 1e6) errs far below this.
PLANE_SLACK = 1e-6
# Screen centres per tested triangle that edge records (hiz.edges) may hide: beyond it the
# triangle is kept (a visible triangle along an occluder's outline stops scanning sooner).
EDGE_RESCUES = 6


@njit(cache=True, nogil=True, inline="always")
def _projected_bounds(cam, m, tx, ty, reach):
    """(umin, umax, vmin, vmax, grow): tangent-space bounds of the m camera-space points of cam
    each taken `reach` nearer, and the largest growth of their projection under that move.
    Contract: the arithmetic _rect and _centre_rect test with (shared so they agree bit for bit).
    One division per point (its reciprocal depth) and two per call, not four per point (issue
    32: 32 a box were the node walks' largest arithmetic cost): each bound is a few roundings
    (~1e-15 relative) off the quotients, far inside the SLACK_PX (0.01 px) every rectangle
    is grown by."""
    umin, umax, vmin, vmax, grow = np.inf, -np.inf, np.inf, -np.inf, 0.0
    itx, ity = 1.0 / tx, 1.0 / ty
    for k in range(m):
        iz = 1.0 / (cam[k, 2] - reach)
        u, v = cam[k, 0] * iz * itx, cam[k, 1] * iz * ity
        umin, umax, vmin, vmax = min(umin, u), max(umax, u), min(vmin, v), max(vmax, v)
        lateral = max(abs(cam[k, 0]), abs(cam[k, 1])) + reach
        grow = max(grow, reach * iz * (1.0 + lateral * iz))
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
def _behind(x0, x1, y0, y1, zmin, depth, width, tile_max, rows, cols, tw, th, margin, recede):
    """True when zmin > D + margin D^2 + recede for the largest D over the inclusive pixel
    rectangle (blocks first when tile_max has them (tile_max_size), then the tiles of a block
    whose maximum fails, pixels of partly covered tiles only when their maximum fails). The
    same answer with or without blocks: D + margin D^2 + recede grows with D >= 0 (margin >= 0,
    each rounded operation monotone), so a block's maximum passing means each tile's does."""
    r0, r1, c0, c1 = y0 // th, y1 // th, x0 // tw, x1 // tw
    if len(tile_max) < tile_max_size(rows, cols) or (r1 - r0 + 1) * (c1 - c0 + 1) <= 2:
        return _behind_tiles(x0, x1, y0, y1, r0, r1, c0, c1, zmin, depth, width, tile_max,
                             cols, tw, th, margin, recede)
    base, bcols = rows * cols, -(-cols // BLOCK_COLS)
    for by in range(r0 // BLOCK_ROWS, r1 // BLOCK_ROWS + 1):
        for bx in range(c0 // BLOCK_COLS, c1 // BLOCK_COLS + 1):
            d = tile_max[base + by * bcols + bx]
            if zmin > d + margin * d * d + recede:
                continue
            if not _behind_tiles(x0, x1, y0, y1, max(r0, by * BLOCK_ROWS),
                                 min(r1, by * BLOCK_ROWS + BLOCK_ROWS - 1),
                                 max(c0, bx * BLOCK_COLS),
                                 min(c1, bx * BLOCK_COLS + BLOCK_COLS - 1), zmin, depth, width,
                                 tile_max, cols, tw, th, margin, recede):
                return False
    return True


@njit(cache=True, nogil=True)
def _behind_tiles(x0, x1, y0, y1, tr0, tr1, tc0, tc1, zmin, depth, width, tile_max, cols, tw,
                  th, margin, recede):
    """_behind over tiles tr0..tr1 x tc0..tc1 (inclusive) of the pixel rectangle."""
    for ty_ in range(tr0, tr1 + 1):
        for tx_ in range(tc0, tc1 + 1):
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


@njit(cache=True, nogil=True, inline="always")
def _triangle_edges(cam, tx, ty, width, height, edges):
    """The projected triangle cam (3, 3) (corners in front of the eye) in buffer pixels as three
    inward edge functions: edges[e] = (a, b, c) with a x + b y + c >= 0 inside, and edges[3] =
    (a, b, c) with 1 / z = a x + b y + c over the triangle's plane (affine in pixels). Returns
    False for a projection too thin to orient (|area| <= 1e-6 of its edges' product): no shape
    test."""
    sx, sy = 0.5 * width / tx, 0.5 * height / ty
    px0, py0 = cam[0, 0] / cam[0, 2] * sx + 0.5 * width, cam[0, 1] / cam[0, 2] * sy + 0.5 * height
    px1, py1 = cam[1, 0] / cam[1, 2] * sx + 0.5 * width, cam[1, 1] / cam[1, 2] * sy + 0.5 * height
    px2, py2 = cam[2, 0] / cam[2, 2] * sx + 0.5 * width, cam[2, 1] / cam[2, 2] * sy + 0.5 * height
    ax, ay, bx, by = px1 - px0, py1 - py0, px2 - px0, py2 - py0
    area = ax * by - ay * bx
    if not abs(area) > 1e-6 * np.sqrt((ax * ax + ay * ay) * (bx * bx + by * by)):
        return False
    sign = 1.0 if area > 0 else -1.0
    xs, ys = (px0, px1, px2), (py0, py1, py2)
    for e in range(3):
        qx, qy = xs[e], ys[e]
        rx, ry = xs[(e + 1) % 3] - qx, ys[(e + 1) % 3] - qy
        # e(p) = r x (p - q), positive on the third corner's side when sign > 0
        edges[e, 0], edges[e, 1] = -sign * ry, sign * rx
        edges[e, 2] = sign * (ry * qx - rx * qy)
    w0, w1, w2 = 1.0 / cam[0, 2], 1.0 / cam[1, 2], 1.0 / cam[2, 2]
    a = ((w1 - w0) * by - (w2 - w0) * ay) / area
    b = ((w2 - w0) * ax - (w1 - w0) * bx) / area
    edges[3, 0], edges[3, 1], edges[3, 2] = a, b, w0 - a * px0 - b * py0
    return True


@njit(cache=True, nogil=True, inline="always")
def _outside(x0, x1, y0, y1, edges):
    """True when the pixel block [x0, x1] x [y0, y1] (buffer pixel coordinates, already grown)
    lies wholly outside one edge of the triangle (edges: _triangle_edges)."""
    for e in range(3):
        a, b, c = edges[e, 0], edges[e, 1], edges[e, 2]
        if max(a * x0, a * x1) + max(b * y0, b * y1) + c < 0:
            return True
    return False


@njit(cache=True, nogil=True, inline="always")
def _plane_near(x0, x1, y0, y1, zmin, edges, reach, wmax):
    """A lower bound of the depth of the triangle's points (each moved by up to reach) that
    project into the pixel block [x0, x1] x [y0, y1]: the nearest depth of its plane there (1 / z
    is affine in pixels, edges[3]: its largest over the block at a corner, taken PLANE_SLACK
    wmax larger for rounding), less reach, pulled forward by DEPTH_SLACK; never below zmin (the
    whole triangle's bound). Errs low."""
    a, b, c = edges[3, 0], edges[3, 1], edges[3, 2]
    w = max(a * x0, a * x1) + max(b * y0, b * y1) + c + PLANE_SLACK * wmax
    if not w > 0:  # nan, or the plane is not in front over the block: the triangle's bound
        return zmin
    return max(zmin, (1.0 / w - reach) * (1.0 - DEPTH_SLACK))


@njit(cache=True, nogil=True)
def _behind_shape(x0, x1, y0, y1, zmin, depth, width, tile_max, cols, tw, th, margin, recede,
                  edges, gx, gy, reach, wmax, centres, first):
    """_behind for a triangle, reading only the pixels its shape may reach: a pixel (or tile)
    whose square grown by gx, gy pixels lies wholly outside an edge of the projected triangle
    (edges: _triangle_edges) holds no point the device draws there, nor one an occluder's
    shift brings there (gx, gy: that shift and the points' move, plus SLACK_PX); a point drawn
    there is no nearer than the triangle's plane over that grown square less `reach` (its
    corners' move; _plane_near, wmax: the largest 1 / z of the corners), nor than zmin.
    centres (8,) (sw, sh, height, gsx, gsy, gmx, gmy, reach): with a screen (sw > 0) a pixel is
    read only at the screen's pixel centres the device may draw there (_pixel_centres_behind):
    those within gsx, gsy buffer pixels of its square (the occluders' shift), each a box grown
    by gmx, gmy (the points' own move and the GPU's snapping) for the shape and plane tests.
    first (2,): a buffer point whose tile is read first (the triangle's projected centroid:
    a visible triangle fails soonest there); the answer does not depend on it.
    Errs toward False as _behind does."""
    tx0, ty0, ntx = x0 // tw, y0 // th, x1 // tw - x0 // tw + 1
    fx = int(min(max(first[0], x0), x1)) // tw if first[0] == first[0] else tx0
    fy = int(min(max(first[1], y0), y1)) // th if first[1] == first[1] else ty0
    for k in range(-1, ntx * (y1 // th - ty0 + 1)):
        if k < 0:  # the first tile, then the others in order
            tx_, ty_ = fx, fy
        else:
            tx_, ty_ = tx0 + k % ntx, ty0 + k // ntx
            if tx_ == fx and ty_ == fy:
                continue
        d = tile_max[ty_ * cols + tx_]
        if zmin > d + margin * d * d + recede:
            continue
        r0, r1 = max(y0, ty_ * th), min(y1, ty_ * th + th - 1)
        c0, c1 = max(x0, tx_ * tw), min(x1, tx_ * tw + tw - 1)
        if _outside(c0 - gx, c1 + 1.0 + gx, r0 - gy, r1 + 1.0 + gy, edges):
            continue
        if _plane_near(c0 - gx, c1 + 1.0 + gx, r0 - gy, r1 + 1.0 + gy, zmin, edges, reach,
                       wmax) > d + margin * d * d + recede:
            continue
        for r in range(r0, r1 + 1):
            for c in range(c0, c1 + 1):
                d = depth[r * width + c]
                if zmin > d + margin * d * d + recede \
                        or _outside(c - gx, c + 1.0 + gx, r - gy, r + 1.0 + gy, edges):
                    continue
                if centres[0] > 0:
                    if not _pixel_centres_behind(c, r, d + margin * d * d + recede, zmin,
                                                 width, edges, wmax, centres, depth,
                                                 margin, recede):
                        return False
                elif not _plane_near(c - gx, c + 1.0 + gx, r - gy, r + 1.0 + gy, zmin,
                                     edges, reach, wmax) > d + margin * d * d + recede:
                    return False
    return True


@njit(cache=True, nogil=True, inline="always")
def _pixel_centres_behind(c, r, bound, zmin, width, edges, wmax, centres, depth, margin,
                          recede):
    """True when every pixel centre of the sw x sh screen within gsx, gsy buffer pixels of
    buffer pixel (c, r)'s square (the occluders' shift: the centres whose device occluder
    fragment may come from this pixel) either lies, grown by gmx, gmy, wholly outside an edge
    of the projected triangle (no fragment of the triangle there) or has the triangle's plane,
    over that grown box less `reach`, beyond `bound` (_plane_near) or beyond the pixel's edge
    record over the centre's box within gsx, gsy (hiz.edges.edge_bound: the occluder points
    the device may draw there all lie on the covered side of an occluder's outline; margin
    and recede as the bound has them). centres: _behind_shape's.
    The device draws and depth-tests at pixel centres only (no multisampling), so a triangle
    fragment at a centre s is hidden when it lies beyond every buffer pixel within the shift of
    s: the pairs (s, pixel) are those the whole-square test reads, minus the points of the
    square no fragment lies on. Errs toward False (a pixel with no such centre is True)."""
    sw, sh, height, gsx, gsy, gmx, gmy, reach = (centres[0], centres[1], centres[2],
                                                 centres[3], centres[4], centres[5],
                                                 centres[6], centres[7])
    fx, fy = sw / width, sh / height  # screen pixels per buffer pixel
    i0 = max(np.ceil((c - gsx) * fx - 0.5), 0.0)
    i1 = min(np.floor((c + 1.0 + gsx) * fx - 0.5), sw - 1.0)
    j0 = max(np.ceil((r - gsy) * fy - 0.5), 0.0)
    j1 = min(np.floor((r + 1.0 + gsy) * fy - 0.5), sh - 1.0)
    if not (i1 - i0 <= 64.0 and j1 - j0 <= 64.0):  # nan, or too many: the whole square
        return _plane_near(c - gsx - gmx, c + 1.0 + gsx + gmx, r - gsy - gmy,
                           r + 1.0 + gsy + gmy, zmin, edges, reach, wmax) > bound
    for j in range(int(j0), int(j1) + 1):
        yc = (j + 0.5) / fy
        for i in range(int(i0), int(i1) + 1):
            xc = (i + 0.5) / fx
            if _outside(xc - gmx, xc + gmx, yc - gmy, yc + gmy, edges):
                continue
            near = _plane_near(xc - gmx, xc + gmx, yc - gmy, yc + gmy, zmin, edges, reach, wmax)
            if not near > bound:
                if not (centres[8] > 0 and near > edge_bound(
                        depth, c, r, width, int(height), xc, yc, gsx, gsy, margin, recede,
                        GUARD_PX)):
                    return False
                centres[8] -= 1.0  # one rescue fewer left to this triangle
    return True


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
    edges = np.empty((4, 3))
    first = np.empty(2)
    centres = np.zeros(9)
    reach = np.sqrt(3.0) * move
    lateral = 2.0 + 2.0 * max(tx, ty) + shift  # bounds 1 + |x / z| over the screen and shift
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
        if r[6] == 0:
            hidden[k] = True
            continue
        # A point the device draws over a pixel projects, unmoved, within `spread` (x / z units)
        # of it: the occluders' shift and its own move, |d(x / z)| <= reach (1 + |x / z|) / z.
        spread = shift + reach * lateral / r[4]
        shaped = use and spread < 0.5 and _triangle_edges(cam, tx, ty, width, height, edges)
        wmax = 1.0 / min(cam[0, 2], cam[1, 2], cam[2, 2])
        gx = spread / tx * 0.5 * width + SLACK_PX
        gy = spread / ty * 0.5 * height + SLACK_PX
        if shaped and sw > 0:
            # The centres' test: the occluders' shift picks the centres, the points' own move
            # (the larger of the buffer's and the screen's) and the GPU's snapping grow each.
            own = np.sqrt(3.0) * max(move, sample_move)
            grow = own * lateral / r[4]
            snap_x = max(SAMPLE_SLACK_PX * width / sw, SLACK_PX)
            snap_y = max(SAMPLE_SLACK_PX * height / sh, SLACK_PX)
            centres[0], centres[1], centres[2] = sw, sh, height
            centres[3] = shift / tx * 0.5 * width + SLACK_PX
            centres[4] = shift / ty * 0.5 * height + SLACK_PX
            centres[5] = grow / tx * 0.5 * width + snap_x
            centres[6] = grow / ty * 0.5 * height + snap_y
            centres[7] = own
            centres[8] = EDGE_RESCUES
        else:
            centres[0] = 0.0
        if shaped:  # the projected centroid's tile first (a visible triangle fails soonest)
            first[0] = (cam[0, 0] / cam[0, 2] + cam[1, 0] / cam[1, 2] + cam[2, 0] / cam[2, 2]) \
                / (3.0 * tx) * 0.5 * width + 0.5 * width
            first[1] = (cam[0, 1] / cam[0, 2] + cam[1, 1] / cam[1, 2] + cam[2, 1] / cam[2, 2]) \
                / (3.0 * ty) * 0.5 * height + 0.5 * height
        if use and (_behind_shape(x0, x1, y0, y1, r[4], depth, width, tile_max, cols, tw, th,
                                  margin, recede, edges, gx, gy, reach, wmax, centres, first)
                    if shaped else
                    _behind(x0, x1, y0, y1, r[4], depth, width, tile_max,
                            (height + th - 1) // th, cols, tw, th, margin, recede)):
            hidden[k] = True
            continue
        if use and sw > 0:  # the wide rectangle failed: the pixels under the centres
            if not _centre_rect(cam, 3, tx, ty, width, height, sample_move, move, shift,
                                tile_shift, cols, tw, th, sw, sh, r):
                subpixel[k] = True  # no centre under its rectangle
                continue
            a0, a1, b0, b1 = int(r[0]), int(r[1]), int(r[2]), int(r[3])
            if (a0 != x0 or a1 != x1 or b0 != y0 or b1 != y1) and (
                    _behind_shape(a0, a1, b0, b1, r[4], depth, width, tile_max, cols, tw, th,
                                  margin, recede, edges, gx, gy, reach, wmax, centres, first)
                    if shaped else
                    _behind(a0, a1, b0, b1, r[4], depth, width, tile_max,
                            (height + th - 1) // th, cols, tw, th, margin, recede)):
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

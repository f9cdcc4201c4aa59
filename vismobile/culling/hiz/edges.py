"""Edge records of the tiled depth buffer (numba, cached on disk): where an occluder group's
boundary crosses a pixel, the part of the pixel on the group's side (issue 32).

A pixel is written only when one plane group wholly covers it, so along an occluder's outline
the buffer holds the farther surface behind it (or nothing), while the device draws the
occluder over the screen's centres on its side. hiz.rasterise records, for a pixel met by
exactly one boundary piece of a group (no crease piece, no near-plane cut, the piece itself
not cut), the group's plane and the piece's line: within the pixel's square (grown by SLACK_PX,
GUARD_PX wider at the screen's border, as the rasteriser marks it) no other piece of the
group's boundary passes, and the piece's ends lie outside it, so the piece crosses the square
and every point of the square on its inner side lies inside the group's union. The triangle
test (hiz.buffer._pixel_centres_behind) reads a record only at a screen centre whose box
(the occluders' shift) lies inside the square and wholly on the inner side: every occluder
point the device may draw there is the group's, no farther than its plane over the box.
The inner side is the side of the triangle's projected winding (pieces in corner order, an
uncut triangle not too thin to orient); a pixel offered several records keeps the nearest at
its centre; the test reads records at up to hiz.buffer.EDGE_RESCUES centres per triangle.
W2, 150 indoor frames at 240x320 (issue 32): sent 138.1 -> 135.3 a frame (MOC 137.5), 0
dropped (tools/bench_peers.py --moc; docs/culling-performance.md).

Layout. depth (H W,) holds the pixels' bounds; a longer depth (buffer_length) holds after them
  [P, 2P)           per pixel, the id of its record (inf: none), P = H W
  [2P]              records written since the buffer was cleared (inf: none)
  [2P + 1]          `half` of the rasterise calls (the squares the records hold over)
  [2P + 2 + 6k, +6) record k: (a, b, c) with 1 / z = a x + b y + c the group's bound at buffer
                    point (x, y) (its plane scaled by 1 / (1 + slack), as the pixel's bound),
                    and (ex, ey, ec) the piece's line, ex x + ey y + ec > 0 on its inner side
                    (not normalised).
Clearing the buffer (depth[:] = inf, every frame) clears the records; when the records are
full a pixel gets none (the test then reads its bound alone).
"""
from __future__ import annotations

import numpy as np
from numba import njit

HEADER = 2  # the count and `half`
RECORD = 6  # floats per record


def buffer_length(pixels: int, records: int) -> int:
    """Length of a depth buffer of `pixels` with room for `records` edge records."""
    return 2 * pixels + HEADER + RECORD * records


@njit(cache=True, nogil=True, inline="always")
def capacity(depth, pixels):
    """Records depth has room for (0: a bare buffer of bounds)."""
    return max((len(depth) - 2 * pixels - HEADER) // RECORD, 0)


@njit(cache=True, nogil=True, inline="always")
def add_record(depth, pixels, half, plane_a, plane_b, plane_c, ax, ay, bx, by, side):
    """Appends the record of the piece a -> b (buffer pixels) of a triangle whose inside lies
    to its left (side 1) or right (side -1), over a group with bound plane (plane_a, plane_b,
    plane_c); returns its id, or -1 when depth is full. The line is not normalised: a
    degenerate piece gives a zero line, which never holds a point inside (edge_bound)."""
    n = depth[2 * pixels]
    k = int(n) if n < np.inf else 0
    if k >= capacity(depth, pixels):
        return -1
    dx, dy = (bx - ax) * side, (by - ay) * side
    q = 2 * pixels + HEADER + RECORD * k
    depth[q], depth[q + 1], depth[q + 2] = plane_a, plane_b, plane_c
    depth[q + 3], depth[q + 4], depth[q + 5] = -dy, dx, dy * ax - dx * ay
    depth[2 * pixels] = k + 1.0
    depth[2 * pixels + 1] = half
    return k


@njit(cache=True, nogil=True, inline="always")
def set_record(depth, pixels, p, k, x, y):
    """Pixel p (centre x, y) takes record k, unless it holds one of this frame whose plane is
    nearer at its centre (each is sound; the nearer hides more)."""
    old = depth[pixels + p]
    if old < np.inf:
        q, r = 2 * pixels + HEADER + RECORD * int(old), 2 * pixels + HEADER + RECORD * k
        if depth[q] * x + depth[q + 1] * y + depth[q + 2] \
                >= depth[r] * x + depth[r + 1] * y + depth[r + 2]:
            return
    depth[pixels + p] = k


@njit(cache=True, nogil=True)
def edge_bound(depth, c, r, width, height, x, y, gx, gy, margin, recede, guard):
    """The bound, plus the 24-bit margin and recede as the tests add them, of every occluder
    point the device may draw at buffer point (x, y) from buffer pixel (c, r)'s edge record,
    the points within gx, gy of it (the occluders' shift and SLACK_PX): the record's plane
    over that box (1 / z affine: least at a corner, lowered by 2^-48 of the terms for float64
    rounding). inf when depth holds no record for the pixel, the box leaves the pixel's square
    (guard: GUARD_PX, wider at the border) or is not wholly on the inner side of the record's line.
    Errs large (module docstring)."""
    pixels = width * height
    if len(depth) < 2 * pixels + HEADER:
        return np.inf
    p = r * width + c
    k = depth[pixels + p]
    if not k < np.inf:
        return np.inf
    half = depth[2 * pixels + 1]
    x0 = c + 0.5 - half - (guard if c == 0 else 0.0)
    x1 = c + 0.5 + half + (guard if c == width - 1 else 0.0)
    y0 = r + 0.5 - half - (guard if r == 0 else 0.0)
    y1 = r + 0.5 + half + (guard if r == height - 1 else 0.0)
    if not (x - gx >= x0 and x + gx <= x1 and y - gy >= y0 and y + gy <= y1):
        return np.inf
    q = 2 * pixels + HEADER + RECORD * int(k)
    ex, ey, ec = depth[q + 3], depth[q + 4], depth[q + 5]
    inner = ex * x + ey * y + ec - abs(ex) * gx - abs(ey) * gy \
        - 2.0 ** -40 * (abs(ex * x) + abs(ey * y) + abs(ec))
    if not inner > 0:
        return np.inf
    a, b, cc = depth[q], depth[q + 1], depth[q + 2]
    ax, by, ag, bg = a * x, b * y, abs(a) * gx, abs(b) * gy
    w = ax + by + cc - ag - bg - 2.0 ** -48 * (abs(ax) + abs(by) + abs(cc) + ag + bg)
    if not w > 0:
        return np.inf
    z = 1.0 / w
    return z + margin * z * z + recede

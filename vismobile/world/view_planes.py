"""The camera's six frustum planes in one compiled call (numba, cached on disk): the same
formula as Camera.frustum_planes always had (the basis from yaw and pitch, the side planes
from the half angles' cosines and sines, unit normals in scalars), offsets as three products
summed in order, and optionally raised by a margin (culling/precision.conservative_planes).
Camera.frustum_planes and the Culler's conservative planes both come from here, so every
path of a frame sees the same bits (issue 32: the Python of the planes was 0.11 ms of a
1.3 ms W2 frame played after a render).
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True, nogil=True)
def view_planes(x, y, z, yaw, pitch, ch, sh, cv, sv, near, far, margin, limit):
    """(6, 4) float64 planes (n, d), unit inward n, inside where n.x + d >= 0, of the camera
    at (x, y, z) with yaw and pitch in degrees, (ch, sh, cv, sv) the cosines and sines of the
    horizontal and vertical half fields of view; order left, right, bottom, top, near, far.
    Each offset is then raised by `margin` (errs outward by it) and a plane whose raised
    offset exceeds `limit` in magnitude becomes the always-inside (0, 0, 0, 1) (margin 0 and
    limit inf: the camera's own planes). Exact up to a few ulps of |n||eye| + |d|."""
    yaw, pitch = math.radians(yaw), math.radians(pitch)
    cy, sy, cp, sp = math.cos(yaw), math.sin(yaw), math.cos(pitch), math.sin(pitch)
    fx, fy, fz = -sy * cp, sp, -cy * cp
    rx, ry, rz = cy, 0.0, -sy
    ux, uy, uz = ry * fz - rz * fy, rz * fx - rx * fz, rx * fy - ry * fx
    rows = np.empty((6, 3))
    rows[0, 0], rows[0, 1], rows[0, 2] = ch * rx + sh * fx, ch * ry + sh * fy, ch * rz + sh * fz
    rows[1, 0], rows[1, 1], rows[1, 2] = (-ch * rx + sh * fx, -ch * ry + sh * fy,
                                          -ch * rz + sh * fz)
    rows[2, 0], rows[2, 1], rows[2, 2] = cv * ux + sv * fx, cv * uy + sv * fy, cv * uz + sv * fz
    rows[3, 0], rows[3, 1], rows[3, 2] = (-cv * ux + sv * fx, -cv * uy + sv * fy,
                                          -cv * uz + sv * fz)
    rows[4, 0], rows[4, 1], rows[4, 2] = fx, fy, fz
    rows[5, 0], rows[5, 1], rows[5, 2] = -fx, -fy, -fz
    planes = np.empty((6, 4))
    for k in range(6):
        a, b, c = rows[k, 0], rows[k, 1], rows[k, 2]
        length = math.sqrt(a * a + b * b + c * c)
        a, b, c = a / length, b / length, c / length
        planes[k, 0], planes[k, 1], planes[k, 2] = a, b, c
        planes[k, 3] = -(a * x + b * y + c * z)
    planes[4, 3] -= near
    planes[5, 3] += far
    for k in range(6):
        planes[k, 3] += margin
        if abs(planes[k, 3]) > limit:
            planes[k, 0], planes[k, 1], planes[k, 2], planes[k, 3] = 0.0, 0.0, 0.0, 1.0
    return planes

"""Footprints in the ground plane: the convex hull and signed area of x-z polygons.

Both the horizon stage's solids (culling/horizon_solids.py) and the street PVS's proven
columns (partition/pvs_columns.py) describe a vertical block by its x-z footprint.
"""
from __future__ import annotations

import numpy as np


def convex_hull(points) -> np.ndarray:
    """(H, 2) convex hull of (P, 2) points, counter-clockwise (Andrew's monotone chain).

    Collinear points on the hull are left out; fewer than 3 distinct points come back as they
    are (sorted, duplicates removed), so callers test len(hull) < 3 for a degenerate footprint.
    """
    pts = np.unique(np.asarray(points, dtype=float), axis=0)
    if len(pts) < 3:
        return pts

    def half(seq):
        out = []
        for p in seq:
            while len(out) >= 2 and ((out[-1][0] - out[-2][0]) * (p[1] - out[-2][1])
                                     - (out[-1][1] - out[-2][1]) * (p[0] - out[-2][0])) <= 0:
                out.pop()
            out.append(p)
        return out[:-1]

    return np.array(half(pts) + half(pts[::-1]))


def polygon_area(poly) -> float:
    """Signed area of the (H, 2) polygon: positive when counter-clockwise."""
    x, z = poly[:, 0], poly[:, 1]
    return 0.5 * float(np.dot(x, np.roll(z, -1)) - np.dot(z, np.roll(x, -1)))

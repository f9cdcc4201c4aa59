"""Tiled rectangles with rectangular holes, oriented to a facing direction, and a mesh collector."""
from __future__ import annotations

import numpy as np

from ..world.world import World


def tiled_rect(origin, u, v, nu: int, nv: int, facing) -> tuple:
    """Rectangle origin + s*u + t*v (s, t in [0, 1]) cut into nu x nv quads, two triangles each.

    Returns (vertices (V,3) float64, triangles (2*nu*nv, 3) int32) with counter-clockwise
    winding seen from the `facing` side, so the front face points along `facing`.
    """
    origin, u, v = (np.asarray(a, dtype=np.float64) for a in (origin, u, v))
    s = np.linspace(0.0, 1.0, nu + 1)
    t = np.linspace(0.0, 1.0, nv + 1)
    grid_s, grid_t = np.meshgrid(s, t, indexing="ij")  # (nu+1, nv+1)
    vertices = origin + grid_s.reshape(-1, 1) * u + grid_t.reshape(-1, 1) * v
    i, j = np.meshgrid(np.arange(nu), np.arange(nv), indexing="ij")
    a = (i * (nv + 1) + j).ravel()
    b, c, d = a + (nv + 1), a + (nv + 2), a + 1
    triangles = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])
    if np.dot(np.cross(u, v), facing) < 0:
        triangles = triangles[:, ::-1]
    return vertices, triangles.astype(np.int32)


def holed_rect(origin, u_dir, v_dir, length: float, height: float, holes, tile: float,
               facing) -> tuple:
    """Rectangle [0, length] x [0, height] in the (u_dir, v_dir) frame minus rectangular holes.

    holes : sequence of (u0, u1, v0, v1) in metres, inside the rectangle and not overlapping.
    The remainder is split into columns at the hole edges, each column into spans between
    holes, each span tiled with quads of side at most `tile`. Returns (vertices, triangles).
    """
    u_dir, v_dir = np.asarray(u_dir, float), np.asarray(v_dir, float)
    cuts = sorted({0.0, float(length), *(h[0] for h in holes), *(h[1] for h in holes)})
    parts = []
    for ua, ub in zip(cuts[:-1], cuts[1:]):
        if ub - ua < 1e-9:
            continue
        spans = sorted((h[2], h[3]) for h in holes if h[0] <= ua + 1e-9 and h[1] >= ub - 1e-9)
        bottom = 0.0
        for v0, v1 in spans + [(float(height), float(height))]:
            if v0 - bottom > 1e-9:
                parts.append(tiled_rect(np.asarray(origin) + ua * u_dir + bottom * v_dir,
                                        (ub - ua) * u_dir, (v0 - bottom) * v_dir,
                                        int(np.ceil((ub - ua) / tile - 1e-9)),
                                        int(np.ceil((v0 - bottom) / tile - 1e-9)), facing))
            bottom = v1
    return merge(parts)


def merge(parts) -> tuple:
    """Concatenate (vertices, triangles) pairs into one pair."""
    if not parts:
        return np.zeros((0, 3)), np.zeros((0, 3), np.int32)
    offsets = np.cumsum([0] + [len(p[0]) for p in parts[:-1]])
    return (np.concatenate([p[0] for p in parts]),
            np.concatenate([p[1] + o for p, o in zip(parts, offsets)]).astype(np.int32))


def quad(corners, facing) -> tuple:
    """One planar quad from 4 corners in order around it, as two triangles facing `facing`."""
    corners = np.asarray(corners, dtype=np.float64)
    return tiled_rect(corners[0], corners[1] - corners[0], corners[3] - corners[0], 1, 1, facing)


def fan_split(vertices, triangles, quads: int) -> tuple:
    """Turn the first `quads` quads (triangle pairs 2k, 2k+1 of a tiled_rect) into 4-triangle fans.

    Adds exactly 2 triangles per quad, keeping the winding and the covered area.
    """
    vertices = np.asarray(vertices, float)
    if quads <= 0:
        return vertices, triangles
    half = len(triangles) // 2
    if quads > half:
        raise ValueError(f"cannot fan-split {quads} quads of a {half}-quad surface")
    first, second = triangles[:quads], triangles[half:half + quads]  # (a,b,c), (a,c,d) or flipped
    a, b, c = first[:, 0], first[:, 1], first[:, 2]
    d = second.sum(axis=1) - a - c  # the corner of the second triangle not on the diagonal
    centre_ids = len(vertices) + np.arange(quads)
    centres = vertices[np.stack([a, b, c, d], 1)].mean(axis=1)
    fans = np.concatenate([np.stack([a, b, centre_ids], 1), np.stack([b, c, centre_ids], 1),
                           np.stack([c, d, centre_ids], 1), np.stack([d, a, centre_ids], 1)])
    keep = np.ones(len(triangles), bool)
    keep[:quads] = False
    keep[half:half + quads] = False
    return (np.concatenate([vertices, centres]),
            np.concatenate([triangles[keep], fans]).astype(np.int32))


class MeshCollector:
    """Gathers named parts; parts with the same name become one OBJ object."""

    def __init__(self):
        self.parts = []  # (vertices, triangles, object name)
        self.names = {}

    def add(self, name: str, vertices, triangles) -> None:
        if len(triangles):
            self.names.setdefault(name, len(self.names))
            self.parts.append((np.asarray(vertices, float), np.asarray(triangles, np.int32), name))

    @property
    def triangle_count(self) -> int:
        return sum(len(p[1]) for p in self.parts)

    def world(self, name: str) -> World:
        vertices, triangles = merge([(p[0], p[1]) for p in self.parts])
        ids = np.concatenate([np.full(len(p[1]), self.names[p[2]], np.int32) for p in self.parts])
        return World(vertices, triangles, ids, list(self.names), name)

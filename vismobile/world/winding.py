"""Winding of a world's triangles: consistency across shared edges, closed rooms seen from inside.

Front faces are counter-clockwise (OpenGL), so back-face culling (`bfc`, `cbfc`, `cone`,
`tbfc`) removes every triangle whose winding points away from the eye. A mesh whose triangles
disagree with their neighbours, or a closed room whose walls face outward (trimesh's boxes do),
loses walls to back-face culling. check_winding() measures this; fixed_world() repairs it.

Topology is read after merging coincident vertices (to 2^-36 of the world's size): an edge
used by one triangle is open (a boundary), by three or more non-manifold, by two a manifold
edge whose triangles agree when they run along it in opposite directions. Triangles joined by
manifold edges form components; each is oriented consistently by a union-find with parity
(numba; trimesh.repair.fix_winding would need networkx), keeping the orientation most of its
triangles already have. A closed component (no open or non-manifold edge) has an inside: one
whose box spans the whole world's box is taken for a room seen from inside and turned to face
its interior (when eye positions are given, only if most of them lie in its box: a lone closed
object looked at from outside stays a solid); any other closed component is a solid seen from
outside and turned to face out.
Open components keep the orientation most of their triangles have (they have no inside).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

# Vertices closer than this fraction of the world's largest extent are one vertex.
MERGE_RELATIVE = 2.0 ** -36
# A component's box spans the world's box when every side is within this fraction of the size.
SPAN_RELATIVE = 1e-6


@njit(cache=True)
def _find(parent, parity, x):
    """Root of x and x's parity relative to it, compressing the path."""
    p = 0
    r = x
    while parent[r] != r:
        p ^= parity[r]
        r = parent[r]
    y, py = x, p
    while parent[y] != y:
        nxt = parent[y]
        pn = py ^ parity[y]
        parent[y] = r
        parity[y] = py
        y, py = nxt, pn
    return r, p


@njit(cache=True)
def _orient(count, face_a, face_b, same):
    """Union-find with parity over manifold edges: (root (T,) int64, flip (T,) uint8, conflicts).

    same[k] = 1 when faces face_a[k] and face_b[k] run along their shared edge in the same
    direction (one must flip). flip[f] = 1 when f must be reversed to agree with its root.
    conflicts counts edges no orientation can satisfy (a non-orientable surface).
    """
    parent = np.arange(count)
    parity = np.zeros(count, np.uint8)
    conflicts = 0
    for k in range(len(face_a)):
        ra, pa = _find(parent, parity, face_a[k])
        rb, pb = _find(parent, parity, face_b[k])
        if ra == rb:
            if (pa ^ pb) != same[k]:
                conflicts += 1
        else:
            parent[rb] = ra
            parity[rb] = pa ^ pb ^ same[k]
    root = np.empty(count, np.int64)
    flip = np.empty(count, np.uint8)
    for f in range(count):
        root[f], flip[f] = _find(parent, parity, f)
    return root, flip, conflicts


@dataclass(eq=False)
class WindingReport:
    """What check_winding found; counts are of triangles (faces) or of distinct edges.

    flip : (T,) bool, the triangles fixed_world() reverses
    """

    triangles: int
    inconsistent_edges: int      # manifold edges whose two triangles run the same way
    inconsistent_faces: int      # triangles against their component's majority
    conflicts: int               # edges no orientation satisfies (non-orientable)
    open_edges: int
    nonmanifold_edges: int
    components: int
    rooms: int                   # closed components spanning the world's box
    room_faces: int
    room_faces_outward: int      # room triangles facing away from its interior
    solids: int                  # other closed components
    solid_faces_inward: int      # solid triangles facing into the solid
    flip: np.ndarray

    @property
    def consistent(self) -> bool:
        return self.inconsistent_edges == 0

    @property
    def to_fix(self) -> int:
        """Triangles fixed_world() reverses."""
        return int(self.flip.sum())

    def lines(self) -> list:
        """Human-readable lines for `vismobile info`."""
        out = [("consistent: every shared edge is run in opposite directions" if self.consistent
                else f"{self.inconsistent_edges:,} shared edges run the same way by both "
                     f"triangles; {self.inconsistent_faces:,} triangles wound against their "
                     "neighbours")
               + (f"; {self.conflicts:,} edges cannot agree (non-orientable)"
                  if self.conflicts else "")]
        closed = self.rooms + self.solids
        out.append(f"{self.components:,} connected parts, {closed:,} closed "
                   f"({self.rooms} room(s) spanning the world, {self.solids:,} solid(s)); "
                   f"{self.open_edges:,} open (boundary) edges, {self.nonmanifold_edges:,} "
                   "non-manifold edges")
        if self.rooms:
            out.append(f"rooms: {self.room_faces_outward:,} of {self.room_faces:,} triangles face "
                       "away from the interior"
                       + (" (seen from inside, back-face culling removes them)"
                          if self.room_faces_outward else ""))
        if self.solid_faces_inward:
            out.append(f"solids: {self.solid_faces_inward:,} triangles face into their solid "
                       "(seen from outside, back-face culling removes them)")
        if self.to_fix:
            out.append(f"--fix-winding reverses {self.to_fix:,} triangles")
        return out


def _merged(world) -> np.ndarray:
    """(T, 3) int64 triangle corners as indices of merged (coincident) vertices."""
    low, high = world.extent
    quantum = max(float((high - low).max()), 1e-300) * MERGE_RELATIVE
    keys = np.round((world.vertices - low) / quantum)
    _, inverse = np.unique(keys, axis=0, return_inverse=True)
    return inverse.reshape(-1)[world.triangles].astype(np.int64)


def check_winding(world, eyes=None) -> WindingReport:
    """Measure a world's winding (see the module docstring); vectorised but for the
    union-find, which is one compiled pass over the manifold edges.

    eyes : optional (N, 3) camera positions (a trajectory's); a closed component spanning the
           world is a room only if most of them lie in its box
    """
    t = _merged(world)
    count = len(t)
    degenerate = (t[:, 0] == t[:, 1]) | (t[:, 1] == t[:, 2]) | (t[:, 2] == t[:, 0])
    directed = np.stack([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]], axis=1).reshape(-1, 2)
    edge_face = np.repeat(np.arange(count), 3)
    usable = ~np.repeat(degenerate, 3)
    directed, edge_face = directed[usable], edge_face[usable]
    ends = np.sort(directed, axis=1)
    size = int(t.max()) + 1 if count else 1
    key = ends[:, 0] * size + ends[:, 1]
    order = np.argsort(key, kind="stable")
    key_sorted = key[order]
    starts = np.flatnonzero(np.r_[True, key_sorted[1:] != key_sorted[:-1]])
    uses = np.diff(np.r_[starts, len(key_sorted)])
    open_edges = int((uses == 1).sum())
    nonmanifold_edges = int((uses > 2).sum())
    pairs = starts[uses == 2]
    a, b = order[pairs], order[pairs + 1]
    same = (directed[a, 0] == directed[b, 0]).astype(np.uint8)
    face_a, face_b = edge_face[a], edge_face[b]
    root, flip, conflicts = _orient(count, face_a, face_b, same)
    _, label = np.unique(root, return_inverse=True)
    label = label.reshape(-1)
    parts = int(label.max()) + 1 if count else 0
    # Keep each component's majority orientation (fewest triangles reversed).
    sizes = np.bincount(label, minlength=parts)
    flipped = np.bincount(label, weights=flip, minlength=parts)
    flip = flip.astype(bool) ^ (2 * flipped > sizes)[label]
    # Closed: no open or non-manifold edge, no degenerate triangle.
    bad = np.zeros(parts, bool)
    bad_edges = np.repeat(uses != 2, uses)  # per sorted directed edge
    bad[label[edge_face[order[bad_edges]]]] = True
    bad[label[degenerate]] = True
    closed = ~bad
    # Signed volume of each component as consistently oriented (centred for precision).
    low, high = world.extent
    corners = world.corners - (low + high) / 2
    volume = np.einsum("ij,ij->i", corners[:, 0], np.cross(corners[:, 1], corners[:, 2])) / 6
    signed = np.bincount(label, weights=np.where(flip, -volume, volume), minlength=parts)
    # Rooms: closed components whose box spans the world's box.
    by = np.argsort(label, kind="stable")
    first = np.flatnonzero(np.r_[True, label[by][1:] != label[by][:-1]]) if count else by
    box_low = np.minimum.reduceat(world.bounds[by, 0], first, axis=0) if count else np.zeros((0, 3))
    box_high = np.maximum.reduceat(world.bounds[by, 1], first, axis=0) if count else box_low
    tol = max(float((high - low).max()), 1e-300) * SPAN_RELATIVE
    spans = (box_low <= low + tol).all(axis=1) & (box_high >= high - tol).all(axis=1)
    if eyes is not None and len(eyes):
        eyes = np.asarray(eyes, dtype=np.float64).reshape(-1, 3)
        within = ((eyes[None] >= box_low[:, None] - tol) & (eyes[None] <= box_high[:, None] + tol)
                  ).all(axis=2).mean(axis=1)
        spans &= within >= 0.5
    room = closed & spans
    solid = closed & ~spans
    invert = (room & (signed > 0)) | (solid & (signed < 0))
    flip = flip ^ invert[label]
    in_room, in_solid = room[label], solid[label]
    return WindingReport(
        triangles=count, inconsistent_edges=int(same.sum()),
        inconsistent_faces=int((flip ^ invert[label]).sum()), conflicts=int(conflicts),
        open_edges=open_edges, nonmanifold_edges=nonmanifold_edges, components=parts,
        rooms=int(room.sum()), room_faces=int(in_room.sum()),
        room_faces_outward=int((flip & in_room).sum()), solids=int(solid.sum()),
        solid_faces_inward=int((flip & in_solid).sum()), flip=flip)


def fixed_world(world, report: WindingReport | None = None, eyes=None):
    """(World with the triangles check_winding flags reversed, the report of the input);
    eyes as in check_winding."""
    from .world import World

    report = check_winding(world, eyes) if report is None else report
    if not report.to_fix:
        return world, report
    triangles = world.triangles.copy()
    triangles[report.flip] = triangles[report.flip][:, ::-1]
    return World(world.vertices, triangles, world.object_ids, list(world.object_names),
                 world.name), report


def fixed_world_said(world, eyes=None, stream=None):
    """fixed_world(world, eyes=eyes)[0], saying on stream (stderr) how many triangles it
    reversed: what every command's --fix-winding prints."""
    import sys

    fixed, report = fixed_world(world, eyes=eyes)
    print(f"--fix-winding: reversed {report.to_fix:,} of {report.triangles:,} triangles",
          file=sys.stderr if stream is None else stream)
    return fixed

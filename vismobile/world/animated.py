"""A world whose objects move: a rest-pose World plus a Motion (motion.py). Triangle ids never
change; `posed(t)` moves only the moving objects' vertices.

Each moving object gets its own copy of the vertices its triangles use, appended after the rest
world's vertices (so a vertex an OBJ shares between a static and a moving object, or between
two moving objects, moves with one object only); `world` is the rest pose with those copies.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from ..errors import WorldError
from .motion import Motion, Track
from .world import World

BOX_PAD = 2.0 ** -40  # relative pad on a moved box: its corners and the vertices round apart


@dataclass(eq=False, repr=False)
class PosedWorld(World):
    """A World sharing its rest world's static rows: derived arrays copied from `rest` and
    recomputed only for the `moving` triangle ids."""

    rest: World | None = None
    moving: np.ndarray | None = None

    def _derive(self):
        if self.rest is None:
            return super()._derive()
        rest, ids = self.rest, self.moving
        corners = self.vertices[self.triangles[ids]]
        self.corners = rest.corners.copy()
        self.corners[ids] = corners
        from .world import unit_normals

        normals, length = unit_normals(corners)
        self.normals = rest.normals.copy()
        self.normals[ids] = normals
        self.areas = rest.areas.copy()
        self.areas[ids] = 0.5 * length
        self.bounds = rest.bounds.copy()
        self.bounds[ids] = np.stack([corners.min(axis=1), corners.max(axis=1)], axis=1)
        self.centroids = rest.centroids.copy()
        self.centroids[ids] = corners.mean(axis=1)


class AnimatedWorld:
    """A rest-pose world and the motion of some of its objects.

    world            : World, the rest pose (moving objects on their own vertex copies)
    motion           : Motion
    moving_mask      : (T,) bool, triangles of moving objects
    moving_object_ids: (M,) int64, motion's object ids (track order)
    moving_triangles : (Tm,) int64 their triangle ids, grouped by track (tri_start (M+1,))
    rest_vertices    : (Vm,) x 3 float64 the moving vertices at rest, grouped by track
                       (vertex_start (M+1,)); world.vertices[base:] are the same rows
    local_triangles  : (Tm, 3) int64 moving triangles' corners as rows of rest_vertices
    rest_boxes       : (M, 2, 3) float64 each moving object's rest box
    """

    def __init__(self, world: World, motion: Motion):
        ids = motion.object_ids
        count = len(world.object_names)
        if len(ids) and (ids.min() < 0 or ids.max() >= count):
            raise ValueError(f"motion names object ids outside the world's {count} objects")
        self.motion = motion
        self.name = world.name
        track_of = np.full(max(count, 1), -1, dtype=np.int64)
        track_of[ids] = np.arange(len(ids))
        self.moving_mask = track_of[world.object_ids] >= 0
        tris = np.flatnonzero(self.moving_mask)
        track = track_of[world.object_ids[tris]]
        order = np.lexsort((tris, track))
        self.moving_triangles, track = tris[order], track[order]
        m = len(ids)
        self.tri_start = np.searchsorted(track, np.arange(m + 1)).astype(np.int64)
        base = len(world.vertices)
        key = track[:, None] * base + world.triangles[self.moving_triangles].astype(np.int64)
        unique, inverse = np.unique(key, return_inverse=True)
        self.local_triangles = inverse.reshape(-1, 3).astype(np.int64)
        self.vertex_track = unique // max(base, 1)
        self.vertex_start = np.searchsorted(self.vertex_track, np.arange(m + 1)).astype(np.int64)
        self.rest_vertices = np.ascontiguousarray(world.vertices[unique % max(base, 1)])
        self.base = base
        triangles = world.triangles.copy()
        triangles[self.moving_triangles] = base + self.local_triangles
        self.world = World(np.concatenate([world.vertices, self.rest_vertices]), triangles,
                           world.object_ids, list(world.object_names), world.name)
        lo = np.full((m, 3), np.inf)
        hi = np.full((m, 3), -np.inf)
        has = np.diff(self.vertex_start) > 0
        if has.any():
            starts = self.vertex_start[:-1][has]
            lo[has] = np.minimum.reduceat(self.rest_vertices, starts, axis=0)
            hi[has] = np.maximum.reduceat(self.rest_vertices, starts, axis=0)
        lo[~has] = hi[~has] = 0.0  # an object without triangles: a point box, never drawn
        self.rest_boxes = np.stack([lo, hi], axis=1)
        self.static_ids = np.flatnonzero(~self.moving_mask)
        self._static_world = None

    @property
    def moving_object_ids(self) -> np.ndarray:
        return self.motion.object_ids

    @property
    def triangle_count(self) -> int:
        return self.world.triangle_count

    def __repr__(self) -> str:
        return (f"AnimatedWorld({self.name!r}: {self.world.triangle_count:,} triangles, "
                f"{len(self.motion):,} moving objects with {len(self.moving_triangles):,} "
                f"triangles)")

    def static_world(self) -> World:
        """World of the triangles that never move (ids renumbered 0..S-1; static_ids maps
        them back), sharing the vertex array; made once."""
        if self._static_world is None:
            self._static_world = self.world.subset(self.static_ids)
        return self._static_world

    def matrices(self, t, out=None) -> np.ndarray:
        """(M, 4, 4) float64 the moving objects' matrices at time t (None: identity, the rest
        pose); out: an (M, 4, 4) float64 array to fill."""
        if t is None:
            out = np.empty((len(self.motion), 4, 4)) if out is None else out
            out[:] = np.eye(4)
            return out
        return self.motion.matrices(t, out)[1]

    def posed_vertices(self, matrices, tracks=None) -> np.ndarray:
        """(Vm, 3) float64 the moving vertices under matrices (M, 4, 4); tracks (k,) int64: only
        those objects' rows are written (the others are left unset), None: all."""
        out = np.empty_like(self.rest_vertices)
        tracks = np.arange(len(self.motion)) if tracks is None else tracks
        transform_rows(self.rest_vertices, self.vertex_start,
                       np.ascontiguousarray(matrices, dtype=np.float64),
                       np.ascontiguousarray(tracks, dtype=np.int64), out)
        return out

    def posed(self, t) -> World:
        """The world at time t: the same triangle ids, the moving objects' vertices moved (only
        their rows computed; static derived rows copied from the rest world)."""
        vertices = self.world.vertices.copy()
        vertices[self.base:] = self.posed_vertices(self.matrices(t))
        return PosedWorld(vertices, self.world.triangles, self.world.object_ids,
                          list(self.world.object_names), self.world.name, rest=self.world,
                          moving=self.moving_triangles)

    def bounds_at(self, t) -> tuple:
        """(object ids (M,) int64, boxes (M, 2, 3) float64) each moving object's box at time t:
        its rest box's corners moved, padded outward by BOX_PAD relative: holds every vertex
        of the object at t (an affine map keeps points inside the image of their box)."""
        return self.motion.object_ids, moved_boxes(self.rest_boxes, self.matrices(t))

    @classmethod
    def from_motion_file(cls, world: World, path) -> "AnimatedWorld":
        """world with the paths of a JSON motion file (files/motionfile.py) attached to its
        objects by name. Raises WorldError naming the file on bad input or unknown names."""
        from ..files.motionfile import read_motion

        fps, entries = read_motion(path)
        index = {name: i for i, name in enumerate(world.object_names)}
        tracks = []
        for name, entry in entries.items():
            if name not in index:
                known = ", ".join(list(world.object_names)[:5])
                raise WorldError(path, f"object {name!r} is not in world {world.name!r} "
                                       f"(its objects: {known}, ...)")
            oid = index[name]
            pivot = entry.pop("pivot", None)
            if pivot is None:
                corners = world.corners[world.object_ids == oid].reshape(-1, 3)
                pivot = (corners.min(axis=0) + corners.max(axis=0)) / 2 if len(corners) \
                    else np.zeros(3)
            tracks.append(Track(oid, pivot=tuple(pivot), **entry))
        try:
            motion = Motion(tracks, fps=fps)
        except ValueError as error:
            raise WorldError(path, str(error)) from None
        return cls(world, motion)

    @classmethod
    def from_gltf(cls, path) -> "AnimatedWorld":
        """The meshes of a glTF/GLB file and its first animation's node channels
        (files/gltf_anim.py). Raises WorldError naming the file on bad input."""
        from ..files.gltf_anim import read_animated_gltf

        vertices, triangles, object_ids, names, tracks = read_animated_gltf(path)
        world = World.from_arrays(vertices, triangles, object_ids, names, path)
        try:
            motion = Motion([Track(**track) for track in tracks])
        except ValueError as error:
            raise WorldError(path, str(error)) from None
        return cls(world, motion)


@njit(cache=True, nogil=True)
def transform_rows(rest, start, matrices, tracks, out):
    """out[v] = M_k (rest[v], 1) for v in start[k]:start[k+1], for each k in tracks."""
    for i in range(len(tracks)):
        k = tracks[i]
        m = matrices[k]
        for v in range(start[k], start[k + 1]):
            x, y, z = rest[v, 0], rest[v, 1], rest[v, 2]
            for r in range(3):
                out[v, r] = m[r, 0] * x + m[r, 1] * y + m[r, 2] * z + m[r, 3]


@njit(cache=True, nogil=True, inline="always")
def _move_box(box, m, pad, out):
    """out (2, 3) = the box (2, 3) under the affine m (4, 4): per row the extreme corners (min
    and max of each term), grown by pad times the row's largest magnitude."""
    for r in range(3):
        lo, hi, mag = m[r, 3], m[r, 3], abs(m[r, 3])
        for c in range(3):
            a, b = m[r, c] * box[0, c], m[r, c] * box[1, c]
            lo += min(a, b)
            hi += max(a, b)
            mag += max(abs(a), abs(b))
        out[0, r] = lo - pad * mag
        out[1, r] = hi + pad * mag


@njit(cache=True, nogil=True)
def _moved_boxes(boxes, matrices, pad, out):
    """out (M, 2, 3) = moved_boxes; returns the largest |coordinate| of out."""
    most = 0.0
    for k in range(len(boxes)):
        _move_box(boxes[k], matrices[k], pad, out[k])
        for r in range(3):
            most = max(most, abs(out[k, 0, r]), abs(out[k, 1, r]))
    return most


def moved_boxes(boxes, matrices) -> np.ndarray:
    """(M, 2, 3) float64 boxes (M, 2, 3) under affine matrices (M, 4, 4): the box of the moved
    corners (per row, the sum of each term's extremes), padded by BOX_PAD times the row's
    magnitude, so float64 rounding of the moved vertices stays inside."""
    out = np.empty((len(boxes), 2, 3))
    _moved_boxes(np.ascontiguousarray(boxes, dtype=np.float64),
                 np.ascontiguousarray(matrices, dtype=np.float64), BOX_PAD, out)
    return out

"""Keyframe motion of a world's objects: per-object translation, rotation and scale tracks
sampled at a time t into one 4x4 matrix per moving object.

The matrix of an object maps its REST-POSE world coordinates (the world as loaded) to where
they stand at time t:

    M(t) = post @ T(translation(t)) @ R(rotation(t)) @ S(scale(t)) @ pre

`pre` and `post` are fixed per object. For a motion file (files/motionfile.py) they are
translate(-pivot) and translate(pivot), the tracks say how far the object moved from its rest
pose and how it turned about its pivot (by default its rest box's centre). For a glTF node
animation (files/gltf_anim.py) post is the animated node's parent transform and pre the inverse
of the parent's transform times the node's rest TRS, so the tracks are the node's own TRS.

Sampling: 'linear' interpolates translation and scale linearly and rotation by slerp
(shortest arc), 'step' holds each key until the next. Before the first key a channel holds its
first value. Past a track's last key (the last key time over its channels, its duration) a
track with `loop` starts again (t modulo the duration), one without it holds its last values
(clamp). A channel without keys holds its neutral value (no move, no turn, unit scale).

All tracks live in flat arrays (CSR per channel: key times, values, per-object offsets) and one
numba kernel samples every object, so a frame costs O(objects x log keys), no Python loop.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

CHANNELS = ("translation", "rotation", "scale")
WIDTH = {"translation": 3, "rotation": 4, "scale": 3}
NEUTRAL = {"translation": (0.0, 0.0, 0.0), "rotation": (0.0, 0.0, 0.0, 1.0),
           "scale": (1.0, 1.0, 1.0)}
INTERPOLATIONS = ("linear", "step")
MAX_KEYS = 1 << 24  # keys over every track and channel: bounded memory for a read file


@dataclass
class Track:
    """One object's keyframes. Each channel is None or (times (K,) float64 seconds, strictly
    increasing; values (K, 3) for translation and scale, (K, 4) quaternions x, y, z, w for
    rotation, normalised here). interpolation: 'linear' or 'step'; loop: repeat past the last
    key (else clamp). pivot (3,): the point rotation and scale turn about (pre/post when None);
    pre, post: (4, 4) float64 fixed matrices (module docstring), overriding pivot."""

    object_id: int
    translation: tuple | None = None
    rotation: tuple | None = None
    scale: tuple | None = None
    interpolation: str = "linear"
    loop: bool = False
    pivot: tuple = (0.0, 0.0, 0.0)
    pre: np.ndarray | None = None
    post: np.ndarray | None = None


def _check_channel(name, channel, object_id) -> tuple:
    times = np.asarray(channel[0], dtype=np.float64).reshape(-1)
    values = np.asarray(channel[1], dtype=np.float64)
    width = WIDTH[name]
    if values.ndim != 2 or values.shape != (len(times), width):
        raise ValueError(f"object {object_id}: {name} needs {len(times)} keys of {width} "
                         f"values, got shape {values.shape}")
    if not (np.isfinite(times).all() and np.isfinite(values).all()):
        raise ValueError(f"object {object_id}: {name} has a NaN or infinite key")
    if len(times) and np.any(np.diff(times) <= 0):
        raise ValueError(f"object {object_id}: {name} key times must be strictly increasing")
    if name == "rotation" and len(values):
        norm = np.linalg.norm(values, axis=1)
        if np.any(norm < 1e-12):
            raise ValueError(f"object {object_id}: rotation has a zero quaternion")
        values = values / norm[:, None]
    return times, values


class Motion:
    """Keyframe tracks of a set of objects (Track list; one track per object id).

    object_ids : (M,) int64 the moving objects, in track order
    duration   : (M,) float64 each track's last key time (0 for a track without keys)
    loop       : (M,) bool
    pre, post  : (M, 4, 4) float64
    fps        : frames per second of a trajectory played with it (t = frame / fps)
    """

    def __init__(self, tracks, fps: float = 30.0):
        tracks = list(tracks)
        ids = np.array([int(t.object_id) for t in tracks], dtype=np.int64)
        if len(np.unique(ids)) != len(ids):
            raise ValueError("one track per object: an object id repeats")
        if not (np.isfinite(fps) and fps > 0):
            raise ValueError(f"fps must be positive, got {fps}")
        self.fps = float(fps)
        self.object_ids = ids
        m = len(tracks)
        self.loop = np.array([bool(t.loop) for t in tracks], dtype=np.bool_)
        self.step = np.zeros(m, dtype=np.bool_)
        self.pre = np.tile(np.eye(4), (m, 1, 1))
        self.post = np.tile(np.eye(4), (m, 1, 1))
        self.duration = np.zeros(m)
        self.channels = {}
        per = {name: [] for name in CHANNELS}
        total = 0
        for k, track in enumerate(tracks):
            if track.interpolation not in INTERPOLATIONS:
                raise ValueError(f"object {track.object_id}: interpolation "
                                 f"{track.interpolation!r}; valid: {', '.join(INTERPOLATIONS)}")
            self.step[k] = track.interpolation == "step"
            pivot = np.asarray(track.pivot, dtype=np.float64).reshape(3)
            self.pre[k, :3, 3], self.post[k, :3, 3] = -pivot, pivot
            for name, matrix in (("pre", track.pre), ("post", track.post)):
                if matrix is not None:
                    matrix = np.asarray(matrix, dtype=np.float64)
                    if matrix.shape != (4, 4) or not np.isfinite(matrix).all():
                        raise ValueError(f"object {track.object_id}: {name} must be a finite "
                                         "4x4 matrix")
                    getattr(self, name)[k] = matrix
            for name in CHANNELS:
                channel = getattr(track, name)
                if channel is None:
                    per[name].append((np.zeros(0), np.zeros((0, WIDTH[name]))))
                    continue
                times, values = _check_channel(name, channel, track.object_id)
                total += len(times)
                if total > MAX_KEYS:
                    raise ValueError(f"more than {MAX_KEYS:,} keys")
                per[name].append((times, values))
                if len(times):
                    self.duration[k] = max(self.duration[k], times[-1])
        # pre and post affine (last row 0 0 0 1) is required; pure translations take a short cut
        for name, matrices in (("pre", self.pre), ("post", self.post)):
            if not np.allclose(matrices[:, 3], [0, 0, 0, 1], rtol=0, atol=0):
                raise ValueError(f"{name} matrices must be affine (last row 0 0 0 1)")
        eye = np.eye(3)
        self.simple = (np.all(self.pre[:, :3, :3] == eye, axis=(1, 2))
                       & np.all(self.post[:, :3, :3] == eye, axis=(1, 2)))
        for name in CHANNELS:
            counts = np.array([len(t) for t, _ in per[name]], dtype=np.int64)
            start = np.zeros(m + 1, dtype=np.int64)
            np.cumsum(counts, out=start[1:])
            times = np.concatenate([t for t, _ in per[name]]) if m else np.zeros(0)
            values = (np.concatenate([v for _, v in per[name]]) if m
                      else np.zeros((0, WIDTH[name])))
            self.channels[name] = (np.ascontiguousarray(times, dtype=np.float64),
                                   np.ascontiguousarray(values, dtype=np.float64).reshape(
                                       -1, WIDTH[name]), start)

        self.arc = _arcs(self.channels["rotation"][1])
        self._all = np.arange(m, dtype=np.int64)
        self.records = pose_records(self)

    def __len__(self) -> int:
        return len(self.object_ids)

    def __repr__(self) -> str:
        longest = float(self.duration.max()) if len(self) else 0.0
        return (f"Motion({len(self):,} moving objects, {int(self.loop.sum()):,} looping, "
                f"longest {longest:g} s, {self.fps:g} fps)")

    def local_time(self, t: float) -> np.ndarray:
        """(M,) float64 each track's own time: t modulo its duration when it loops."""
        t = float(t)
        if not np.isfinite(t):
            raise ValueError(f"time must be finite, got {t}")
        out = np.full(len(self), t)
        wrap = self.loop & (self.duration > 0)
        out[wrap] = np.mod(t, self.duration[wrap])
        return out

    def sample(self, t: float) -> dict:
        """{channel: (M, width) float64 values at time t} (module docstring's rules)."""
        local = self.local_time(t)
        out = {}
        for name in CHANNELS:
            times, values, start = self.channels[name]
            result = np.empty((len(self), WIDTH[name]))
            _sample(times, values, start, local, self.step, name == "rotation",
                    np.asarray(NEUTRAL[name], dtype=np.float64), result)
            out[name] = result
        return out

    def matrices(self, t: float, out=None, rows=None) -> tuple:
        """(object ids (M,) int64, matrices (M, 4, 4) float64) mapping each moving object's
        rest-pose coordinates to its pose at time t (module docstring); one compiled pass
        (out: an (M, 4, 4) float64 array to fill, else a new one; rows: (k,) int64 tracks, only
        their matrices written)."""
        t = float(t)
        if not np.isfinite(t):
            raise ValueError(f"time must be finite, got {t}")
        out = np.empty((len(self), 4, 4)) if out is None else out
        c = self.channels
        rows = self._all if rows is None else rows
        _matrices(t, rows, *self.records, *c["translation"][:2], *c["rotation"][:2], self.arc,
                  *c["scale"][:2], self.pre, self.post, out)
        return self.object_ids, out


def pose_records(motion) -> tuple:
    """(record (M, 16) float64, links: the same memory as int64) one 128-byte row per track,
    what _matrices reads of it besides its keys: record[k, 0] its duration, 1:4 pre's and 4:7
    post's translations; links[k, 8] flags (1 loop, 2 step, 4 simple: pre and post pure
    translations), 9:15 its translation, rotation and scale key ranges (start, end)."""
    record = np.zeros((len(motion), 16))
    links = record.view(np.int64)
    record[:, 0] = motion.duration
    record[:, 1:4] = motion.pre[:, :3, 3]
    record[:, 4:7] = motion.post[:, :3, 3]
    links[:, 8] = motion.loop + 2 * motion.step + 4 * motion.simple
    for j, name in enumerate(CHANNELS):
        start = motion.channels[name][2]
        links[:, 9 + 2 * j], links[:, 10 + 2 * j] = start[:-1], start[1:]
    return record, links


def _arcs(q) -> np.ndarray:
    """(R, 3) float64 per unit quaternion key q[i] (R, 4) the slerp toward q[i + 1]: angle, 1 /
    sin(angle), sign (-1: the shortest arc goes to -q[i + 1]); angle 0 where they nearly agree
    (dot > 0.9995: lerp then normalise), and on the last row (never read across tracks: a
    segment ends at its track's last key)."""
    out = np.zeros((len(q), 3))
    out[:, 2] = 1.0
    if len(q) > 1:
        dot = np.einsum("ij,ij->i", q[:-1], q[1:])
        out[:-1, 2] = np.where(dot < 0, -1.0, 1.0)
        dot = np.abs(dot)
        arc = dot <= 0.9995
        theta = np.arccos(np.minimum(dot[arc], 1.0))
        rows = np.flatnonzero(arc)
        out[rows, 0] = theta
        out[rows, 1] = 1.0 / np.sin(theta)
    return out


def quaternion_matrices(q) -> np.ndarray:
    """(M, 3, 3) rotation matrices of unit quaternions q (M, 4) x, y, z, w."""
    x, y, z, w = (q[:, i] for i in range(4))
    return np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)], axis=1),
        np.stack([2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)], axis=1),
        np.stack([2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)], axis=1),
    ], axis=1)


def trs_matrices(translation, rotation, scale) -> np.ndarray:
    """(M, 4, 4) float64 T @ R @ S from (M, 3), (M, 4) quaternions and (M, 3)."""
    m = len(translation)
    out = np.zeros((m, 4, 4))
    out[:, :3, :3] = quaternion_matrices(rotation) * scale[:, None, :]
    out[:, :3, 3] = translation
    out[:, 3, 3] = 1.0
    return out


@njit(cache=True, nogil=True, inline="always")
def rotation_scale(x, y, z, w, sx, sy, sz, m):
    """m[:3, :3] = R(x, y, z, w) @ diag(sx, sy, sz), R the unit quaternion's rotation."""
    m[0, 0] = (1 - 2 * (y * y + z * z)) * sx
    m[0, 1] = 2 * (x * y - z * w) * sy
    m[0, 2] = 2 * (x * z + y * w) * sz
    m[1, 0] = 2 * (x * y + z * w) * sx
    m[1, 1] = (1 - 2 * (x * x + z * z)) * sy
    m[1, 2] = 2 * (y * z - x * w) * sz
    m[2, 0] = 2 * (x * z - y * w) * sx
    m[2, 1] = 2 * (y * z + x * w) * sy
    m[2, 2] = (1 - 2 * (x * x + y * y)) * sz


@njit(cache=True, nogil=True, inline="always")
def _sample_track(times, values, a, b, t, step, quaternion, neutral, out):
    """out (width,) = the channel keys values[a:b] at times[a:b] sampled at t: _segment's
    binary search, then hold (step), lerp or slerp (quaternion, shortest arc, normalised)."""
    width = values.shape[1]
    if a == b:
        for j in range(width):
            out[j] = neutral[j]
        return
    lo, hi, u = _segment(times, a, b, t, step)
    if lo == hi:  # held: before the first key, past the last, or a step
        for j in range(width):
            out[j] = values[lo, j]
        return
    if not quaternion:
        for j in range(width):
            out[j] = values[lo, j] + u * (values[hi, j] - values[lo, j])
        return
    dot = 0.0
    for j in range(4):
        dot += values[lo, j] * values[hi, j]
    sign = 1.0
    if dot < 0.0:
        sign, dot = -1.0, -dot
    if dot > 0.9995:  # nearly equal: lerp then normalise
        wa, wb = 1.0 - u, u
    else:
        theta = np.arccos(min(dot, 1.0))
        wa = np.sin((1.0 - u) * theta) / np.sin(theta)
        wb = np.sin(u * theta) / np.sin(theta)
    norm = 0.0
    for j in range(4):
        out[j] = wa * values[lo, j] + wb * sign * values[hi, j]
        norm += out[j] * out[j]
    norm = np.sqrt(norm)
    for j in range(4):
        out[j] /= norm


@njit(cache=True, nogil=True)
def _sample(times, values, start, local, step, quaternion, neutral, out):
    """out[k] = channel of track k at local[k] (_sample_track)."""
    for k in range(len(local)):
        _sample_track(times, values, start[k], start[k + 1], local[k], step[k], quaternion,
                      neutral, out[k])


@njit(cache=True, nogil=True, inline="always")
def key_bracket(times, lo, hi, t):
    """(lo, lo + 1): the keys around t by binary search, given times[lo] <= t < times[hi]
    (sorted times): times[lo] <= t < times[lo + 1]."""
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if times[mid] <= t:
            lo = mid
        else:
            hi = mid
    return lo, hi


@njit(cache=True, nogil=True, inline="always")
def _segment(times, a, b, t, step):
    """(lo, hi, u) of keys times[a:b] (a < b) at t: the value is v[lo] + u (v[hi] - v[lo])
    (u = 0: v[lo] held, before the first key, past the last, or a step)."""
    if t <= times[a]:
        return a, a, 0.0
    if t >= times[b - 1]:
        return b - 1, b - 1, 0.0
    lo, hi = key_bracket(times, a, b - 1, t)
    if step:
        return lo, lo, 0.0
    return lo, hi, (t - times[lo]) / (times[hi] - times[lo])


@njit(cache=True, nogil=True)
def _matrices(t, rows, record, links, tt, tv, rt, rv, arc, st, sv, pre, post, out):
    """out[k] = post[k] @ T R S @ pre[k] of track k in rows at time t (looping tracks wrapped), as
    _sample_track samples: every track in one pass, scalars only. record, links: the tracks'
    records (pose_records: one 128-byte row each, so a posed track reads its row and its keys,
    not a dozen arrays); arc (R, 3): per rotation key, the slerp to the next key's (angle,
    1 / sin(angle), sign; angle 0: lerp), precomputed."""
    trs = np.empty((3, 4))
    mid = np.empty((3, 4))
    for i in range(len(rows)):
        k = rows[i]
        flags = links[k, 8]
        local = t
        if (flags & 1) and record[k, 0] > 0:
            local = t - np.floor(t / record[k, 0]) * record[k, 0]
        step = (flags & 2) != 0
        tx = ty = tz = 0.0
        if links[k, 9] < links[k, 10]:
            lo, hi, u = _segment(tt, links[k, 9], links[k, 10], local, step)
            tx = tv[lo, 0] + u * (tv[hi, 0] - tv[lo, 0])
            ty = tv[lo, 1] + u * (tv[hi, 1] - tv[lo, 1])
            tz = tv[lo, 2] + u * (tv[hi, 2] - tv[lo, 2])
        sx = sy = sz = 1.0
        if links[k, 13] < links[k, 14]:
            lo, hi, u = _segment(st, links[k, 13], links[k, 14], local, step)
            sx = sv[lo, 0] + u * (sv[hi, 0] - sv[lo, 0])
            sy = sv[lo, 1] + u * (sv[hi, 1] - sv[lo, 1])
            sz = sv[lo, 2] + u * (sv[hi, 2] - sv[lo, 2])
        x, y, z, w = 0.0, 0.0, 0.0, 1.0
        if links[k, 11] < links[k, 12]:
            lo, hi, u = _segment(rt, links[k, 11], links[k, 12], local, step)
            if u == 0.0:
                x, y, z, w = rv[lo, 0], rv[lo, 1], rv[lo, 2], rv[lo, 3]
            else:
                theta, inverse, sign = arc[lo, 0], arc[lo, 1], arc[lo, 2]
                if theta == 0.0:  # nearly equal: lerp then normalise
                    wa, wb = 1.0 - u, u
                else:
                    wa = np.sin((1.0 - u) * theta) * inverse
                    wb = np.sin(u * theta) * inverse
                wb *= sign
                x = wa * rv[lo, 0] + wb * rv[hi, 0]
                y = wa * rv[lo, 1] + wb * rv[hi, 1]
                z = wa * rv[lo, 2] + wb * rv[hi, 2]
                w = wa * rv[lo, 3] + wb * rv[hi, 3]
                norm = np.sqrt(x * x + y * y + z * z + w * w)
                x, y, z, w = x / norm, y / norm, z / norm, w / norm
        rotation_scale(x, y, z, w, sx, sy, sz, trs)
        trs[0, 3], trs[1, 3], trs[2, 3] = tx, ty, tz
        if flags & 4:  # pre, post pure translations: R S, then R S pre_t + t + post_t
            for r in range(3):
                acc = trs[r, 3] + record[k, 4 + r]
                for i in range(3):
                    out[k, r, i] = trs[r, i]
                    acc += trs[r, i] * record[k, 1 + i]
                out[k, r, 3] = acc
                out[k, 3, r] = 0.0
            out[k, 3, 3] = 1.0
            continue
        for r in range(3):  # affine: the last rows are 0 0 0 1
            for c in range(4):
                acc = trs[r, 3] if c == 3 else 0.0
                for i in range(3):
                    acc += trs[r, i] * pre[k, i, c]
                mid[r, c] = acc
        for r in range(3):
            for c in range(4):
                acc = post[k, r, 3] if c == 3 else 0.0
                for i in range(3):
                    acc += post[k, r, i] * mid[i, c]
                out[k, r, c] = acc
            out[k, 3, r] = 0.0
        out[k, 3, 3] = 1.0

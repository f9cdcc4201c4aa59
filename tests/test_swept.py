"""world/swept.py: a track's temporal bounding volume holds its exact moved box at every time of
its interval (random tracks: linear and step, looping or clamped, pivots, scales, pre/post
matrices), and the interval is where its channels stay within one key segment. The baked
intervals (bake_intervals, baked_boxes) give the same boxes bit for bit."""
import numpy as np
import pytest

from vismobile.world.animated import moved_boxes
from vismobile.world.motion import Motion, Track
from vismobile.world.swept import SPAN, bake_intervals, baked_boxes, expired, swept_boxes


def random_motion(rng, count=40, scale=0.8):
    tracks = []
    for i in range(count):
        channels = {}
        for name, width in (("translation", 3), ("rotation", 4), ("scale", 3)):
            if rng.random() < (scale if name == "scale" else 0.8):
                k = int(rng.integers(1, 5))
                times = np.sort(rng.choice(np.arange(0.0, 8.0, 0.25), k, replace=False))
                values = rng.normal(size=(k, width)) * (5 if name == "translation" else 1)
                if name == "rotation" and rng.random() < 0.3:
                    values[:] = values[0]  # a fixed turn: the exact branch
                if name == "scale":
                    values = rng.uniform(0.3, 2.0, (k, 3)) * rng.choice([-1, 1], 3)
                channels[name] = (times, values)
        pre = post = None
        if rng.random() < 0.3:  # a glTF-like parent transform
            post = np.eye(4)
            post[:3, :3] = rng.normal(size=(3, 3))
            post[:3, 3] = rng.normal(size=3)
            pre = np.linalg.inv(post)
        tracks.append(Track(i, interpolation="step" if rng.random() < 0.3 else "linear",
                            loop=bool(rng.random() < 0.5), pivot=tuple(rng.normal(size=3)),
                            pre=pre, post=post, **channels))
    return Motion(tracks)


@pytest.mark.parametrize("seed, scale", [(7, 0.8), (8, 0.0), (9, 0.0)])
def test_swept_boxes_hold_the_exact_box_over_their_interval(seed, scale):
    """scale 0: no scale channel, so every turning track takes the turn's axis bound
    (swept._arc_box) rather than the ball."""
    rng = np.random.default_rng(seed)
    motion = random_motion(rng, scale=scale)
    m = len(motion)
    rest = np.sort(rng.normal(size=(m, 2, 3)), axis=1)
    c = motion.channels
    rows = np.arange(m)
    for t in rng.uniform(-2, 20, 30):
        out, start, until = np.empty((m, 2, 3)), np.empty(m), np.empty(m)
        swept_boxes(t, rows, motion.loop, motion.duration, motion.step, *c["translation"],
                    *c["rotation"], *c["scale"], motion.pre, motion.post, rest, out, start,
                    until)
        assert np.all(start <= t) and np.all(t < until)
        for probe in np.linspace(0, 1, 9):  # times across each track's interval
            lo = np.where(np.isfinite(start), start, t - 5.0)
            hi = np.where(np.isfinite(until), until, t + 5.0)
            times = lo + probe * (hi - lo) * (1 - 1e-9)
            for k in range(m):
                exact = moved_boxes(rest[k:k + 1], motion.matrices(times[k])[1][k:k + 1])[0]
                assert np.all(exact[0] >= out[k, 0]) and np.all(exact[1] <= out[k, 1]), \
                    (k, t, times[k], exact, out[k])


def test_expired_lists_tracks_outside_their_interval():
    out = np.empty(3, dtype=np.int64)
    count = expired(1.0, np.array([0.0, 1.5, -np.inf]), np.array([1.0, 2.0, np.inf]), out)
    assert list(out[:count]) == [0, 1]


@pytest.mark.parametrize("seed", [11, 12])
def test_baked_intervals_give_the_swept_boxes(seed):
    """At random times (before, inside and past the keys, and many loops on) each track's baked
    box is swept_boxes' box bit for bit, over an interval holding t and swept_boxes' own (held
    ranges are one interval); the box holds the exact box over the whole baked interval."""
    rng = np.random.default_rng(seed)
    motion = random_motion(rng)
    m = len(motion)
    rest = np.sort(rng.normal(size=(m, 2, 3)), axis=1)
    c = motion.channels
    arrays = (motion.loop, motion.duration, motion.step, *c["translation"], *c["rotation"],
              *c["scale"], motion.pre, motion.post, rest)
    start, lo, hi, boxes = bake_intervals(*arrays, SPAN, 4096)
    assert np.all(np.diff(start) > 0)  # every track baked
    rows = np.arange(m)
    for t in np.concatenate([rng.uniform(-3, 12, 25), rng.uniform(990, 1010, 5), [0.0, 8.0]]):
        out, first, until = np.empty((m, 2, 3)), np.empty(m), np.empty(m)
        swept_boxes(t, rows, *arrays, out, first, until)
        got, b_first, b_until = np.empty((m, 2, 3)), np.empty(m), np.empty(m)
        missed = np.empty(m, dtype=np.int64)
        assert baked_boxes(t, rows, motion.loop, motion.duration, start, lo, hi, boxes, got,
                           b_first, b_until, missed) == 0
        assert np.array_equal(got, out)
        assert np.all(b_first <= first) and np.all(until <= b_until)
        for probe in np.linspace(0, 1, 5):
            low = np.where(np.isfinite(b_first), b_first, t - 50.0)
            high = np.where(np.isfinite(b_until), b_until, t + 50.0)
            times = low + probe * (high - low) * (1 - 1e-9)
            for k in range(m):
                exact = moved_boxes(rest[k:k + 1], motion.matrices(times[k])[1][k:k + 1])[0]
                assert np.all(exact[0] >= got[k, 0]) and np.all(exact[1] <= got[k, 1])


def test_a_track_over_the_limit_is_swept():
    """More intervals than the limit: none baked, baked_boxes lists it to sweep."""
    times = np.arange(0.0, 40.0, 0.5)
    motion = Motion([Track(0, translation=(times, np.outer(times, [1.0, 0, 0]))),
                     Track(1, translation=(times[:3], np.zeros((3, 3))))])
    c = motion.channels
    rest = np.array([[[0.0, 0, 0], [1, 1, 1]]] * 2)
    start, lo, hi, boxes = bake_intervals(
        motion.loop, motion.duration, motion.step, *c["translation"], *c["rotation"],
        *c["scale"], motion.pre, motion.post, rest, SPAN, 16)
    assert start[1] == 0 and start[2] > 0
    out, first, until = np.empty((2, 2, 3)), np.empty(2), np.empty(2)
    missed = np.empty(2, dtype=np.int64)
    n = baked_boxes(3.0, np.arange(2), motion.loop, motion.duration, start, lo, hi, boxes, out,
                    first, until, missed)
    assert list(missed[:n]) == [0] and first[1] <= 3.0 < until[1]


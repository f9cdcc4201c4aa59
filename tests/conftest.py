"""Session fixtures shared by all tests: the thesis worlds (built once and cached in worlds/),
tiny literal geometry and the box-clipping oracle."""
import os
import types

import numpy as np
import pytest
from hypothesis import settings

# Property tests draw the same examples on every run, so CI is reproducible.
settings.register_profile("vismobile", derandomize=True, deadline=None)
settings.load_profile("vismobile")

from vismobile.app.cli import main
from vismobile.scenes import build_world
from vismobile.world.camera import Camera
from vismobile.world.world import World

# Status lines depend on how long a command runs (they start after 2 s): on a loaded machine a
# bad-input run would print one before its error line. Tests of stderr see no status lines;
# tests/test_progress.py draws them on its own streams.
os.environ.setdefault("VISMOBILE_STATUS", "off")


# One triangle as OBJ text: the smallest valid mesh file for the CLI's tests.
TRIANGLE = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"


def refuse(capsys, argv, *needles):
    """Run the CLI, expect exit 2 and one stderr line containing every needle; return it."""
    assert main([str(a) for a in argv]) == 2
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in err, err
    for needle in needles:
        assert str(needle) in lines[0], (needle, lines[0])
    return lines[0]


def clip_overlaps(tri, lo, hi, slack=0.0):
    """Oracle: Sutherland-Hodgman clip of a (3, 3) triangle to the box [lo - slack, hi + slack];
    True when anything survives."""
    poly = [np.asarray(p, dtype=float) for p in tri]
    for axis in range(3):
        for sign, bound in ((1, lo[axis] - slack), (-1, hi[axis] + slack)):
            out = []
            for i, a in enumerate(poly):
                b = poly[(i + 1) % len(poly)]
                da, db = sign * (a[axis] - bound), sign * (b[axis] - bound)
                if da >= 0:
                    out.append(a)
                if (da >= 0) != (db >= 0):
                    out.append(a + (b - a) * (da / (da - db)))
            poly = out
            if not poly:
                return False
    return True


def rect(axis, plane, a, b, facing):
    """(4, 3) vertices, (2, 3) triangles of an axis-aligned rectangle in x[axis] = plane over
    a = (lo, hi) along axis + 1 and b = (lo, hi) along axis + 2, facing +axis (facing=1) or -axis."""
    u, v = (axis + 1) % 3, (axis + 2) % 3
    quad = np.zeros((4, 3))
    quad[:, axis] = plane
    quad[:, u] = [a[0], a[1], a[1], a[0]]
    quad[:, v] = [b[0], b[0], b[1], b[1]]
    tris = np.array([[0, 1, 2], [0, 2, 3]]) if facing > 0 else np.array([[0, 2, 1], [0, 3, 2]])
    return quad, tris


def literal_world(parts, name="literal"):
    """World from a list of (vertices, triangles) parts, one object each."""
    vertices, triangles, ids, offset = [], [], [], 0
    for k, (v, t) in enumerate(parts):
        vertices.append(v)
        triangles.append(t + offset)
        ids.append(np.full(len(t), k))
        offset += len(v)
    return World(np.concatenate(vertices), np.concatenate(triangles), np.concatenate(ids),
                 name=name)


def crease_world():
    """The T-junction room of test_pvs_cracks and test_tjunctions: x, z in [0, 4], y in
    [0.2, 3] (faces in), its far wall z = 4 in 22 strips whose bottom corners lie along the
    floor's edge; the slab's bottom y = 0 below, z in [0, 5], facing up (its two triangles,
    last, are what the cracks show)."""
    parts = [rect(1, 0.2, (0, 4), (0, 4), 1), rect(1, 3.0, (0, 4), (0, 4), -1),
             rect(0, 0.0, (0.2, 3), (0, 4), 1), rect(0, 4.0, (0.2, 3), (0, 4), -1),
             rect(2, 0.0, (0, 4), (0.2, 3), 1)]
    xs = np.concatenate([[0.0], np.sort(np.random.default_rng(5).uniform(0.1, 3.9, 22)), [4.0]])
    parts += [rect(2, 4.0, (a, b), (0.2, 3.0), -1) for a, b in zip(xs[:-1], xs[1:])]
    parts.append(rect(1, 0.0, (0, 5), (0, 4), 1))
    return literal_world(parts, name="crease")


def crease_cameras(profile, count):
    """Eyes in the room looking down at random points of the crease (floor meets far wall)."""
    rng = np.random.default_rng(0)
    for _ in range(count):
        eye = np.array([rng.uniform(0.5, 3.5), rng.uniform(0.5, 2.8), rng.uniform(0.5, 3.0)])
        look = np.array([rng.uniform(0, 4), 0.2, 4.0]) - eye
        yield Camera(eye, yaw=np.degrees(np.arctan2(look[0], -look[2])),
                     pitch=np.degrees(np.arctan2(look[1], np.hypot(look[0], look[2]))),
                     fov=rng.uniform(30, 100), near=0.1, aspect=profile.aspect)


@pytest.fixture(scope="session")
def literal():
    """The helpers above, for test modules (importlib mode cannot import conftest)."""
    return types.SimpleNamespace(clip_overlaps=clip_overlaps, rect=rect, world=literal_world,
                                 crease_world=crease_world, crease_cameras=crease_cameras)


@pytest.fixture(scope="session")
def thesis_world():
    """Factory: thesis_world("w2") -> World, cached per session and on disk in worlds/."""
    cache = {}

    def get(name: str):
        if name not in cache:
            cache[name] = build_world(name)
        return cache[name]

    return get


@pytest.fixture(scope="session")
def w1(thesis_world):
    return thesis_world("w1")


@pytest.fixture(scope="session")
def vismobile_cli():
    """run(*args, cwd): the real entry point, `python -m vismobile ...` in a fresh process
    (this checkout's package first on the path); returns the CompletedProcess (text)."""
    import os
    import subprocess
    import sys
    from pathlib import Path

    env = dict(os.environ, PYTHONPATH=str(Path(__file__).resolve().parents[1]))

    def run(*args, cwd):
        return subprocess.run([sys.executable, "-m", "vismobile", *map(str, args)], cwd=cwd,
                              env=env, capture_output=True, text=True, timeout=300)
    return run


@pytest.fixture(scope="session")
def w1_world_dir(tmp_path_factory, w1):
    """W1 streamed into a world directory (vismobile.mapped) in three pieces, float32 vertices."""
    from vismobile.world.mapped import write_world_dir

    path = tmp_path_factory.mktemp("w1dir")

    def parts():
        for ids in np.array_split(np.arange(w1.triangle_count), 3):
            used, local = np.unique(w1.triangles[ids], return_inverse=True)
            yield w1.vertices[used].astype(np.float32), local.reshape(-1, 3), w1.object_ids[ids]

    write_world_dir(path, parts, "w1", w1.object_names)
    return path


@pytest.fixture(scope="session")
def w5(thesis_world):
    return thesis_world("w5")

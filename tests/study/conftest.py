"""Tiny fixtures for the study tests: a two-room world with a few boxes and an 8-frame path."""
import numpy as np
import pytest
import trimesh

from vismobile.device.profile import get_profile
from vismobile.world.trajectory import Trajectory
from vismobile.world.world import World


def _box(extents, centre, inward=False):
    mesh = trimesh.creation.box(extents=extents)
    mesh.apply_translation(centre)
    faces = mesh.faces[:, ::-1] if inward else mesh.faces
    return World(mesh.vertices, faces)


def tiny_world() -> World:
    """A 20 x 4 x 10 hall seen from inside, a dividing wall and five boxes (~84 triangles)."""
    parts = [_box((20, 4, 10), (0, 2, 0), inward=True),
             _box((0.4, 4, 6), (0, 2, -2))]
    rng = np.random.default_rng(7)
    for _ in range(5):
        parts.append(_box(rng.uniform(0.5, 1.5, 3), (rng.uniform(-9, 9), 0.8,
                                                     rng.uniform(-4, 4))))
    world = World.concatenate(parts, name="tiny")
    return world


@pytest.fixture(scope="session")
def world():
    return tiny_world()


@pytest.fixture(scope="session")
def world_file(tmp_path_factory, world):
    path = tmp_path_factory.mktemp("worlds") / "tiny.obj"
    world.to_obj(path)
    return path


@pytest.fixture(scope="session")
def trajectory():
    frames = 8
    x = np.linspace(-8, 8, frames)
    poses = np.column_stack([x, np.full(frames, 1.6), np.full(frames, 3.0),
                             np.linspace(-60, 90, frames), np.linspace(-10, 10, frames)])
    return Trajectory(poses, {"A": 2, "B": 5})


@pytest.fixture(scope="session")
def trajectory_file(tmp_path_factory, trajectory):
    path = tmp_path_factory.mktemp("trajectories") / "tiny.csv"
    trajectory.save(path)
    return path


@pytest.fixture(scope="session")
def profile():
    return get_profile("ipaq-hx2490b")


@pytest.fixture(scope="session")
def study(tmp_path_factory, world_file, trajectory_file):
    """(context, specs, records) of a small comparison on the tiny world, run once."""
    from vismobile.study.matrix import RunSpec
    from vismobile.study.runner import Context, run_matrix

    root = tmp_path_factory.mktemp("study")
    context = Context("/", root / "out", root / "worlds", root / "cache")
    specs = [RunSpec(str(world_file), str(trajectory_file), structure, cull, "ipaq-hx2490b",
                     "sample:4")
             for structure in ("octree:2", "bsp")
             for cull in ("none", "vfc+bfc+cbfc", "vfc+occlusion")]
    records = run_matrix(specs, context, processes=1, progress=False)
    return context, specs, records

"""Fixtures for the culling tests: thesis worlds and their partitions (built once per session),
tiny literal rooms, random and boundary cameras, and the ground-truth oracle."""
import types

import numpy as np
import pytest

from vismobile.world.camera import Camera
from vismobile.culling import BACKFACE_STAGES
from vismobile.partition import partition
from vismobile.device.profile import get_profile
from vismobile.render import SENTINEL, item_buffer
from vismobile.scenes import build_world

PROFILE = get_profile("ipaq-hx2490b")
ASPECT = PROFILE.aspect
BACKFACE_STAGES = set(BACKFACE_STAGES)

# Structure parameters per world: small enough to build quickly, deep enough to cull.
STRUCTURES = {"octree": {"depth": 4}, "portal": {"depth": 2}, "bsp": {}, "grid": {},
              "kdtree": {}}
BIG = {"w2", "w3", "w4"}  # 30k-100k triangles: shallower trees keep the session short
BIG_STRUCTURES = {"octree": {"depth": 3}, "portal": {"depth": 1}, "bsp": {"min_leaf": 256},
                  "grid": {}, "kdtree": {}}

_WORLDS, _PARTITIONS = {}, {}


def world(name):
    if name not in _WORLDS:
        _WORLDS[name] = build_world(name)
    return _WORLDS[name]


def structure(name, kind):
    key = (name, kind)
    if key not in _PARTITIONS:
        params = (BIG_STRUCTURES if name in BIG else STRUCTURES)[kind]
        _PARTITIONS[key] = partition(world(name), kind, **params)
    return _PARTITIONS[key]


def visible_ids(world_, camera, cull_back):
    """(K,) int64 triangle ids the full world's item buffer shows (the ground truth)."""
    ids = item_buffer(world_, None, camera, PROFILE, cull_back=cull_back)
    ids = np.unique(ids)
    return ids[ids != SENTINEL].astype(np.int64)


def random_cameras(part, count, seed):
    """Cameras inside the world's box (random yaw, pitch in [-60, 60]) and, every other one,
    placed exactly on a corner of a random node box (node and cell boundaries)."""
    rng = np.random.default_rng(seed)
    low, high = part.world.extent
    cams = []
    for i in range(count):
        if i % 2:
            node = rng.integers(part.node_count)
            box = part.node_bounds[node]
            corner = rng.integers(0, 2, 3)
            pos = box[corner, np.arange(3)]
            if not np.all((pos >= low) & (pos <= high)):
                pos = np.clip(pos, low, high)
        else:
            pos = rng.uniform(low, high)
        yaw = float(rng.choice([0.0, 90.0, 180.0, 270.0])) if i % 4 == 1 else rng.uniform(0, 360)
        pitch = 0.0 if i % 4 == 1 else rng.uniform(-60, 60)
        cams.append(Camera(pos, yaw=yaw, pitch=pitch, aspect=ASPECT))
    return cams


def quad(x0, x1, y0, y1, z, facing=1.0):
    """(4, 3) vertices and (2, 3) triangles of an axis-aligned quad in the plane z, facing +z
    (facing=1) or -z (facing=-1)."""
    v = np.array([[x0, y0, z], [x1, y0, z], [x1, y1, z], [x0, y1, z]], dtype=float)
    t = np.array([[0, 1, 2], [0, 2, 3]]) if facing > 0 else np.array([[0, 2, 1], [0, 3, 2]])
    return v, t


def streamed_octree(tmp_path_factory, world_, name, depth):
    """world_ written into a world directory (float32 vertices, three pieces) and its octree
    built streamed (partition/external.py): the path of the .vmp, for map_partition and
    load_partition."""
    from vismobile.world.mapped import MappedWorld, write_world_dir
    from vismobile.partition.external import build_octree_file

    folder = tmp_path_factory.mktemp(f"{name}dir")

    def parts():
        for ids in np.array_split(np.arange(world_.triangle_count), 3):
            used, local = np.unique(world_.triangles[ids], return_inverse=True)
            yield (world_.vertices[used].astype(np.float32), local.reshape(-1, 3),
                   world_.object_ids[ids])

    write_world_dir(folder / "world", parts, name, world_.object_names)
    out = folder / f"{name}.vmp"
    build_octree_file(MappedWorld.open(folder / "world"), out, depth=depth)
    return out


@pytest.fixture(scope="session")
def w1_streamed(tmp_path_factory, w1_world_dir):
    """W1's world directory (float32 vertices, three pieces) and its streamed octree."""
    from vismobile.world.mapped import MappedWorld
    from vismobile.partition.external import build_octree_file

    out = tmp_path_factory.mktemp("vmp") / "w1.vmp"
    build_octree_file(MappedWorld.open(w1_world_dir), out, depth=4)
    return out


@pytest.fixture(scope="session")
def w2_streamed(tmp_path_factory):
    """W2 (indoor: walls hide rooms) as a world directory and its streamed octree, depth 5."""
    return streamed_octree(tmp_path_factory, world("w2"), "w2", 5)


@pytest.fixture(scope="session")
def w1_octree():
    return structure("w1", "octree")


@pytest.fixture(scope="session")
def w1_portal():
    return structure("w1", "portal")


@pytest.fixture(scope="session")
def kit(literal):
    """The helpers above and the root conftest's rect and literal_world, for test modules
    (importlib mode cannot import conftest)."""
    return types.SimpleNamespace(
        structure=structure, world=world, visible_ids=visible_ids,
        random_cameras=random_cameras, quad=quad, rect=literal.rect, literal_world=literal.world,
        BACKFACE_STAGES=BACKFACE_STAGES, BIG=BIG, ASPECT=ASPECT, PROFILE=PROFILE)

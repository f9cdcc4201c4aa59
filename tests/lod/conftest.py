"""The level-of-detail test scene: a floor, a fine sphere and a bumpy tessellated box."""
import numpy as np
import pytest
import trimesh

from vismobile.world import World


def scene_world():
    """A floor, a fine sphere (1,280 triangles) and a bumpy tessellated box: three objects."""
    floor = trimesh.creation.box(extents=(12.0, 0.2, 12.0))
    floor.apply_translation((0.0, -1.1, 0.0))
    sphere = trimesh.creation.icosphere(subdivisions=3, radius=1.0)
    box = trimesh.creation.box(extents=(1.5, 1.5, 1.5)).subdivide().subdivide().subdivide()
    rng = np.random.default_rng(1)
    box.vertices += rng.normal(0.0, 0.01, box.vertices.shape)
    box.apply_translation((3.0, 0.0, -1.0))
    parts = [floor, sphere, box]
    offsets = np.cumsum([0] + [len(p.vertices) for p in parts])
    return World(np.concatenate([p.vertices for p in parts]),
                 np.concatenate([p.faces + o for p, o in zip(parts, offsets)]),
                 np.concatenate([np.full(len(p.faces), k) for k, p in enumerate(parts)]),
                 ["floor", "sphere", "box"], "lodscene")



@pytest.fixture(scope="session")
def lod_world():
    return scene_world()

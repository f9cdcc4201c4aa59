import numpy as np

from vismobile.terrain import sources
from vismobile.terrain.mesh import terrain_world
from vismobile.terrain.placement import place_objects


def test_objects_stand_on_the_ground_deterministically():
    hm = sources.diamond_square(65, seed=1)
    a = place_objects(hm, 4, seed=7, height=3.0, kinds=("goblet",))
    b = place_objects(hm, 4, seed=7, height=3.0, kinds=("goblet",))
    assert np.array_equal(a.positions, b.positions)
    ground = hm.height_at(a.positions[:, 0], a.positions[:, 2])
    assert (a.positions[:, 1] <= ground + 1e-9).all()  # never floating above the ground
    boxes = a.boxes()
    assert np.allclose(boxes[:, 1, 1] - boxes[:, 0, 1], 3.0)
    assert np.allclose(boxes[:, 0, 1], a.positions[:, 1])
    world = terrain_world(hm, a, stride=2)
    assert world.object_names[0] == "terrain" and len(world.object_names) == 5
    assert (world.object_ids == 0).sum() == 2 * 32 * 32

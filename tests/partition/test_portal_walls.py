"""Portal cells on both faces of every thin wall (`portal:walls=true`, partition/portal_edges.py):
W1's walls and slabs each give two boundaries, a room per storey; a closed box's opposite sides
and a doorway's reveals give none; bad options are refused."""
import numpy as np
import pytest

from vismobile.partition import partition
from vismobile.partition.portal_edges import thin_walls, wall_edges
from vismobile.world.world import World


def test_w1_walls_and_slabs_give_both_faces(w1):
    world = w1
    edges = wall_edges(world)
    # the walls at x = 8, 14, 24, 31 and z = 8, 17, 24, 0.2 thick; the slab between storeys
    # (ceiling 3.0, floor 3.2); the outer walls lie on the world's sides
    assert np.allclose(edges[0][1:-1], [7.9, 8.1, 13.9, 14.1, 23.9, 24.1, 30.9, 31.1])
    assert np.allclose(edges[1][1:-1], [3.0, 3.2])
    assert np.allclose(edges[2][1:-1], [7.9, 8.1, 16.9, 17.1, 23.9, 24.1])
    part = partition(world, "portal", depth=1, walls=True)
    assert part.params["walls"] and part.params["slabs"] == [9, 3, 7]


def box(lo, hi, outward=True):
    """Closed box (12 triangles) as a World, wound outward (or inward)."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    v = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1])
                  for z in (lo[2], hi[2])])
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    tris = np.array([t for a, b, c, d in quads for t in ((a, b, c), (a, c, d))])
    corners = v[tris]
    volume = np.einsum("ij,ij->", corners[:, 0], np.cross(corners[:, 1], corners[:, 2]))
    if (volume > 0) != outward:
        tris = tris[:, ::-1]
    return World(v, tris.astype(np.int32), name="box")


def test_a_thin_slab_is_a_wall_and_a_thick_box_is_not():
    thin = box((0, 0, 0), (10, 0.2, 10))  # 100 m2 faces 0.2 apart: thin
    rows = thin_walls(thin, 1)
    assert len(rows) == 1 and np.allclose(rows[0], [0.0, 0.2, 100.0])
    assert not len(thin_walls(box((0, 0, 0), (10, 6, 10)), 1))  # 6 apart: a block, not a wall
    # wound inward (a room's faces: they face each other across it) is never a wall
    assert not len(thin_walls(box((0, 0, 0), (10, 0.2, 10), outward=False), 1))


@pytest.mark.parametrize("spec", ["portal:1,walls=yes", "portal:1,walls=2",
                                  "portal:1,walls=true,cells=8",
                                  "portal:1,walls=true,slabs=2x2x2"])
def test_bad_walls_options_are_refused(spec):
    with pytest.raises(ValueError):
        partition(box((0, 0, 0), (1, 1, 1)), spec)

"""Crack portals come only from the unshared edges of triangles lying in the cells' common face
(pvs_cracks.crack_portals): an edge of another triangle lying on a wall (a ramp's side standing
against it) does not open the wall, whose own edges are shared (the fill rule)."""
import numpy as np

from vismobile.partition.pvs_cracks import crack_portals


def test_only_edges_of_triangles_in_the_face_open_it(literal):
    wall = literal.rect(0, 0.0, (0.0, 2.0), (0.0, 2.0), 1)  # in the face x = 0
    patch = literal.rect(0, 0.0, (3.0, 4.0), (0.0, 2.0), 1)  # in it too, its own borders
    ramp = (np.array([[0.0, 0.5, 0.5], [0.0, 1.0, 1.5], [0.8, 0.5, 1.0]]),
            np.array([[0, 1, 2]]))  # leans on the wall along its edge at x = 0
    world = literal.world([wall, patch, ramp])
    boxes = np.array([[[-1.0, 0.0, 0.0], [0.0, 5.0, 2.0]], [[0.0, 0.0, 0.0], [1.0, 5.0, 2.0]]])
    pairs, quads = crack_portals(world, boxes, 1e-9)
    assert len(pairs) and (pairs == [0, 1]).all()
    seg = quads[:, :2]
    # every piece is a border of the wall or the patch: y in {0, 2, 3, 4} or z in {0, 2}
    on_border = (np.isin(np.round(seg[:, :, 1], 9), [0.0, 2.0, 3.0, 4.0]).all(axis=1)
                 | np.isin(np.round(seg[:, :, 2], 9), [0.0, 2.0]).all(axis=1))
    assert on_border.all()
    # the ramp's edge inside the wall, (0, 0.5, 0.5)-(0, 1, 1.5), is no crack
    mid = np.array([0.0, 0.75, 1.0])
    d = seg[:, 1] - seg[:, 0]
    t = np.clip(((mid - seg[:, 0]) * d).sum(1) / np.maximum((d * d).sum(1), 1e-300), 0, 1)
    assert np.linalg.norm(seg[:, 0] + t[:, None] * d - mid, axis=1).min() > 0.1

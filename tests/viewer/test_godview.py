import numpy as np

from vismobile.world.camera import Camera
from vismobile.viewer.godview import FRUSTUM, NODES, OUTLINE, SENT, GodView


def box_world(literal):
    # a room 10 x 4 x 10: floor facing up, one wall facing +z
    floor = literal.rect(1, 0.0, (0.0, 10.0), (0.0, 10.0), 1)
    wall = literal.rect(2, 0.0, (0.0, 4.0), (0.0, 10.0), 1)
    return literal.world([floor, wall])


def test_top_view_maps_x_right_and_z_down_keeping_aspect(literal):
    god = GodView(box_world(literal), (100, 50), margin=0.0)
    pixels = god.to_pixels([[0, 0, 0], [10, 0, 10], [10, 4, 0]], "top")
    assert np.allclose(pixels, [[25, 0], [75, 50], [75, 0]])
    side = god.to_pixels([[0, 0, 0], [10, 4, 0]], "side")
    assert side[0, 1] > side[1, 1]  # up is up


def test_outline_leaves_out_faces_toward_the_viewer(literal):
    god = GodView(box_world(literal), (64, 64))
    top = god.outline("top")
    # only the wall (edge-on from above) is drawn: one line along z = 0
    rows = np.flatnonzero((top == OUTLINE).all(axis=2).any(axis=1))
    assert len(rows) and rows.max() - rows.min() <= 1


def test_draw_marks_sent_triangles_nodes_and_frustum(literal):
    world = box_world(literal)
    god = GodView(world, (64, 64))
    camera = Camera((5.0, 2.0, 9.0), aspect=0.75)
    plain = god.draw("top", camera, np.array([], dtype=np.int64))
    marked = god.draw("top", camera, np.array([0, 1]), node_boxes=world.bounds[:1])
    for colour in (SENT, NODES):
        assert (marked == colour).all(axis=2).any() and not (plain == colour).all(axis=2).any()
    assert (plain == FRUSTUM).all(axis=2).any()
    assert np.array_equal(god.outline("top"), god.outline("top"))  # drawing leaves it intact

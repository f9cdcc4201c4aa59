"""Doors (culling/doors.py): which objects are doors, which portals they hold, when they block."""
import numpy as np

from vismobile.culling import doors
from vismobile.scenes.crowd import outward_boxes

BOX = np.array([[0.0, 0.0, 0.0], [0.2, 2.0, 1.0]])


def corners_of(boxes):
    vertices, triangles = outward_boxes(np.asarray(boxes).reshape(-1, 2, 3))
    return vertices[triangles]


def test_a_closed_outward_box_is_a_door_and_other_shapes_are_not():
    assert np.allclose(doors.is_box(corners_of(BOX)), BOX)
    assert doors.is_box(corners_of(BOX)[:, ::-1]) is None  # wound inward
    assert doors.is_box(corners_of(BOX)[:-1]) is None  # a face missing
    assert doors.is_box(corners_of([BOX, BOX + [[0, 3, 0]]])) is None  # two boxes
    bent = corners_of(BOX).copy()
    bent[0, 0] += 0.05  # a vertex off the corners
    assert doors.is_box(bent) is None


def test_find_doors_keeps_named_boxes_among_the_moving():
    corners = np.concatenate([corners_of(BOX), corners_of(BOX + 5), corners_of(BOX + 9)])
    ids = np.repeat([0, 1, 2], 12)
    names = ["door_a", "crate", "door_b"]
    rows, boxes = doors.find_doors(names, ids, corners, np.array([2, 1, 0]))
    assert rows.tolist() == [0, 2] and np.allclose(boxes[0], BOX + 9)
    rows, _ = doors.find_doors(names, ids, corners, np.array([1]))
    assert len(rows) == 0  # a door that never moves is not in the moving set


def square(axis, plane, lo, hi):
    """(4, 3) rectangle on x[axis] = plane spanning lo..hi on the two other axes."""
    u, v = (axis + 1) % 3, (axis + 2) % 3
    out = np.zeros((4, 3))
    out[:, axis] = plane
    out[:, u] = [lo[0], hi[0], hi[0], lo[0]]
    out[:, v] = [lo[1], lo[1], hi[1], hi[1]]
    return out


def test_pairs_hold_portals_wholly_inside_a_door_with_their_depth():
    inside = square(0, 0.05, (0.1, 0.05), (1.9, 0.9))  # y 0.1..1.9, z 0.05..0.9
    poking = square(0, 0.05, (0.1, 0.05), (2.5, 0.9))
    on_face = square(0, 0.0, (0.1, 0.05), (1.9, 0.9))
    vertices = np.concatenate([inside, poking, on_face])
    portals, ids, depth = doors.door_pairs(vertices, [0, 4, 8, 12], BOX[None])
    assert portals.tolist() == [0] and ids.tolist() == [0]
    assert np.isclose(depth[0], 0.05)


def test_blocked_needs_a_closed_door_a_deep_portal_and_the_eye_outside():
    portals, ids, depth = doors.door_pairs(square(0, 0.1, (0.5, 0.3), (1.5, 0.7)), [0, 4],
                                           BOX[None])
    assert np.isclose(depth[0], 0.1)
    shut = np.eye(4)[None]
    closed, slack = doors.closed_doors(shut)
    args = (portals, ids, depth, BOX[None])
    far = np.array([-3.0, 1.0, 0.5])
    assert doors.blocked(*args, closed, slack, far, 0.1, 0.01).tolist() == [0]
    assert len(doors.blocked(*args, closed, slack, far, 0.1, 0.2)) == 0  # shallower than grow
    near = np.array([-0.05, 1.0, 0.5])  # within the near plane's reach of the door
    assert len(doors.blocked(*args, closed, slack, near, 0.1, 0.01)) == 0
    inside = np.array([0.1, 1.0, 0.5])
    assert len(doors.blocked(*args, closed, slack, inside, 0.0, 0.01)) == 0
    turn = np.eye(4)
    a = np.radians(0.01)  # ajar by a hundredth of a degree: not closed
    turn[[0, 0, 2, 2], [0, 2, 0, 2]] = [np.cos(a), np.sin(a), -np.sin(a), np.cos(a)]
    closed, slack = doors.closed_doors(turn[None])
    assert not closed[0]
    assert len(doors.blocked(*args, closed, slack, far, 0.1, 0.01)) == 0

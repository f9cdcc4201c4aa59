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


def test_edges_spanning_many_cells_give_the_same_portals_in_any_batch(literal, monkeypatch):
    """edge_portals tests an edge's cell pairs in batches of PAIRS: a floor's border edges that
    run through a row of cells give the same portals, in the same order, whatever the batch
    (and each piece lies on its pair's common face)."""
    from vismobile.partition import pvs_cracks

    floor = literal.rect(1, 0.0, (0.0, 1.0), (0.0, 6.0), 1)  # y = 0, x 0-6, z 0-1
    world = literal.world([floor])
    cuts = np.linspace(0.0, 6.0, 7)  # cells below and above the floor, 6 along x, 2 along z
    boxes = np.array([[[x0, y0, z0], [x1, y0 + 1.0, z0 + 0.5]] for x0, x1 in zip(cuts, cuts[1:])
                      for y0 in (-1.0, 0.0) for z0 in (0.0, 0.5)])
    whole = crack_portals(world, boxes, 1e-9)
    monkeypatch.setattr(pvs_cracks, "PAIRS", 3)
    pieces = crack_portals(world, boxes, 1e-9)
    assert len(whole[0]) == 16  # 6 columns x 2 borders along x, 2 x 2 along z
    assert all(np.array_equal(x, y) for x, y in zip(whole, pieces))
    a, b = whole[0][:, 0], whole[0][:, 1]
    seg = whole[1][:, :2]
    for k in range(3):  # each piece within its two cells' common box (grown by eps)
        lo = np.maximum(boxes[a, 0, k], boxes[b, 0, k])[:, None] - 2e-9
        hi = np.minimum(boxes[a, 1, k], boxes[b, 1, k])[:, None] + 2e-9
        assert ((seg[:, :, k] >= lo) & (seg[:, :, k] <= hi)).all()

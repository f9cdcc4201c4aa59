"""The PVS's sealed cell model (tools/pvs_slack.py): a doorway's reveals split the hollow wall's
thin cell so the doorway is a cell closed on its sides and above (pvs_refine), and unshared
edges, where the rasteriser may leave a pixel open, become portals (pvs_cracks)."""
import numpy as np

from vismobile.partition import portal
from vismobile.partition.pvs_cells import view_grid
from vismobile.partition.pvs_cracks import crack_portals, unshared_edges
from vismobile.partition.pvs_refine import inner_cuts


def doorway_world(literal):
    """Rooms x in [0, 4] and [4.2, 8.2] (3 high, 6 deep, faces in) split by a hollow wall
    0.2 thick with a doorway z in [1, 2], y below 2.1, lined with reveals."""
    rect = literal.rect
    parts = [rect(1, 0.0, (0, 8.2), (0, 6), 1), rect(1, 3.0, (0, 8.2), (0, 6), -1),
             rect(2, 0.0, (0, 3), (0, 8.2), 1), rect(2, 6.0, (0, 3), (0, 8.2), -1),
             rect(0, 0.0, (0, 3), (0, 6), 1), rect(0, 8.2, (0, 3), (0, 6), -1)]
    for x, facing in ((4.0, -1), (4.2, 1)):
        parts += [rect(0, x, (0, 3), (0, 1), facing), rect(0, x, (0, 3), (2, 6), facing),
                  rect(0, x, (2.1, 3), (1, 2), facing)]
    parts += [rect(2, 1.0, (4.0, 4.2), (0, 2.1), 1), rect(2, 2.0, (4.0, 4.2), (0, 2.1), -1),
              rect(1, 2.1, (1, 2), (4.0, 4.2), -1)]
    return literal.world(parts, name="doorway")


def test_reveals_cut_the_thin_cell(literal):
    world = doorway_world(literal)
    lo, hi = np.array([4.0, 0.0, 0.0]), np.array([4.2, 3.0, 6.0])
    edges = inner_cuts(world, lo, hi, np.arange(world.triangle_count), 1e-9)
    assert np.allclose(edges[0], [4.0, 4.2])  # the thin side is not cut
    assert np.allclose(edges[1], [0.0, 2.1, 3.0]) and np.allclose(edges[2], [0.0, 1.0, 2.0, 6.0])
    # a room is not thin: no cuts
    room = inner_cuts(world, np.zeros(3), np.array([4.0, 3.0, 6.0]),
                      np.arange(world.triangle_count), 1e-9)
    assert all(len(e) == 2 for e in room)


def test_the_doorway_cell_opens_only_to_the_rooms(literal, monkeypatch):
    from vismobile.partition import pvs_cells

    world = doorway_world(literal)
    edges = [np.array([0.0, 4.0, 4.2, 8.2]), np.array([0.0, 3.0]), np.array([0.0, 6.0])]
    monkeypatch.setattr(pvs_cells, "paired_edges", lambda world, cells: edges)
    g = view_grid(world, split=True)
    boxes = g["cell_bounds"]
    door = np.flatnonzero(((boxes[:, 0] <= [4.1, 1.0, 1.5]) & (boxes[:, 1] >= [4.1, 1.0, 1.5]))
                          .all(axis=1))
    assert len(door) == 1
    d = int(door[0])
    assert np.allclose(boxes[d], [[4.0, 0.0, 1.0], [4.2, 2.1, 2.0]])
    real = len(g["portal_cells"]) - g.get("cracks", 0)
    mine = [p for p in g["cell_portals"][g["cell_portal_start"][d]:g["cell_portal_start"][d + 1]]
            if p < real]
    quads = np.asarray(g["portal_vertices"]).reshape(-1, 4, 3)[mine]
    # real portals only through the wall's two faces (x = 4 and x = 4.2), none along the wall
    assert len(mine) >= 2 and np.all(np.ptp(quads[:, :, 0], axis=1) == 0)
    assert set(np.round(quads[:, 0, 0], 6)) == {4.0, 4.2}


def test_unshared_edges_and_their_crack_portals(literal):
    rect = literal.rect
    # a floor quad [0, 2] x [0, 2] and a wall x = 1 whose bottom edge ends mid-way along the
    # floor's diagonal-free split at x = 1: the wall's corners are not the floor's
    parts = [rect(1, 0.0, (0, 2), (0, 1), 1), rect(1, 0.0, (0, 2), (1, 2), 1),
             rect(0, 1.0, (0, 1), (0.5, 1.5), 1)]
    world = literal.world(parts, name="tjunction")
    edges = unshared_edges(world)
    # two floor quads share z = 1's edge; every other edge (outline, wall) is unshared
    keys = {tuple(np.round(np.sort(e, axis=0).ravel(), 6)) for e in edges}
    assert (0.0, 0.0, 1.0, 2.0, 0.0, 1.0) not in keys and len(edges) == 6 + 4
    # two cells split at x = 1: the wall's bottom edge (x = 1, y = 0, z 0.5..1.5) lies in both
    boxes = np.array([[[0.0, 0.0, 0.0], [1.0, 1.0, 2.0]], [[1.0, 0.0, 0.0], [2.0, 1.0, 2.0]]])
    pairs, quads = crack_portals(world, boxes, 1e-9 * portal.THICKNESS)
    assert len(pairs) >= 1 and set(map(tuple, pairs)) == {(0, 1)}
    lo, hi = quads.min(axis=(0, 1)), quads.max(axis=(0, 1))
    assert np.allclose(lo[0], 1.0) and np.allclose(hi[0], 1.0)  # on the shared face


def test_region_backfacing_holds_for_every_eye_in_the_box():
    # whatever it calls back-facing from the box, tbfc's device-rounded test calls back-facing
    # from random eyes inside it (culling/triangle_backface.py), and it finds some
    from vismobile.culling.triangle_backface import certainly_backfacing, triangle_cross
    from vismobile.partition.pvs_back import region_backfacing

    rng = np.random.default_rng(5)
    corners = rng.uniform(-10, 10, (400, 3, 3))
    lo, hi = np.array([-1.0, -2.0, 0.5]), np.array([1.5, 0.0, 2.0])
    delta = 2.0 ** -16
    back = region_backfacing(corners, lo, hi, delta)
    assert 0 < back.sum() < len(back)
    cross, abs_cross, la, lb = triangle_cross(corners[back])
    for eye in lo + rng.uniform(0, 1, (64, 3)) * (hi - lo):
        assert certainly_backfacing(cross, abs_cross, la, lb, corners[back, 0], eye, delta).all()

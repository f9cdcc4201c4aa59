"""Portal octree: cells, per-cell octrees, portals found from the walls and the solid space."""
import numpy as np
import pytest

import vismobile
from vismobile.partition import portal
from vismobile.world.world import World


def inward(world):
    """The same world with every triangle turned over (the fixture's rooms face outward)."""
    return World(world.vertices, world.triangles[:, ::-1].copy(), name=world.name)


def test_doorway_gives_a_portal_of_its_size(rooms):
    p = vismobile.partition(inward(rooms), "portal", depth=1, slabs=((0.5, 0.5), 1, 1))
    assert list(p.extras["portal_cells"][0]) == [0, 1] and len(p.extras["portal_cells"]) == 1
    quad = p.extras["portal_vertices"][p.extras["portal_start"][0]:p.extras["portal_start"][1]]
    assert np.allclose(quad[:, 0], 0.0)  # on the shared face x = 0
    # sample boundaries fall on the doorway's edges: the portal is the doorway
    assert np.allclose([quad[:, 1].min(), quad[:, 1].max(), quad[:, 2].min(), quad[:, 2].max()],
                       [0.0, 2.0, 1.5, 2.5])
    # winding: right-hand normal points from the first cell (x < 0) to the second
    normal = np.cross(quad[1] - quad[0], quad[2] - quad[0])
    assert normal[0] > 0


def test_open_face_is_one_portal_and_a_solid_wall_none(rooms):
    rooms = inward(rooms)
    keep = ~((np.abs(rooms.corners[:, :, 0]).max(axis=1) == 0))  # drop the middle wall
    open_world = World(rooms.vertices, rooms.triangles[keep])
    p = portal.build(open_world, 1, slabs=((0.5, 0.5), 1, 1))
    quad = p.extras["portal_vertices"]
    assert len(p.extras["portal_cells"]) == 1
    assert quad[:, 2].min() == 0.0 and quad[:, 2].max() == 4.0
    door = World(np.array([[0, 0, 1.5], [0, 3, 1.5], [0, 3, 2.5], [0, 0, 2.5]], float),
                 np.array([[0, 1, 2], [0, 2, 3]]))
    solid = World.concatenate([rooms, door])
    assert len(portal.build(solid, 1, slabs=((0.5, 0.5), 1, 1)).extras["portal_cells"]) == 0


def test_face_inside_a_closed_object_is_blocked(rooms):
    # a closed box wound consistently facing out (trimesh's): solid inside, its middle face
    # has no portal
    import trimesh

    solid = trimesh.creation.box(extents=(8.0, 3.0, 4.0))
    solid.apply_translation((0.0, 1.5, 2.0))
    box = World.from_trimesh(solid)
    assert len(portal.build(box, 1, slabs=((0.5, 0.5), 1, 1)).extras["portal_cells"]) == 0
    # the fixture's box is closed but wound inconsistently (4 triangles against their
    # neighbours): no solid is assumed, so the face stays open
    keep = ~((np.abs(rooms.corners[:, :, 0]).max(axis=1) == 0))
    box = World(rooms.vertices, rooms.triangles[keep])
    assert len(portal.build(box, 1, slabs=((0.5, 0.5), 1, 1)).extras["portal_cells"]) == 1


def slab_world(literal, gap):
    """Two storeys of one room (x, z in [0, 4]) with a hollow slab y in (3, 3 + gap) between
    the lower ceiling (facing down) and the upper floor (facing up); walls face inward."""
    rect = literal.rect
    parts = [rect(1, 0.0, (0, 4), (0, 4), 1), rect(1, 3.0, (0, 4), (0, 4), -1),
             rect(1, 3.0 + gap, (0, 4), (0, 4), 1), rect(1, 6.0 + gap, (0, 4), (0, 4), -1)]
    for y0, y1 in ((0.0, 3.0), (3.0 + gap, 6.0 + gap)):
        parts += [rect(0, 0.0, (y0, y1), (0, 4), 1), rect(0, 4.0, (y0, y1), (0, 4), -1),
                  rect(2, 0.0, (0, 4), (y0, y1), 1), rect(2, 4.0, (0, 4), (y0, y1), -1)]
    return literal.world(parts, "slab")


@pytest.mark.parametrize("gap", [0.2, 0.001])
def test_hollow_slab_is_blocked_on_a_vertical_face(literal, gap):
    # a closed box facing out (overhanging the walls, so it shares no edge with them) is solid
    import trimesh

    rooms = slab_world(literal, gap)
    keep = ~np.isclose(rooms.centroids[:, 1], 3.0) & ~np.isclose(rooms.centroids[:, 1], 3.0 + gap)
    slab = trimesh.creation.box(extents=(5.0, gap, 5.0))
    slab.apply_translation((2.0, 3.0 + gap / 2, 2.0))
    w = literal.world([(rooms.vertices, rooms.triangles[keep]), (slab.vertices, slab.faces)])
    rects = portal.face_openings(w, 0, 2.0, (0.0, 0.0), (6.0 + gap, 4.0), 1e-9)
    ys = np.concatenate([rects[:, 0, 0], rects[:, 1, 0]])
    # the two rooms are open, the slab between them is not, however thin it is
    assert len(rects) == 2 and np.allclose(np.sort(ys), [0.0, 3.0, 3.0 + gap, 6.0 + gap])


def test_uncapped_slab_is_open(literal):
    # without caps the slab is no closed solid: a sight line may enter it from its open sides
    w = slab_world(literal, 0.2)
    rects = portal.face_openings(w, 0, 2.0, (0.0, 0.0), (6.2, 4.0), 1e-9)
    assert len(rects) == 1 and np.allclose(rects[0], [[0.0, 0.0], [6.2, 4.0]])


def test_slab_between_walls_in_the_face_stays_open(literal):
    # walls of both storeys lie in the face x = 2 and the slab between them has no cap there:
    # with back faces culled a sight line can run inside the slab (entering where it is open
    # elsewhere) and cross the face between the walls, so that band stays a portal
    rect, gap = literal.rect, 0.2
    w = slab_world(literal, gap)
    walls = [rect(0, 2.0, (0.0, 3.0), (0, 4), 1), rect(0, 2.0, (3.0 + gap, 6.0 + gap), (0, 4), 1)]
    w = literal.world([(w.vertices, w.triangles)] + walls, "slab_walls")
    rects = portal.face_openings(w, 0, 2.0, (0.0, 0.0), (6.0 + gap, 4.0), 1e-9)
    assert len(rects) == 1 and np.allclose(rects[0], [[3.0, 0.0], [3.0 + gap, 4.0]])


def test_thin_crack_stays_open(literal):
    # a wall in the face x = 2 stops 1 mm below the ceiling: the crack is an opening
    rect = literal.rect
    w = literal.world([rect(1, 0.0, (0, 4), (0, 4), 1), rect(1, 3.0, (0, 4), (0, 4), -1),
                       rect(0, 2.0, (0.0, 2.999), (0, 4), -1)])
    rects = portal.face_openings(w, 0, 2.0, (0.0, 0.0), (3.0, 4.0), 1e-9)
    assert len(rects) == 1 and np.allclose(rects[0], [[2.999, 0.0], [3.0, 4.0]])


def test_layout_cells_and_adjacency(cow, checks):
    p = portal.build(cow, 2, cells=27)
    e = p.extras
    cells = len(e["cell_node"])
    assert np.all(p.node_levels()[e["cell_node"]] == 1) and cells == p.child_count[0]
    assert np.array_equal(p.node_bounds[e["cell_node"]], e["cell_bounds"])
    checks.covered(p)
    checks.exact(p)
    # every portal lies on the face shared by its two cells
    for k, (a, b) in enumerate(e["portal_cells"]):
        quad = e["portal_vertices"][e["portal_start"][k]:e["portal_start"][k + 1]]
        ba, bb = e["cell_bounds"][a], e["cell_bounds"][b]
        lo, hi = np.maximum(ba[0], bb[0]), np.minimum(ba[1], bb[1])
        assert np.all(quad >= lo - 1e-6) and np.all(quad <= hi + 1e-6)
        assert np.sum(np.isclose(lo, hi)) == 1
    # CSR adjacency lists each portal under both of its cells
    start, ids = e["cell_portal_start"], e["cell_portals"]
    assert start[-1] == len(ids) == 2 * len(e["portal_cells"])
    for c in range(cells):
        for k in ids[start[c]:start[c + 1]]:
            assert c in e["portal_cells"][k]


@pytest.mark.parametrize("depth", [0, 4])
def test_bad_depth(cow, depth):
    with pytest.raises(ValueError, match="portal octree depth"):
        portal.build(cow, depth)


def test_crossing_segment_through_a_vertex():
    # plane x = 0; corner 0 lies on it, corners 1 and 2 on opposite sides
    corners = np.array([[[0.0, 1.0, 1.0], [1.0, 3.0, 1.0], [-1.0, 3.0, 3.0]]])
    cu, cv, flat, crossing, seg, box = portal.plane_footprints(corners, 0, 0.0, 1e-9)
    assert crossing[0] and not flat[0]
    ends = sorted(map(tuple, seg[0]))
    assert np.allclose(ends, [(1.0, 1.0), (3.0, 2.0)])  # (y, z): the vertex, the edge midpoint
    assert np.allclose(box[0], [[1.0, 1.0], [3.0, 2.0]])


def test_touching_edge_is_a_segment_with_its_side():
    # a floor triangle (facing +y) ending on the plane x = 0 along its edge z in [0, 2], y = 1
    corners = np.array([[[0.0, 1.0, 0.0], [0.0, 1.0, 2.0], [1.0, 1.0, 0.0]]])
    seg, side = portal.plane_segments(corners, np.array([[0.0, 1.0, 0.0]]), 0, 0.0, 1e-9)
    assert np.allclose(sorted(map(tuple, seg[0])), [(1.0, 0.0), (1.0, 2.0)])
    assert np.allclose(side, [[1.0, 0.0]])  # (u, v) = (y, z): faces +u
    # a triangle touching the plane at one corner leaves nothing
    corners[0, 1, 0] = 1.0
    assert len(portal.plane_segments(corners, np.array([[0.0, 1.0, 0.0]]), 0, 0.0, 1e-9)[0]) == 0


def test_wall_outline_drops_shared_edges_only():
    cu = np.array([[0.0, 1.0, 1.0], [0.0, 1.0, 0.0]])
    cv = np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 1.0]])
    assert len(portal.wall_outline(cu, cv, 1e-9)) == 4  # the square's diagonal is inside
    # two copies of one triangle lie on the same side of every edge: all edges bound
    assert len(portal.wall_outline(np.repeat(cu[:1], 2, 0), np.repeat(cv[:1], 2, 0), 1e-9)) == 6


def brute_back(seg, side, p, direction):
    """Nearest segment hit from point p along direction (2,), and whether it is seen from behind
    (None when nothing is hit)."""
    best, back = np.inf, None
    for (a, b), n in zip(seg, side):
        d = b - a
        det = direction[0] * (-d[1]) - direction[1] * (-d[0])
        if det == 0:
            continue
        rhs = a - p
        t = (rhs[0] * (-d[1]) - rhs[1] * (-d[0])) / det
        s = (direction[0] * rhs[1] - direction[1] * rhs[0]) / det
        if t > 0 and 0 <= s <= 1 and t < best:
            best, back = t, float(n @ direction) > 0
    return back


def test_solid_cells_are_solid_everywhere_inside():
    rng = np.random.default_rng(3)
    # random closed convex polygons (outward normals: solid inside) and some stray segments
    segs, sides = [], []
    for _ in range(6):
        c, r = rng.uniform(2, 8, 2), rng.uniform(1.0, 2.5)
        ang = np.sort(rng.uniform(0, 2 * np.pi, 5))
        pts = c + r * np.stack([np.cos(ang), np.sin(ang)], axis=1)
        for k in range(5):
            a, b = pts[k], pts[(k + 1) % 5]
            d = b - a
            segs.append([a, b])
            sides.append(np.array([d[1], -d[0]]) / np.linalg.norm(d))  # outward for CCW
    for _ in range(8):
        a = rng.uniform(0, 10, 2)
        segs.append([a, a + rng.normal(size=2)])
        sides.append(rng.normal(size=2))
    seg, side = np.array(segs), np.array(sides)
    bu, bv = np.linspace(0, 10, 41), np.linspace(0, 10, 37)
    solid = ~portal.cells_crossed(seg, bu, bv, 1e-12) & portal._solid(seg, side, bu, bv, 1e-12)
    assert 40 < solid.sum() < solid.size
    for i, j in zip(*np.nonzero(solid)):
        for _ in range(3):
            p = np.array([rng.uniform(bu[i], bu[i + 1]), rng.uniform(bv[j], bv[j + 1])])
            along = [[brute_back(seg, side, p, np.array(d, float)) for d in pair]
                     for pair in (((1, 0), (-1, 0)), ((0, 1), (0, -1)))]
            assert any(all(x is True for x in pair) for pair in along), (i, j, p)


def test_cells_crossed_matches_dense_sampling():
    rng = np.random.default_rng(11)
    seg = rng.uniform(0, 4, (12, 2, 2))
    bu, bv = np.linspace(0, 4, 9), np.linspace(0, 4, 7)
    crossed = portal.cells_crossed(seg, bu, bv, 1e-12)
    t = np.linspace(0, 1, 4001)
    pts = seg[:, None, 0] + t[None, :, None] * (seg[:, None, 1] - seg[:, None, 0])
    pts = pts.reshape(-1, 2)
    i = np.clip(np.searchsorted(bu, pts[:, 0]) - 1, 0, 7)
    j = np.clip(np.searchsorted(bv, pts[:, 1]) - 1, 0, 5)
    dense = np.zeros_like(crossed)
    dense[i, j] = True
    assert np.array_equal(crossed, dense)


def test_open_rectangles_cover_every_open_cell():
    rng = np.random.default_rng(5)
    for max_rects in (2, 64):
        mask = rng.random((12, 9)) < 0.3
        bu, bv = np.cumsum(rng.uniform(0.1, 1, 13)), np.cumsum(rng.uniform(0.1, 1, 10))
        rects = portal.open_rectangles(mask, bu, bv, max_rects)
        oi, oj = np.nonzero(mask)
        mid = np.stack([(bu[oi] + bu[oi + 1]) / 2, (bv[oj] + bv[oj + 1]) / 2], axis=1)
        inside = ((mid[:, None] >= rects[None, :, 0]) & (mid[:, None] <= rects[None, :, 1])).all(2)
        assert inside.any(axis=1).all()

"""Portal octree: cells, per-cell octrees, portals found from the walls."""
import numpy as np
import pytest

import vismobile
from vismobile.partition import portal


def test_doorway_gives_a_portal_of_its_size(rooms):
    p = vismobile.partition(rooms, "portal", depth=1, slabs=((0.5, 0.5), 1, 1))
    assert list(p.extras["portal_cells"][0]) == [0, 1] and len(p.extras["portal_cells"]) == 1
    quad = p.extras["portal_vertices"][p.extras["portal_start"][0]:p.extras["portal_start"][1]]
    assert np.allclose(quad[:, 0], 0.0)  # on the shared face x = 0
    y0, y1, z0, z1 = quad[:, 1].min(), quad[:, 1].max(), quad[:, 2].min(), quad[:, 2].max()
    spacing = 4.0 / portal.FACE_SAMPLES
    # never smaller than the doorway, at most two samples larger on each side
    assert y0 <= 0.0 and y1 >= 2.0 and z0 <= 1.5 and z1 >= 2.5
    assert y1 <= 2.0 + 2 * spacing and z0 >= 1.5 - 2 * spacing and z1 <= 2.5 + 2 * spacing
    # winding: right-hand normal points from the first cell (x < 0) to the second
    normal = np.cross(quad[1] - quad[0], quad[2] - quad[0])
    assert normal[0] > 0


def test_closed_wall_has_no_portal(rooms):
    from vismobile.world import World

    tris = rooms.triangles.copy()
    corners = rooms.corners
    keep = ~((np.abs(corners[:, :, 0]).max(axis=1) == 0))  # drop the middle wall
    open_world = World(rooms.vertices, tris[keep])
    p = portal.build(open_world, 1, slabs=((0.5, 0.5), 1, 1))
    quad = p.extras["portal_vertices"]
    # without the wall the whole face (minus nothing) is one portal
    assert len(p.extras["portal_cells"]) == 1
    assert quad[:, 2].min() == 0.0 and quad[:, 2].max() == 4.0
    # a solid wall: no portal
    solid = World.concatenate([rooms, World(np.array([[0, 0, 1.5], [0, 3, 1.5], [0, 3, 2.5],
                                                      [0, 0, 2.5]], float),
                                            np.array([[0, 1, 2], [0, 2, 3]]))])
    assert len(portal.build(solid, 1, slabs=((0.5, 0.5), 1, 1)).extras["portal_cells"]) == 0


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


def brute_covered(corners, plane_thickness, lo_uv, s, nu, nv):
    """Per-sample reference: within s/2 of an in-plane triangle or of a crossing segment."""
    cu, cv, flat, crossing, seg, _ = portal.plane_footprints(corners, 0, 0.0, plane_thickness)
    out = np.zeros((nu, nv), dtype=bool)
    for i in range(nu):
        for j in range(nv):
            p = lo_uv + (np.array([i, j]) + 0.5) * s
            for t in range(len(corners)):
                if flat[t]:
                    a, b, c = np.stack([cu[t], cv[t]], axis=1)
                    cross = [(y - x)[0] * (p - x)[1] - (y - x)[1] * (p - x)[0]
                             for x, y in ((a, b), (b, c), (c, a))]
                    inside = all(k >= 0 for k in cross) or all(k <= 0 for k in cross)
                    edges = [(a, b), (b, c), (c, a)]
                elif crossing[t]:
                    inside, edges = False, [(seg[t, 0], seg[t, 1])]
                else:
                    continue
                near = min(portal._point_segment_sq(p[0], p[1], x[0], x[1], y[0], y[1])
                           for x, y in edges)
                if inside or near <= (s / 2) ** 2:
                    out[i, j] = True
                    break
    return out


def test_vectorised_coverage_matches_per_sample_reference():
    rng = np.random.default_rng(7)
    centres = rng.uniform(0, 4, (30, 3)) * [0, 1, 1]
    corners = centres[:, None, :] + rng.normal(scale=0.4, size=(30, 3, 3))
    corners[:12, :, 0] = 0.0  # in the plane
    corners[12:, 0, 0] = np.abs(corners[12:, 0, 0]) + 0.05  # the others cross it
    corners[12:, 1, 0] = -np.abs(corners[12:, 1, 0]) - 0.05
    lo_uv, hi_uv = np.array([0.0, 0.0]), np.array([4.0, 3.0])
    s, nu, nv = portal._face_grid(lo_uv, hi_uv, 24)
    cu, cv, flat, crossing, seg, box = portal.plane_footprints(corners, 0, 0.0, 1e-9)
    mask = portal._covered(cu, cv, flat, seg, box, lo_uv, s, nu, nv)
    assert np.array_equal(mask, brute_covered(corners, 1e-9, lo_uv, s, nu, nv))
    assert 0 < mask.sum() < mask.size
    # conservative: every open sample lies in some opening rectangle
    rects = portal._open_rectangles(mask, lo_uv, hi_uv, s)
    oi, oj = np.nonzero(~mask)
    pts = lo_uv + (np.stack([oi, oj], axis=1) + 0.5) * s
    inside = ((pts[:, None] >= rects[None, :, 0]) & (pts[:, None] <= rects[None, :, 1])).all(axis=2)
    assert inside.any(axis=1).all()

"""The BSP tree's leaves as the PVS's view cells (partition/pvs_leaves.py): the leaves' regions
tile the world's box, and `bsp:pvs=conservative` drops nothing the item buffer shows from
cameras in its leaves (inside, on faces, edges and corners, any pitch and fov, three
arithmetic modes); an eye outside every cell falls back and says so."""
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from vismobile.culling import Culler
from vismobile.partition import partition
from vismobile.partition.pvs_leaves import LATTICE, clip, box_faces, leaf_regions, on_lattice
from vismobile.world.camera import Camera

from .pvs_cases import (MODES, in_cell_cameras, in_face_plane, keeps_what_cameras_see,
                        near_boundary_cameras, zigzag_world)


@pytest.fixture(scope="module")
def baked(kit):
    return partition(zigzag_world(kit), "bsp", min_leaf=4, pvs="conservative")


def descend(part, point):
    """The leaf whose region holds the point (first child: n.x + d >= 0)."""
    planes, node = part.extras["split_planes"], 0
    while part.child_count[node]:
        side = planes[node, :3] @ point + planes[node, 3] >= 0
        node = part.first_child[node] + (0 if side else 1)
    return node


def test_clipping_a_cube_by_a_diagonal_plane_leaves_a_prism():
    faces = clip(box_faces(np.zeros(3), np.ones(3)), np.array([1.0, 1.0, 0.0, -1.0]), 1e-12)
    points = np.unique(np.round(np.concatenate(faces), 9), axis=0)
    assert len(points) == 6 and (points.sum(axis=1) >= 0.0).all()
    assert np.allclose(points[:, :2].sum(axis=1).min(), 1.0)  # the cap lies on x + y = 1


def test_the_leaves_regions_tile_the_world(baked):
    leaves, boxes, _ = leaf_regions(baked)
    assert len(leaves) > 1 and set(leaves) <= set(baked.leaf_ids)
    rng = np.random.default_rng(0)
    low, high = baked.world.extent
    for point in low + rng.uniform(0, 1, (300, 3)) * (high - low):
        k = np.searchsorted(leaves, descend(baked, point))
        assert leaves[k] == descend(baked, point)
        assert ((boxes[k, 0] - 1e-9 <= point) & (point <= boxes[k, 1] + 1e-9)).all()


def test_the_view_cells_are_the_leaves(baked):
    leaves, boxes, _ = leaf_regions(baked)
    cells = baked.extras["pvs_cells"]
    assert len(cells) == len(leaves)
    assert (cells[:, 0] <= boxes[:, 0]).all() and (cells[:, 1] >= boxes[:, 1]).all()


@pytest.mark.parametrize("mode", MODES)
def test_bsp_leaves_pvs_keeps_what_cameras_in_them_see(kit, baked, mode):
    cams = in_cell_cameras(baked, 40, 11) + near_boundary_cameras(baked, 24, 12)
    used = keeps_what_cameras_see(baked, ("pvs,vfc",), cams, mode, kit.PROFILE)
    assert used == sum(not in_face_plane(baked, cam) for cam in cams) > 0


def test_an_eye_outside_every_leaf_falls_back_and_says_so(baked):
    low, high = baked.world.extent
    outside = Camera(high + (high - low), yaw=200.0, pitch=-30.0, aspect=4 / 3)
    result = Culler(baked, "pvs,vfc").cull(outside)
    assert result.stats.get("pvs.fallbacks") == 1 and "pvs.cells" not in result.stats
    inside = Camera((low + high) / 2.0, yaw=0.0, aspect=4 / 3)
    assert "pvs.fallbacks" not in Culler(baked, "pvs,vfc").cull(inside).stats


@settings(max_examples=50)
@given(st.integers(0, 2**32 - 1), st.floats(-1e4, 1e4), st.sampled_from([1e-3, 0.039, 0.5, 3.0]))
def test_stored_boxes_grow_outward_onto_the_lattice(seed, origin, step):
    rng = np.random.default_rng(seed)
    lo = origin + rng.uniform(0, 100, (20, 3))
    boxes = np.stack([lo, lo + rng.uniform(0, 10, (20, 3))], axis=1)
    out = on_lattice(boxes, np.full(3, origin), step)
    assert (out[:, 0] <= boxes[:, 0]).all() and (out[:, 1] >= boxes[:, 1]).all()
    assert (out[:, 0] >= boxes[:, 0] - 2 * step).all()
    assert (out[:, 1] <= boxes[:, 1] + 2 * step).all()
    k = (out - origin) / step
    assert (np.abs(k - np.round(k)) <= 1e-6 * (1 + np.abs(k))).all()


def test_the_leaves_stored_boxes_share_lattice_coordinates(baked):
    """Each leaf's stored box holds its region's bounding box, on the lattice or at the
    world's box grown by the bake's pad (never beyond: an eye there falls back)."""
    _, regions, _ = leaf_regions(baked)
    cells = baked.extras["pvs_cells"]
    assert len(cells) == len(regions)
    assert (cells[:, 0] <= regions[:, 0]).all() and (cells[:, 1] >= regions[:, 1]).all()
    extent = np.asarray(baked.world.extent)
    step = LATTICE * float(np.ptp(extent, axis=0).max())
    k = (cells - extent[0]) / step
    at_side = (cells < extent[0]) | (cells > extent[1])
    assert (cells >= extent[0] - step).all() and (cells <= extent[1] + step).all()
    assert np.allclose(k[~at_side], np.round(k[~at_side]), atol=1e-6)

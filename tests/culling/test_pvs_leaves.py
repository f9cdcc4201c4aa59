"""The BSP tree's leaves as the PVS's view cells (partition/pvs_leaves.py): the leaves' regions
tile the world's box, and `bsp:pvs=conservative` drops nothing the item buffer shows from
cameras in its leaves (inside, on faces, edges and corners, any pitch and fov, three
arithmetic modes); an eye outside every cell falls back and says so."""
import importlib.util
from pathlib import Path

import numpy as np
import pytest

from vismobile.culling import Culler, device_options
from vismobile.device.profile import get_profile
from vismobile.partition import partition
from vismobile.partition.pvs_leaves import clip, box_faces, leaf_regions
from vismobile.render import SENTINEL, item_buffer
from vismobile.world.camera import Camera

# test_pvs.py's world and cameras (importlib mode: test modules are not importable by name)
_spec = importlib.util.spec_from_file_location("pvs_cases", Path(__file__).with_name("test_pvs.py"))
_cases = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(_cases)
MODES, in_cell_cameras, zigzag_world = _cases.MODES, _cases.in_cell_cameras, _cases.zigzag_world


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
    profile = kit.PROFILE if mode == "float64" else get_profile(kit.PROFILE, mode)
    options = {"arithmetic": "float64"} if mode == "float64" else device_options(profile)
    culler = Culler(baked, "pvs,vfc", **options)
    used = 0
    cams = in_cell_cameras(baked, 40, 11)
    for cam in cams:
        shown = np.unique(item_buffer(baked.world, None, cam, profile, cull_back=False))
        shown = shown[shown != SENTINEL].astype(np.int64)
        result = culler.cull(cam)
        missing = np.setdiff1d(shown, result.triangles)
        assert not len(missing), f"bsp leaves ({mode}) dropped {missing}: {cam}"
        used += "pvs.fallbacks" not in result.stats
    assert used == sum(not _cases.in_face_plane(baked, cam) for cam in cams) > 0


def test_an_eye_outside_every_leaf_falls_back_and_says_so(baked):
    low, high = baked.world.extent
    outside = Camera(high + (high - low), yaw=200.0, pitch=-30.0, aspect=4 / 3)
    result = Culler(baked, "pvs,vfc").cull(outside)
    assert result.stats.get("pvs.fallbacks") == 1 and "pvs.cells" not in result.stats
    inside = Camera((low + high) / 2.0, yaw=0.0, aspect=4 / 3)
    assert "pvs.fallbacks" not in Culler(baked, "pvs,vfc").cull(inside).stats

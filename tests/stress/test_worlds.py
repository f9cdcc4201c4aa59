"""Stress worlds and cameras: each case is what its name says."""
import numpy as np
import pytest

from vismobile.scenes.stress import (ROOM_SIZE, base_cameras, base_world, partition_cameras,
                                     stress_cases)

CASES = {case.name: case for case in stress_cases()}


def test_every_issue_case_is_present_and_finite():
    expect = {"base", "translate_1e3", "translate_1e5", "translate_1e7", "scale_1e-4",
              "scale_1e4", "slivers", "zero_area", "duplicated", "coplanar_overlap",
              "huge_triangle", "single_triangle", "empty_cell"}
    assert set(CASES) == expect
    for case in CASES.values():
        assert np.all(np.isfinite(case.world.vertices)) and case.world.triangle_count >= 1
        assert case.world.name == case.name


def test_base_world_is_closed_rooms_with_inward_shell():
    world = base_world()
    shell = world.object_ids == 0
    probe = world.centroids[shell] + 0.01 * world.normals[shell]
    assert np.all((probe > 0) & (probe < ROOM_SIZE))
    assert np.allclose(world.extent, [[0, 0, 0], ROOM_SIZE])


@pytest.mark.parametrize("name, shift", [("translate_1e3", 1e3), ("translate_1e7", 1e7)])
def test_translations_move_world_and_cameras_together(name, shift):
    case, base = CASES[name], CASES["base"]
    assert np.allclose(case.world.vertices, base.world.vertices + shift, rtol=0, atol=1e-8)
    for (label, cam), (_, ref) in zip(case.cameras, base.cameras):
        assert np.allclose(cam.eye, ref.eye + shift, rtol=0, atol=1e-8), label


def test_scaled_world_scales_near_and_far():
    case = CASES["scale_1e-4"]
    assert np.ptp(case.world.extent, axis=0).max() == pytest.approx(12e-4)
    near = dict(case.cameras)["near_1e-4"]
    assert near.near == pytest.approx(1e-8) and near.far == pytest.approx(0.1)


def test_degenerate_cases():
    zero = CASES["zero_area"].world
    assert (zero.areas == 0).sum() == 12
    needles = CASES["slivers"].world
    extra = needles.object_ids == needles.object_ids.max()
    assert np.all(needles.areas[extra] < 1e-6) and np.all(needles.areas[extra] > 0)
    dup = CASES["duplicated"].world
    assert dup.triangle_count == 2 * 264 + 50
    huge = CASES["huge_triangle"].world
    assert np.ptp(huge.bounds[-1], axis=0).max() > 100 * 12
    assert CASES["single_triangle"].world.triangle_count == 1


def test_camera_stresses():
    cams = dict(base_cameras())
    assert cams["fov_1"].fov == 1.0 and cams["fov_170"].fov == 170.0
    assert cams["pitch_+90"].pitch == 90.0 and cams["pitch_-90"].pitch == -90.0
    assert cams["far_near_1e7"].far / cams["far_near_1e7"].near == pytest.approx(1e7)
    assert cams["near_1e-4"].near == 1e-4


def test_partition_cameras_sit_exactly_on_planes_corners_and_portals():
    root = np.array([[0.0, 0, 0], [8, 4, 12]])
    kids = np.array([[[x, y, z], [x + 4, y + 2, z + 6]] for x in (0.0, 4.0) for y in (0.0, 2.0)
                     for z in (0.0, 6.0)])
    bounds = np.concatenate([root[None], kids])
    portal = np.array([[4.0, 0, 5], [4, 2, 5], [4, 2, 7], [4, 0, 7]])
    cams = dict(partition_cameras(bounds, np.array([0, 1, 9]), portal))
    assert cams["on_plane_x"].eye.tolist() == [4.0, 2.0, 6.0]
    assert cams["on_plane_y"].eye[1] == 2.0 and cams["on_plane_z"].eye[2] == 6.0
    assert cams["node_corner"].eye.tolist() == [4.0, 2.0, 6.0]
    assert cams["portal_plane_0"].eye[0] == 4.0 and cams["portal_plane_1"].eye.tolist() == [4, 0, 5]
    assert not partition_cameras(root[None], np.array([0, 1]))  # a lone root has no planes

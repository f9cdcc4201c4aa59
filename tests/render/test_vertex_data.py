"""Per-corner vertex data: crease-angle normals, object colours, float32 / fixed16.16 records."""
import numpy as np
import pytest
import trimesh

from vismobile.errors import ProfileError
from vismobile.device.profile import VERTEX_BYTES, get_profile
from vismobile.render.vertex_data import corner_normals, object_colors, vertex_records
from vismobile.world.world import World

CUBE_VERTICES = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], float)
CUBE_FACES = [[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1],
              [2, 3, 7], [2, 7, 6], [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]]


def test_box_corners_keep_their_face_normals():
    cube = World(CUBE_VERTICES, CUBE_FACES)
    assert np.array_equal(corner_normals(cube), np.repeat(cube.normals[:, None], 3, axis=1))


def test_curved_surfaces_get_smooth_normals():
    sphere = trimesh.creation.icosphere(3)
    world = World(sphere.vertices, sphere.faces)
    normals = corner_normals(world)
    radial = world.corners / np.linalg.norm(world.corners, axis=2, keepdims=True)
    assert np.degrees(np.arccos(np.clip((normals * radial).sum(2), -1, 1))).max() < 1.0
    assert np.allclose(np.linalg.norm(normals, axis=2), 1.0)


def test_a_wide_fan_centre_falls_back_to_face_normals():
    angles = np.linspace(0, 2 * np.pi, 101)[:-1]
    rim = np.column_stack([np.cos(angles), 0.05 * np.sin(5 * angles), np.sin(angles)])
    vertices = np.vstack([[0.0, 0.3, 0.0], rim])
    faces = np.column_stack([np.zeros(100, int), np.r_[2:101, 1], np.r_[1:101]])
    world = World(vertices, faces)
    normals = corner_normals(world)
    assert np.array_equal(normals[:, 0], world.normals)  # 100 triangles share vertex 0
    assert np.allclose(np.linalg.norm(normals, axis=2), 1.0)


def test_one_colour_per_object_deterministic():
    colours = object_colors(np.array([0, 1, 0, 2]))
    assert colours.dtype == np.uint8 and colours.shape == (4, 4)
    assert np.array_equal(colours[0], colours[2]) and not np.array_equal(colours[0], colours[1])
    assert np.all(colours[:, 3] == 255)


def test_records_in_both_formats():
    world = World(CUBE_VERTICES * 3.25 - 1.0, CUBE_FACES)
    plain = vertex_records(world, get_profile("nokia-n82"))
    fixed = vertex_records(world, get_profile("nokia-n82", "fixed16.16"))
    assert plain.dtype.itemsize == fixed.dtype.itemsize == VERTEX_BYTES == 28
    assert len(plain) == 3 * world.triangle_count
    assert plain["position"].dtype == np.float32 and fixed["position"].dtype == np.int32
    assert np.array_equal(fixed["position"] / 65536.0, world.corners.reshape(-1, 3))
    assert np.abs(fixed["normal"] / 65536.0 - plain["normal"]).max() <= 2.0 ** -17 + 1e-7
    with pytest.raises(ProfileError, match="world 'far'"):
        vertex_records(World(CUBE_VERTICES + 33_000.0, CUBE_FACES, name="far"),
                       get_profile("nokia-n82", "fixed16.16"))

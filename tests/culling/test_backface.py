"""cbfc and cone: they only drop triangles that no frustum ray can see the front of."""
import numpy as np

from vismobile.world.camera import Camera
from vismobile.culling import Culler
from vismobile.culling.backface import corner_rays, thesis_region_count, unit_corner_rays
from vismobile.geometry.sphere_regions import direction_regions


def test_thesis_region_count_is_360_over_90_minus_fov():
    assert thesis_region_count(45.0) == 8 and thesis_region_count(60.0) == 12


def test_dropped_triangles_are_back_facing_for_every_frustum_ray(kit):
    part = kit.structure("w6", "octree")
    world = part.world
    for cam in kit.random_cameras(part, 12, seed=7):
        base = Culler(part, "vfc").cull(cam).triangles
        rays = corner_rays(cam)
        for stages in ("vfc,cbfc", "vfc,cone"):
            dropped = np.setdiff1d(base, Culler(part, stages).cull(cam).triangles)
            n = world.normals[dropped]
            sees_front = (n @ rays.T < -1e-9).any(axis=1)  # some frustum ray meets the front
            facing = np.einsum("ij,ij->i", n, cam.eye - world.corners[dropped, 0]) > 1e-9
            if stages == "vfc,cbfc":
                assert not sees_front.any(), stages
            else:
                assert not facing.any(), stages


def test_thesis_2d_rule_would_drop_a_floor_facing_the_eye():
    # The SPEC note: yaw-only regions put an upward normal in some yaw sector; looking that way
    # the thesis drops the floor under the camera, which faces the eye and is in the frustum.
    up = np.array([[0.0, 1.0, -1e-3]])  # a floor tilted by 0.06 degrees toward -z
    n = thesis_region_count(45.0)
    floor_sector = direction_regions(up, n, 1)[0]
    cam = Camera((0.0, 1.6, 0.0), yaw=0.0, pitch=-30.0, aspect=0.75)
    assert direction_regions(cam.forward[None], n, 1)[0] == floor_sector
    assert (up @ corner_rays(cam).T < 0).all()  # every ray sees the floor's front


def test_cbfc_keeps_a_floor_under_a_camera_looking_down(kit):
    v, t = kit.quad(-5, 5, -5, 5, 0.0)
    floor = kit.literal_world([(v[:, [0, 2, 1]], t[:, ::-1])])  # in y = 0, facing +y
    assert floor.normals[0, 1] > 0.99
    from vismobile.partition import partition

    part = partition(floor, "octree", depth=1)
    cam = Camera((0.0, 1.6, 0.0), yaw=0.0, pitch=-30.0, aspect=0.75)
    assert len(Culler(part, "vfc,cbfc").cull(cam).triangles) == 2
    # Seen from below (back face), looking up: the region test drops it.
    below = Camera((0.0, -1.6, 0.0), yaw=0.0, pitch=60.0, aspect=0.75)
    assert len(Culler(part, "vfc,cbfc,cone").cull(below).triangles) == 0


def test_cbfc_thesis_stage_drops_a_tilted_floor_that_faces_the_eye(kit):
    from vismobile.partition import partition

    v, t = kit.quad(-5, 5, -5, 5, 0.0)
    v = v[:, [0, 2, 1]]
    v[:, 1] += 0.01 * v[:, 2]  # tilt the floor's normal a little toward -z (yaw sector 0)
    floor = kit.literal_world([(v, t[:, ::-1])])
    assert floor.normals[0, 1] > 0.99
    part = partition(floor, "octree", depth=1)
    cam = Camera((0.0, 1.6, 0.0), yaw=0.0, pitch=-30.0, aspect=0.75)
    assert len(Culler(part, "vfc,cbfc_thesis").cull(cam).triangles) == 0
    assert len(Culler(part, "vfc,cbfc").cull(cam).triangles) == 2


def test_frame_table_is_droppable_and_spare_in_one_pass(kit):
    stage = Culler(kit.structure("w6", "octree"), "cbfc").stages[0]
    rng = np.random.default_rng(9)
    dropping = 0
    for _ in range(300):
        cam = Camera(rng.uniform(-5, 5, 3), yaw=rng.uniform(-360, 360),
                     pitch=rng.uniform(-90, 90), fov=rng.uniform(10, 100),
                     aspect=rng.uniform(0.3, 3))
        rays = corner_rays(cam)
        assert np.array_equal(unit_corner_rays(cam),
                              rays / np.linalg.norm(rays, axis=1, keepdims=True))
        table = stage.droppable(cam)
        dropped, spare = stage.frame_table(cam)
        assert dropped == table.sum()
        expect = stage.spare(cam, table)
        assert np.array_equal(spare < 0, expect < 0) and spare[-1] == -1.0
        assert np.abs(spare - expect).max() <= 1e-15
        dropping += dropped > 0
    assert 0 < dropping < 300

"""`occlusion` (union depth buffer) and `occlusion_thesis` on literal scenes: a wall made of
quads with T-junctions around a door hides what is behind it, keeps what shows through the
door, never drops what the item buffer shows; the thesis stage skips grazing occluders."""
import numpy as np

from vismobile.camera import Camera
from vismobile.culling import Culler
from vismobile.partition import partition


def wall_scene(kit):
    """A wall at z = -5 with a door [-0.5, 0.5] x [-1, 0.5] (4 quads meeting in T-junctions),
    a floor at y = -1 creasing with it, a patch behind the wall, a patch behind the door."""
    q = kit.quad
    parts = [q(-6, 6, 0.5, 4, -5), q(-6, -0.5, -1, 0.5, -5), q(0.5, 6, -1, 0.5, -5),
             q(-6, 6, -1, -5, -5),  # below the floor: completes the wall, hidden anyway
             ]
    floor_v = np.array([[-6.0, -1, -5], [6, -1, -5], [6, -1, 0.5], [-6, -1, 0.5]])
    parts.append((floor_v, np.array([[0, 2, 1], [0, 3, 2]])))  # facing +y
    parts.append(q(2.0, 2.6, -0.9, -0.3, -7))   # hidden behind the wall, near the crease
    parts.append(q(-0.2, 0.2, -0.8, 0.2, -9))   # seen through the door
    return kit.literal_world(parts, "wall")


def test_wall_hides_what_is_behind_and_keeps_the_door_view(kit):
    world = wall_scene(kit)
    part = partition(world, "octree", depth=3)
    cam = Camera((0.0, 0.2, 0.0), yaw=0.0, pitch=0.0, aspect=kit.ASPECT)
    sent = Culler(part, "vfc,occlusion").cull(cam).triangles
    visible = kit.visible_ids(world, cam, False)
    hidden_patch, door_patch = world.object_ids == 5, world.object_ids == 6
    assert not np.isin(np.flatnonzero(hidden_patch), visible).any()
    assert not np.isin(np.flatnonzero(hidden_patch), sent).any()
    assert np.isin(np.flatnonzero(door_patch), sent).all()
    assert np.isin(visible, sent).all()


def test_occlusion_never_drops_visible_triangles_from_many_cameras(kit):
    world = wall_scene(kit)
    part = partition(world, "octree", depth=3)
    rng = np.random.default_rng(5)
    cullers = [Culler(part, s) for s in ("occlusion", "vfc,occlusion", "vfc,occlusion_thesis")]
    for _ in range(12):
        pos = rng.uniform([-4, -0.9, -4.9], [4, 3, 0.4])
        cam = Camera(pos, yaw=rng.uniform(-60, 60), pitch=rng.uniform(-30, 30),
                     aspect=kit.ASPECT)
        visible = kit.visible_ids(world, cam, False)
        for culler in cullers:
            missing = np.setdiff1d(visible, culler.cull(cam).triangles)
            assert not len(missing), (culler.names, cam, missing)


def test_thesis_occlusion_skips_an_occluder_seen_edge_on(kit):
    # The eye 3e-11 off a wall's plane (at a 1e-4 world scale): the wall hides nothing.
    q = kit.quad
    world = kit.literal_world([q(-1e-4, 1e-4, -1e-4, 1e-4, 0.0), q(-2e-5, 2e-5, -2e-5, 2e-5, -3e-4)])
    part = partition(world, "octree", depth=2)
    cam = Camera((5e-5, 0.0, 3e-11), yaw=0.0, pitch=0.0, aspect=kit.ASPECT, near=1e-6, far=1.0)
    culler = Culler(part, "occlusion_thesis")
    culler.cull(cam)  # the first frame records the occluder candidates
    assert not np.isin([0, 1], culler.stages[0].select(cam)).any()  # the wall is skipped
    assert np.isin(kit.visible_ids(world, cam, False), culler.cull(cam).triangles).all()

"""The PVS per door state (issue 25): a PVS baked from an animated world with doors keeps, per
view cell and door, what the door shut hides (partition/pvs.py door_sets); `pvs` leaves those
out while the door is shut and the eye outside it, and drops nothing the item buffer of the
frame's pose shows, shut, opening or open."""
import numpy as np
import pytest

from vismobile.culling import Culler
from vismobile.partition import load_partition, partition, save_partition
from vismobile.scenes.crowd import outward_boxes, yaw_quaternion
from vismobile.world.animated import AnimatedWorld
from vismobile.world.camera import Camera
from vismobile.world.motion import Motion, Track
from vismobile.world.world import World

from .pvs_cases import SLABS, zigzag_world

# a door in the first wall's doorway (x 4 .. 4.2, z 0.2 .. 1.0, y 0 .. 2), 1 cm past it
DOOR = np.array([[3.99, -0.01, 0.19], [4.21, 2.01, 1.01]])
OPEN_AT = 1.0  # shut until 1 s, then it turns 90 degrees about its hinge over 1 s


@pytest.fixture(scope="module")
def doored(kit):
    rooms = zigzag_world(kit)
    vertices, triangles = outward_boxes(DOOR[None])
    door = World(vertices, triangles, np.zeros(len(triangles), dtype=np.int64), ["door_1"],
                 name="door")
    world = World.concatenate([rooms, door], name="zigzag_door")
    track = Track(object_id=len(world.object_names) - 1, pivot=tuple(DOOR[0]),
                  rotation=(np.array([0.0, OPEN_AT, OPEN_AT + 1.0]),
                            yaw_quaternion([0.0, 0.0, -90.0])))
    animated = AnimatedWorld(world, Motion([track]))
    return partition(animated, "portal", depth=1, slabs=SLABS, pvs="conservative",
                     pvs_doors=True)


def room_cameras(count, seed, aspect=4 / 3):
    """Cameras in the first room (x in (0.3, 3.7)) looking anywhere, near 0.05."""
    rng = np.random.default_rng(seed)
    return [Camera((rng.uniform(0.3, 3.7), rng.uniform(0.3, 2.7), rng.uniform(0.3, 3.7)),
                   yaw=rng.uniform(0, 360), pitch=rng.uniform(-60, 60), near=0.05,
                   aspect=aspect) for _ in range(count)]


def test_the_bake_keeps_what_the_door_hides(doored):
    x = doored.extras
    assert x["pvs_door_boxes"].shape == (1, 2, 3)
    assert len(x["pvs_door_runs"]) > 0  # some cell loses something to the shut door
    plain = partition(doored.animated, "portal", depth=1, slabs=SLABS, pvs="conservative")
    assert "pvs_door_boxes" not in plain.extras  # only when asked (the bake walks again)


def test_a_shut_door_hides_the_rooms_beyond_and_nothing_shown_is_dropped(kit, doored):
    animated = doored.animated
    cullers = {back: Culler(doored, "pvs,vfc,tbfc" if back else "pvs,vfc") for back in (0, 1)}
    beyond = np.flatnonzero(animated.world.bounds[:, 0, 0] > 4.21)  # wholly in rooms 2..5
    shut_sent = open_sent = 0
    for t in (0.0, 1.5, 2.5):  # shut, opening, open
        posed = animated.posed(t)
        for cam in room_cameras(12, seed=int(10 * t), aspect=kit.ASPECT):
            for back, culler in cullers.items():
                result = culler.cull(cam, time=t)
                missing = np.setdiff1d(kit.visible_ids(posed, cam, bool(back)), result.triangles)
                assert not len(missing), f"pvs dropped {missing} at t={t}, camera {cam}"
                assert ("pvs.doors_shut" in result.stats) == (t == 0.0)
            # counted with back faces culled: the walls beyond facing away from the first room
            # are not what the doors decide
            sent = len(np.intersect1d(result.triangles, beyond))
            shut_sent += sent if t == 0.0 else 0
            open_sent += sent if t == 2.5 else 0
    assert shut_sent == 0 < open_sent


def test_an_eye_in_the_doorway_keeps_everything_behind_the_door(doored):
    # inside the door's box the shut-door rule does not hold: the sets stay whole
    cam = Camera((4.1, 1.0, 0.6), yaw=-90.0, pitch=0.0, near=0.05)
    result = Culler(doored, "pvs,vfc").cull(cam, time=0.0)
    assert "pvs.doors_shut" not in result.stats


def test_the_vmp_keeps_the_door_sets_and_refuses_corrupt_ones(doored, tmp_path):
    static = doored.static
    path = tmp_path / "doored.vmp"
    save_partition(static, path)
    loaded = load_partition(path)
    for key in ("pvs_door_boxes", "pvs_door_start", "pvs_door_runs"):
        assert np.array_equal(loaded.extras[key], static.extras[key])
    bad = dict(static.extras)
    bad["pvs_door_start"] = bad["pvs_door_start"][:-1]
    from vismobile.partition.pvs_check import check_pvs

    with pytest.raises(ValueError, match="pvs_door_start"):
        check_pvs(bad, static.world.triangle_count)

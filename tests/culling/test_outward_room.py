"""`portals` through a doorway into a room whose one-sided walls face outward (issue 29).

The room's walls are trimesh-style boxes' faces: they face away from the room, so from inside
each is seen from behind. A wall blocks sight from both sides whatever its winding (winding
decides only back-face culling), so the portal builder may not take the room's inside for solid
space. Truth is the full world's item buffer, with and without back-face culling.
"""
import numpy as np
import pytest
import trimesh

from vismobile.world.camera import Camera, yaw_toward
from vismobile.culling import Culler
from vismobile.partition import partition
from vismobile.world.world import World

ROOM = np.array([[0.0, 0.0, 0.0], [10.0, 3.0, 10.0]])
DOOR_Z, DOOR_TOP = (4.0, 6.0), 2.2


def outward_room_world():
    """A 10 x 3 x 10 room, every wall facing out (as trimesh's box faces), a doorway in x = 0,
    three spheres inside, one outside beyond the far wall and one to the west, all in a hall
    whose walls face in."""
    (x0, y0, z0), (x1, y1, z1) = ROOM
    quads = []

    def quad(axis, plane, a, b, facing):
        u, v = (axis + 1) % 3, (axis + 2) % 3
        q = np.zeros((4, 3))
        q[:, axis], q[:, u], q[:, v] = plane, [a[0], a[1], a[1], a[0]], [b[0], b[0], b[1], b[1]]
        t = np.array([[0, 1, 2], [0, 2, 3]]) if facing > 0 else np.array([[0, 2, 1], [0, 3, 2]])
        quads.append(trimesh.Trimesh(q, t, process=False))

    quad(1, y0, (z0, z1), (x0, x1), -1)          # floor, facing down (out)
    quad(1, y1, (z0, z1), (x0, x1), 1)           # ceiling, facing up (out)
    quad(0, x1, (y0, y1), (z0, z1), 1)           # far wall, facing +x (out)
    quad(2, z0, (x0, x1), (y0, y1), -1)          # side walls
    quad(2, z1, (x0, x1), (y0, y1), 1)
    # the doorway wall x = 0, facing -x, with a hole z in DOOR_Z, y below DOOR_TOP
    quad(0, x0, (y0, y1), (z0, DOOR_Z[0]), -1)
    quad(0, x0, (y0, y1), (DOOR_Z[1], z1), -1)
    quad(0, x0, (DOOR_TOP, y1), DOOR_Z, -1)
    # an enclosing hall facing in (correctly wound), so eyes outside the room are in free space
    (hx0, hy0, hz0), (hx1, hy1, hz1) = (-12.0, -0.5, -4.0), (18.0, 5.0, 14.0)
    quad(1, hy0, (hz0, hz1), (hx0, hx1), 1)
    quad(1, hy1, (hz0, hz1), (hx0, hx1), -1)
    quad(0, hx0, (hy0, hy1), (hz0, hz1), 1)
    quad(0, hx1, (hy0, hy1), (hz0, hz1), -1)
    quad(2, hz0, (hx0, hx1), (hy0, hy1), 1)
    quad(2, hz1, (hx0, hx1), (hy0, hy1), -1)
    spheres = []
    for centre, radius in (((3.0, 1.0, 5.0), 0.8), ((7.0, 1.5, 3.0), 1.0),
                           ((6.0, 1.0, 7.5), 0.7), ((14.0, 1.5, 5.0), 1.0),
                           ((-8.0, 1.5, 5.0), 0.5)):
        s = trimesh.creation.icosphere(subdivisions=2, radius=radius)
        s.apply_translation(centre)
        spheres.append(s)
    return World.from_trimesh(trimesh.util.concatenate(quads + spheres))


def aimed_cameras(count, seed):
    """Cameras west of the doorway aimed at random points inside the room through it."""
    rng = np.random.default_rng(seed)
    cams = []
    for _ in range(count):
        eye = np.array([rng.uniform(-6.0, -0.5), rng.uniform(0.4, 2.0), rng.uniform(3.0, 7.0)])
        door = np.array([0.0, rng.uniform(0.2, DOOR_TOP - 0.2),
                         rng.uniform(DOOR_Z[0] + 0.2, DOOR_Z[1] - 0.2)])
        d = door - eye
        yaw = float(yaw_toward(d[0], d[2]))
        pitch = float(np.degrees(np.arctan2(d[1], np.hypot(d[0], d[2]))))
        cams.append(Camera(eye, yaw=yaw, pitch=pitch, fov=float(rng.uniform(20, 90)),
                           aspect=4 / 3))
    return cams


@pytest.fixture(scope="module")
def room():
    return outward_room_world()


# cell faces on the room's walls (x = 0, x = 10, y = 3, z = 0, z = 10) in the last case
ON_WALLS = {"slabs": ((12 / 30, 10 / 30, 8 / 30), (3.5 / 5.5, 2 / 5.5), (4 / 18, 10 / 18, 4 / 18))}
CASES = [({"slabs": (5, 3, 5)}, False), ({"cells": 64}, False), (ON_WALLS, False),
         ({"slabs": (5, 3, 5)}, True), ({"cells": 64}, True),
         # Known limit: with back faces culled, a one-sided wall lying in a cell face lets
         # sight through from behind (the room's far wall, seen from inside); the portals
         # still close the face both ways. Directed portals would fix it (not done).
         pytest.param(ON_WALLS, True, marks=pytest.mark.xfail(strict=True, reason=(
             "a one-sided wall in a cell face, seen from behind with back faces culled")))]


@pytest.mark.parametrize("params,cull_back", CASES)
def test_portals_keep_the_inside_of_an_outward_facing_room(kit, room, params, cull_back):
    part = partition(room, "portal", depth=1, **params)
    inside = np.flatnonzero(((room.centroids > ROOM[0] + 0.1)
                             & (room.centroids < ROOM[1] - 0.1)).all(axis=1))
    stages = "portals,tbfc" if cull_back else "portals"
    seen_inside = fallbacks = 0
    for cam in aimed_cameras(30, 1):
        truth = kit.visible_ids(room, cam, cull_back)
        result = Culler(part, stages).cull(cam)
        fallbacks += result.stats.get("portals.fallbacks", 0)
        missing = np.setdiff1d(truth, result.triangles)
        assert not len(missing), f"{stages} dropped {len(missing)} of {len(truth)}: {cam}"
        seen_inside += len(np.intersect1d(truth, inside))
    assert seen_inside > 0  # the cameras do see into the room
    assert fallbacks < 30  # and the portals ran (eyes in free space)


def test_only_closed_outward_parts_are_solid(room):
    # The room (open at its doorway, facing out) and the hall (closed, facing in) are no
    # solids; the five icospheres (closed, facing out) are. Reversed, a sphere is none.
    from vismobile.partition.solids import outward_solid_faces

    quads = 2 * (8 + 6)  # the room's and the hall's quads come first
    solid = outward_solid_faces(room)
    assert not solid[:quads].any() and solid[quads:].all() and solid.sum() == 5 * 320
    triangles = room.triangles.copy()
    triangles[quads:quads + 320] = triangles[quads:quads + 320, ::-1]
    flipped = World(room.vertices, triangles, room.object_ids)
    assert outward_solid_faces(flipped).sum() == 4 * 320

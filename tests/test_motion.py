"""world/motion.py and world/animated.py: keyframe sampling (linear, slerp, step, clamp, loop),
matrices about a pivot, posed worlds keeping triangle ids, moved boxes holding their vertices."""
import numpy as np
import pytest

from vismobile.world.animated import AnimatedWorld, moved_boxes
from vismobile.world.motion import Motion, Track
from vismobile.world.world import World

TURN = (0.0, np.sin(np.pi / 4), 0.0, np.cos(np.pi / 4))  # 90 degrees about +y


def two_cubes():
    """Two unit cubes sharing a corner vertex (object 0 at the origin, object 1 at x = 1)."""
    import trimesh

    box = trimesh.creation.box(extents=(1, 1, 1))
    v = np.vstack([box.vertices + 0.5, box.vertices + [1.5, 0.5, 0.5]])
    t = np.vstack([box.faces, box.faces + 8])
    return World(v, t, np.repeat([0, 1], 12), ["still", "walker"])


def test_linear_translation_and_clamp():
    m = Motion([Track(0, translation=([0.0, 2.0], [[0, 0, 0], [4, 0, 0]]))])
    assert np.allclose(m.sample(1.0)["translation"], [[2, 0, 0]])
    assert np.allclose(m.sample(-1.0)["translation"], [[0, 0, 0]])
    assert np.allclose(m.sample(9.0)["translation"], [[4, 0, 0]])  # clamped past the end


def test_loop_wraps_and_step_holds():
    m = Motion([Track(0, translation=([0.0, 1.0, 2.0], [[0, 0, 0], [1, 0, 0], [2, 0, 0]]),
                      interpolation="step", loop=True)])
    assert np.allclose(m.sample(1.5)["translation"], [[1, 0, 0]])
    assert np.allclose(m.sample(2.5)["translation"], [[0, 0, 0]])  # 2.5 mod 2 = 0.5: key 0


def test_slerp_halfway_and_shortest_arc():
    m = Motion([Track(0, rotation=([0.0, 1.0], [[0, 0, 0, 1], TURN]))])
    q = m.sample(0.5)["rotation"][0]
    assert np.isclose(np.linalg.norm(q), 1.0)
    assert np.isclose(2 * np.degrees(np.arccos(q[3])), 45.0)
    flipped = Motion([Track(0, rotation=([0.0, 1.0], [[0, 0, 0, 1], -np.array(TURN)]))])
    assert np.allclose(np.abs(flipped.sample(0.5)["rotation"]), np.abs(q))


def test_matrix_turns_about_the_pivot():
    m = Motion([Track(3, rotation=([0.0], [TURN]), pivot=(1.0, 0.0, 0.0))])
    ids, mats = m.matrices(0.0)
    assert list(ids) == [3]
    point = mats[0] @ [2.0, 0.0, 0.0, 1.0]
    assert np.allclose(point[:3], [1.0, 0.0, -1.0])  # +x about +y by 90: -z
    assert np.allclose(mats[0] @ [1.0, 0, 0, 1], [1.0, 0, 0, 1])


@pytest.mark.parametrize("bad", [
    dict(translation=([0.0, 0.0], [[0, 0, 0], [1, 0, 0]])),  # times not increasing
    dict(translation=([0.0], [[0, 0]])),  # wrong width
    dict(rotation=([0.0], [[0, 0, 0, 0]])),  # zero quaternion
    dict(translation=([0.0], [[np.nan, 0, 0]])),
    dict(translation=([0.0], [[0, 0, 0]]), interpolation="cubic")])
def test_bad_tracks_are_refused(bad):
    with pytest.raises(ValueError):
        Motion([Track(0, **bad)])


def test_posed_world_keeps_ids_and_shares_static_rows():
    world = two_cubes()
    a = AnimatedWorld(world, Motion([Track(1, translation=([0.0, 1.0], [[0, 0, 0], [0, 3, 0]]))]))
    assert list(a.moving_object_ids) == [1] and a.moving_mask.sum() == 12
    posed = a.posed(1.0)
    assert posed.triangle_count == world.triangle_count
    assert np.array_equal(posed.object_ids, world.object_ids)
    assert np.allclose(posed.corners[:12], world.corners[:12])  # the still cube (and the
    assert np.allclose(posed.corners[12:], world.corners[12:] + [0, 3, 0])  # shared corner)
    assert np.allclose(posed.normals, world.normals)
    assert np.allclose(a.posed(None).corners, world.corners)
    ids, boxes = a.bounds_at(0.5)
    assert np.allclose(boxes[0], [[1, 1.5, 0], [2, 2.5, 1]])


def test_moved_boxes_hold_every_moved_vertex():
    rng = np.random.default_rng(3)
    points = rng.normal(size=(50, 3))
    box = np.stack([points.min(0), points.max(0)])[None]
    for _ in range(20):
        q = rng.normal(size=4)
        tracks = [Track(0, translation=([0.0], [rng.normal(size=3) * 100]), rotation=([0.0], [q]),
                        scale=([0.0], [rng.uniform(0.1, 3, 3)]), pivot=tuple(rng.normal(size=3)))]
        mat = Motion(tracks).matrices(0.0)[1]
        moved = points @ mat[0, :3, :3].T + mat[0, :3, 3]
        out = moved_boxes(box, mat)[0]
        assert np.all(moved >= out[0]) and np.all(moved <= out[1])

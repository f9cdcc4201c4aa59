"""The six thesis worlds: Table 5.2 counts, determinism, single-sided walls, real occlusion."""
import hashlib

import numpy as np
import pytest

from vismobile.open3d_import import raycast_primitive_ids
from vismobile.scenes import TARGETS, build_world
from vismobile.scenes.building import make_plan
from vismobile.scenes.thesis import TOLERANCE, W2_OBJECTS


@pytest.mark.parametrize("name", sorted(TARGETS))
def test_world_totals_within_half_a_percent_of_table_5_2(thesis_world, name):
    world = thesis_world(name)
    assert abs(world.triangle_count / TARGETS[name].triangles - 1) <= TOLERANCE


def test_w1_and_w4_hit_their_targets_exactly(thesis_world):
    assert thesis_world("w1").triangle_count == 6199
    assert thesis_world("w4").triangle_count == 30199


def test_w2_and_w3_hold_the_same_objects(thesis_world):
    w1, w2, w3 = (thesis_world(n) for n in ("w1", "w2", "w3"))
    extra = lambda w: sorted(set(w.object_names) - set(w1.object_names))  # noqa: E731
    assert extra(w2) == extra(w3)
    assert len(extra(w2)) == len(W2_OBJECTS)
    for world in (w2, w3):
        counts = np.bincount(world.object_ids, minlength=len(world.object_names))
        by_name = dict(zip(world.object_names, counts))
        assert all(by_name[n] == 5288 for n in extra(world) if n.startswith("flower"))


def test_object_names_are_distinct(thesis_world):
    for name in TARGETS:
        names = thesis_world(name).object_names
        assert len(names) == len(set(names))


@pytest.mark.parametrize("name", ["w1", "w5"])
def test_building_twice_gives_byte_identical_obj(tmp_path, name):
    build_world(name, tmp_path / "a", rebuild=True)
    build_world(name, tmp_path / "b", rebuild=True)
    assert (tmp_path / "a" / f"{name}.obj").read_bytes() == (tmp_path / "b" / f"{name}.obj").read_bytes()


def test_cache_is_rebuilt_when_stale(tmp_path):
    first = build_world("w5", tmp_path)
    (tmp_path / "w5.key").write_text("stale\n")
    (tmp_path / "w5.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    assert build_world("w5", tmp_path).digest() == first.digest()


def test_unknown_world_name_raises():
    with pytest.raises(KeyError):
        build_world("w9")


def room_eyes(plan):
    """(R, 3) eye points 1.7 m above the middle of every room's floor."""
    return np.array([[b[:, 0].mean(), b[0, 1] + 1.7, b[:, 2].mean()] for b in plan.rooms.values()])


def test_every_surface_seen_from_inside_faces_the_viewer(w1):
    eyes = room_eyes(make_plan())
    rng = np.random.default_rng(7)
    directions = rng.normal(size=(len(eyes) * 400, 3))
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    origins = np.repeat(eyes, 400, axis=0)
    ids = raycast_primitive_ids(w1.vertices, w1.triangles, origins, directions)
    hit = ids >= 0
    assert hit.mean() > 0.98  # the rest leave through windows
    facing = np.einsum("ij,ij->i", w1.normals[ids[hit]], directions[hit])
    assert (facing < 0).all()


def test_the_building_occludes_most_rooms_from_each_room(w1):
    """From each room's middle, at most 5 of the 39 other rooms' middles are in sight."""
    eyes = room_eyes(make_plan())
    count = len(eyes)
    origins = np.repeat(eyes, count, axis=0)
    offsets = np.tile(eyes, (count, 1)) - origins
    lengths = np.linalg.norm(offsets, axis=1)
    mask = lengths > 0
    directions = offsets[mask] / lengths[mask, None]
    ids = raycast_primitive_ids(w1.vertices, w1.triangles, origins[mask], directions)
    corners = w1.corners[ids]
    normal = w1.normals[ids]
    # distance to the hit triangle's plane along the ray
    t = np.einsum("ij,ij->i", normal, corners[:, 0] - origins[mask]) / np.einsum(
        "ij,ij->i", normal, directions)
    blocked = (ids >= 0) & (t < lengths[mask] - 1e-6)
    seen = (~blocked).reshape(count, count - 1).sum(axis=1)
    assert seen.max() <= 5
    assert np.median(seen) <= 1


def test_closed_objects_are_wound_outward(thesis_world):
    w2 = thesis_world("w2")
    w1_names = set(thesis_world("w1").object_names)
    for index, name in enumerate(w2.object_names):
        if name in w1_names:
            continue
        corners = w2.corners[w2.object_ids == index]
        centre = corners.reshape(-1, 3).mean(axis=0)
        a, b, c = (corners[:, k] - centre for k in range(3))
        volume = np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6
        assert volume > 0, name


def test_objects_stand_on_floors(thesis_world):
    w2 = thesis_world("w2")
    w1_names = set(thesis_world("w1").object_names)
    for index, name in enumerate(w2.object_names):
        if name not in w1_names:
            low = w2.corners[w2.object_ids == index][:, :, 1].min()
            assert min(abs(low - 0.0), abs(low - 3.2)) < 1e-3, name


# SHA-256 of each built OBJ, made with the models shipped in vismobile/scenes/models and
# open3d 0.20.0 (whose quadric decimation places W2, W3, W4 and W6's objects).
PINS = {
    "w1": "8500494582416203f16579a1819b4ba8e270d43f5e03aed817b6e727b5ba5e0d",
    "w2": "d6f78e3649861cda42b3db21b0f392a93e5cd5b2ff46081187bae521c5bbe051",
    "w3": "258fb95d42d75f29b03ee5b54e53baf0e4739c2f03364330cbce30090a122f96",
    "w4": "fa5723d734bcdc1cac0b133a1cc2b38ebd9c95edb30444fd90c95a875d56dd22",
    "w5": "0f1abc19a0c42394e1c8e0e9ee1e18910876e823b7ec7ed7fd1af46609a041a4",
    "w6": "3961c36c45f319dceb5917638a9a06e862d135ff4a813b8d3484cc2de9ddd32c",
}
PINNED_OPEN3D = "0.20.0"


@pytest.mark.parametrize("name", sorted(PINS))
def test_built_worlds_match_their_pinned_sha256(thesis_world, name):
    from vismobile.open3d_import import open3d
    from vismobile.scenes import default_cache_dir

    if name not in ("w1", "w5") and open3d().__version__ != PINNED_OPEN3D:
        pytest.skip(f"{name} places objects decimated by open3d; pinned with {PINNED_OPEN3D}, "
                    f"running {open3d().__version__}, whose decimation may differ")
    thesis_world(name)
    digest = hashlib.sha256((default_cache_dir() / f"{name}.obj").read_bytes()).hexdigest()
    assert digest == PINS[name]


def test_quantized_keeps_ids_and_refuses_what_the_mode_cannot_hold():
    from vismobile.errors import ProfileError
    from vismobile.scenes.stress import base_world

    world = base_world()
    rounded = world.transformed(1.0, (1e3, 1e3, 1e3)).quantized("fixed16.16")
    assert rounded.triangle_count == world.triangle_count
    assert np.array_equal(rounded.vertices * 65536, np.rint(rounded.vertices * 65536))
    with pytest.raises(ProfileError, match="range"):
        world.transformed(1.0, (1e5, 0, 0)).quantized("fixed16.16")
    with pytest.raises(ProfileError, match="cannot resolve"):
        world.transformed(1.0, (1e7, 0, 0)).quantized("float32")
    with pytest.raises(ProfileError, match="cannot resolve"):
        world.transformed(1e-4).quantized("fixed16.16")


def test_to_obj_writes_coordinates_exactly(tmp_path):
    """Far from the origin 6 significant digits would move vertices by up to 0.5 units."""
    from vismobile.world.world import World

    vertices = np.array([[1e5 + 0.123456789, 2.5, -3.0], [1e5 + 1.0, 2.5, -3.0],
                         [1e5, 3.5, -2.0 / 3.0]])
    World(vertices, np.array([[0, 1, 2]]), np.zeros(1, dtype=np.int32), ["tri"], "far").to_obj(
        tmp_path / "far.obj")
    back = World.from_obj(tmp_path / "far.obj")
    assert np.array_equal(back.vertices, vertices)


def test_to_obj_reports_progress_and_writes_the_same_file(tmp_path, monkeypatch):
    import vismobile.world.world as world_module
    from vismobile.world.world import World

    world = World(np.random.default_rng(0).random((50, 3)),
                  np.arange(60).reshape(20, 3) % 50, np.repeat([0, 1], 10), ["a", "b"])
    world.to_obj(tmp_path / "one.obj")
    monkeypatch.setattr(world_module, "OBJ_CHUNK", 7)
    calls = []
    world.to_obj(tmp_path / "two.obj", progress=lambda done, total: calls.append((done, total)))
    assert (tmp_path / "one.obj").read_bytes() == (tmp_path / "two.obj").read_bytes()
    assert calls[-1] == (70, 70) and len(calls) > 5
    assert [d for d, _ in calls] == sorted(d for d, _ in calls)

"""files/gltf_anim.py and files/motionfile.py: glTF/GLB node animations (LINEAR, STEP; parent
transforms; CUBICSPLINE and nested animated nodes refused) and the JSON motion file; every bad
file is one WorldError naming it."""
import json

import numpy as np
import pytest

from vismobile.errors import WorldError
from vismobile.files.gltf_write import animated_glb
from vismobile.world.animated import AnimatedWorld
from vismobile.world.world import World

CUBE_V = np.array([[x, y, z] for x in (-0.5, 0.5) for y in (-0.5, 0.5) for z in (-0.5, 0.5)])
CUBE_F = np.array([[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1],
                   [2, 3, 7], [2, 7, 6], [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]])


def scene(tmp_path, channels, parents=None, name="scene.glb", root_translation=None):
    meshes = [dict(name="floor", vertices=CUBE_V * [10, 0.1, 10], faces=CUBE_F),
              dict(name="walker", vertices=CUBE_V, faces=CUBE_F, translation=[0, 1, 0])]
    if root_translation is not None:
        meshes[0]["translation"] = root_translation
    path = tmp_path / name
    animated_glb(path, meshes, channels, parents)
    return path


def walker_centre(animated, t):
    world = animated.posed(t)
    oid = world.object_names.index("walker")
    return world.corners[world.object_ids == oid].reshape(-1, 3).mean(axis=0)


def test_linear_and_step_channels(tmp_path):
    path = scene(tmp_path, [(1, "translation", [0, 1, 2], [[0, 1, 0], [4, 1, 0], [4, 1, 4]],
                             "LINEAR")])
    a = AnimatedWorld.from_gltf(path)
    assert a.world.triangle_count == 24 and len(a.motion) == 1
    assert np.allclose(walker_centre(a, 0.5), [2, 1, 0])
    assert np.allclose(walker_centre(a, 5.0), [4, 1, 4])  # clamped
    step = AnimatedWorld.from_gltf(scene(tmp_path, [(1, "translation", [0, 1], [[0, 1, 0],
                                                                             [4, 1, 0]], "STEP")],
                                         name="step.glb"))
    assert np.allclose(walker_centre(step, 0.9), [0, 1, 0])


def test_rotation_under_a_moved_parent(tmp_path):
    # the walker is the floor's child; the floor sits at x = 5: the turn is about the walker
    path = scene(tmp_path, [(1, "rotation", [0, 1], [[0, 0, 0, 1], [0, 1, 0, 0]], "LINEAR")],
                 parents=[None, 0], root_translation=[5, 0, 0])
    a = AnimatedWorld.from_gltf(path)
    assert np.allclose(walker_centre(a, 0.0), [5, 1, 0])
    assert np.allclose(walker_centre(a, 0.7), [5, 1, 0])  # turning in place
    corners = a.posed(1.0).corners[a.moving_triangles].reshape(-1, 3)
    assert np.allclose(np.sort(corners[:, 0]), np.sort(a.world.corners[a.moving_triangles]
                                                       .reshape(-1, 3)[:, 0]))


@pytest.mark.parametrize("channels,parents,needle", [
    ([(1, "translation", [0, 1], np.zeros((6, 3)), "CUBICSPLINE")], None, "CUBICSPLINE"),
    ([(0, "translation", [0, 1], np.zeros((2, 3)), "LINEAR"),
      (1, "translation", [0, 1], np.zeros((2, 3)), "LINEAR")], [None, 0], "nested"),
    ([(1, "translation", [0, 1, 2], np.zeros((2, 3)), "LINEAR")], None, "values"),
    ([(1, "translation", [1, 0], np.zeros((2, 3)), "LINEAR")], None, "increasing")])
def test_refused_animations_name_the_file(tmp_path, channels, parents, needle):
    path = scene(tmp_path, channels, parents)
    with pytest.raises(WorldError) as error:
        AnimatedWorld.from_gltf(path)
    assert str(path) in str(error.value) and needle in str(error.value)


def test_truncated_and_garbage_glb(tmp_path):
    good = scene(tmp_path, [(1, "translation", [0, 1], np.zeros((2, 3)), "LINEAR")])
    data = good.read_bytes()
    for k, bad in enumerate((data[:len(data) // 2], b"glTF" + b"\xff" * 40, b"")):
        path = tmp_path / f"bad{k}.glb"
        path.write_bytes(bad)
        with pytest.raises(WorldError, match=f"bad{k}.glb"):
            AnimatedWorld.from_gltf(path)


def motion_file(tmp_path, doc):
    path = tmp_path / "motion.json"
    path.write_text(json.dumps(doc) if not isinstance(doc, str) else doc)
    return path


def test_motion_file_attaches_paths_by_name(tmp_path):
    world = World(np.vstack([CUBE_V, CUBE_V + [3, 0, 0]]), np.vstack([CUBE_F, CUBE_F + 8]),
                  np.repeat([0, 1], 12), ["box", "car"])
    path = motion_file(tmp_path, {"fps": 25, "objects": {"car": {
        "times": [0, 1], "translation": [[0, 0, 0], [0, 0, 2]],
        "rotation": [[0, 0, 0, 1], [0, 1, 0, 0]], "loop": True}}})
    a = AnimatedWorld.from_motion_file(world, path)
    assert a.motion.fps == 25 and list(a.moving_object_ids) == [1]
    centre = a.posed(0.5).corners[12:].reshape(-1, 3).mean(axis=0)
    assert np.allclose(centre, [3, 0, 1])  # turning about its own centre (the default pivot)
    assert np.allclose(a.posed(1.5).corners[12:].reshape(-1, 3).mean(axis=0), [3, 0, 1])


@pytest.mark.parametrize("doc,needle", [
    ("{not json", "not a JSON"),
    ({"objects": {"nobody": {"times": [0], "translation": [[0, 0, 0]]}}}, "nobody"),
    ({"objects": {"car": {"times": [0, 0], "translation": [[0, 0, 0]] * 2}}}, "increasing"),
    ({"objects": {"car": {"times": [0], "translation": [[0, 0]]}}}, "3 numbers"),
    ({"objects": {"car": {"times": [0], "rotation": [[0, 0, 0, 0]]}}}, "zero quaternion"),
    ({"objects": {"car": {"times": [0], "translation": [[1e400, 0, 0]]}}}, "finite"),
    ({"objects": {"car": {"times": [0]}}}, "no translation"),
    ({"objects": {"car": {"times": [0], "scale": [[1, 1, 1]], "interpolation": "cubic"}}},
     "interpolation"),
    ({"fps": -1, "objects": {}}, "fps"),
    ({"objects": [], "extra": 1}, "objects")])
def test_bad_motion_files_name_the_file(tmp_path, doc, needle):
    world = World(CUBE_V, CUBE_F, np.zeros(12), ["car"])
    path = motion_file(tmp_path, doc)
    with pytest.raises(WorldError) as error:
        AnimatedWorld.from_motion_file(world, path)
    assert str(path) in str(error.value) and needle in str(error.value), str(error.value)

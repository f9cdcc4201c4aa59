"""The Python API a newcomer finds (issue 31): help(vismobile) lists the public names, the CLI's
structure grammar works in partition(), and the main objects print in one line."""
import pydoc

import numpy as np

import vismobile
from vismobile import Culler, Trajectory, partition
from vismobile.scenes import build_world


def test_help_lists_the_public_classes_and_functions():
    text = pydoc.render_doc(vismobile, renderer=pydoc.plaintext)
    classes = text[text.index("CLASSES"):text.index("FUNCTIONS")]
    functions = text[text.index("FUNCTIONS"):]
    for name in ("World", "Culler", "Camera", "Trajectory", "Partition", "Profile"):
        assert f".{name}" in classes, name
    for name in ("partition(", "play(", "render_rgb(", "tune(", "get_profile("):
        assert name in functions, name
    assert "__getattr__" not in text
    assert set(vismobile.__all__) <= set(dir(vismobile))


def test_partition_takes_the_cli_grammar():
    world = build_world("w5")
    tree = partition(world, "octree:3")
    assert tree.kind == "octree" and tree.params["depth"] == 3
    assert partition(world, "octree", depth=3).node_count == tree.node_count
    assert partition(world, "grid:4").kind == "grid"
    assert partition(world, "bsp:min_leaf=64").kind == "bsp"


def test_one_line_reprs():
    world = build_world("w5")
    culler = Culler(partition(world, "octree:3"), "vfc+bfc")
    poses = np.column_stack([np.linspace(60, 160, 500), np.full(500, 1.7), np.zeros(500),
                             np.zeros(500), np.zeros(500)])
    walk = Trajectory(poses, {"A": 3})
    result = culler.cull(walk.camera(0))
    for obj, start in ((culler, "Culler(vfc+bfc over octree of 2,548 triangles"),
                       (result, "CullResult("), (walk, "Trajectory(500 frames")):
        text = repr(obj)
        assert text.startswith(start) and "\n" not in text and len(text) < 160, text
    assert f"{len(result.triangles):,} triangles" in repr(result) and "A@3" in repr(walk)

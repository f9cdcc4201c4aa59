"""Issue 25's fuzz targets (tools/fuzz.py imports them): GLB node animations (animglb), JSON
motion files on the cube world (motion), a motion file as `play --motion` takes it
(playmotion), --fps values (fps) and `play --regional` choices (regional): their seeds and
entry points. Each entry loads or ends in a VisMobileError."""
from __future__ import annotations

from pathlib import Path

# A motion file for the cube world (load_motion): linear, step and looping paths.
MOTION_JSON = (b'{"fps": 30, "objects": {"c": {"times": [0, 1.5, 3], "translation": [[0, 0, 0], '
               b'[2, 0, 0], [2, 0, 2]], "rotation": [[0, 0, 0, 1], [0, 0.7071, 0, 0.7071], '
               b'[0, 1, 0, 0]], "scale": [[1, 1, 1], [2, 2, 2], [1, 1, 1]], "loop": true, '
               b'"interpolation": "linear", "pivot": [0.5, 0.5, 0.5]}}}')


def animated_seeds(folder: Path) -> dict:
    """Seeds of issue 25's inputs: a GLB with node animations (translation, rotation and scale
    channels, LINEAR and STEP, a child under a moved parent) and a JSON motion file."""
    import numpy as np

    import hostile_writers as hostile
    from vismobile.files.gltf_write import animated_glb

    cube = dict(vertices=np.asarray(hostile.CUBE_V, float), faces=hostile.CUBE_F)
    meshes = [dict(cube, name="ground", translation=[0, -1, 0]), dict(cube, name="walker"),
              dict(cube, name="turner", translation=[3, 0, 0])]
    channels = [(1, "translation", [0, 1, 2], [[0, 0, 0], [2, 0, 0], [2, 0, 2]], "LINEAR"),
                (2, "rotation", [0, 1], [[0, 0, 0, 1], [0, 1, 0, 0]], "STEP"),
                (2, "scale", [0, 1], [[1, 1, 1], [2, 2, 2]], "STEP")]
    animated_glb(folder / "seed-anim.glb", meshes, channels, parents=[None, 0, None])
    return {"animglb": [(folder / "seed-anim.glb").read_bytes()], "motion": [MOTION_JSON],
            "playmotion": [MOTION_JSON, DOOR_JSON], "fps": FPS_TEXTS,
            "regional": REGIONAL_TEXTS}


# play's and view's --motion as the commands take it (issue 25 deliverable 5): a hinge track
# about a pivot (W7's doors), held shut then open, as scenes/crowd.py writes them.
DOOR_JSON = (b'{"fps": 24, "objects": {"c": {"times": [0, 0.5, 1], "rotation": [[0, 0, 0, 1], '
             b'[0, 0.3827, 0, 0.9239], [0, 0.7071, 0, 0.7071]], "pivot": [0, 0, 0], '
             b'"interpolation": "step"}}}')
# play --regional choices (compare's --cull grammar, ';' between combinations).
REGIONAL_TEXTS = [b"portals+tbfc;vfc+occlusion+tbfc", b"vfc;portals", b"pvs+vfc;vfc+tbfc"]
# --fps values (commands/options.py RANGES: (0, 1e4]).
FPS_TEXTS = [b"30", b"24.5", b"0.001", b"10000"]


def load_animated(path):
    from vismobile.world.animated import AnimatedWorld

    AnimatedWorld.from_gltf(path).posed(0.7)


def load_motion(path):
    """A JSON motion file attached to the cube world (object "c"), posed."""
    import hostile_writers as hostile
    from vismobile.world.animated import AnimatedWorld
    from vismobile.world.world import World

    cube = World.from_arrays(hostile.CUBE_V, hostile.CUBE_F, [0] * 12, ["c"])
    AnimatedWorld.from_motion_file(cube, path).posed(2.2)


def load_play_motion(path):
    """A motion file as `play --motion` takes it: the cube world (object "c") as an OBJ, its
    octree, the motion attached, two frames culled (vfc+tbfc at each frame's time) and drawn
    with the moving cube posed."""
    import numpy as np

    import hostile_writers as hostile
    from vismobile.app.playback import load_scene, play
    from vismobile.world.trajectory import Trajectory
    from vismobile.world.world import World

    obj = Path(path).with_name("cube.obj")
    World.from_arrays(hostile.CUBE_V, hostile.CUBE_F, [0] * 12, ["c"]).to_obj(obj)
    scene = load_scene(obj, "octree:2", motion=path)
    walk = Trajectory(np.array([[0.5, 0.5, 6.0, 0.0, 0.0], [0.5, 0.5, 5.0, 10.0, 0.0]]))
    play(scene, walk, ("vfc", "tbfc"))


def load_fps(path):
    """--fps text through play's parser, its RANGES check and the scene's fps check."""
    from vismobile.app.animation import check_fps
    from vismobile.app.cli import build_parser
    from vismobile.commands import options
    from vismobile.errors import VisMobileError

    text = path.read_bytes()[:256].decode("utf-8", errors="replace")
    try:
        args = build_parser().parse_args(["play", "w1", "-o", str(path) + ".out", "--fps",
                                          text])
    except SystemExit:  # argparse's own refusal (exit 2, one usage line)
        raise VisMobileError(f"--fps {text!r}: not a number") from None
    options.check(args)
    assert 0.0 < check_fps(args.fps) <= 1e4


def load_regional(path):
    """play --regional text: parsed (commands/play.regional_choices) and, when it parses, a
    RegionalCuller over the cube's portal structure culls one camera."""
    import hostile_writers as hostile
    from vismobile.app.playback import Scene, make_culler
    from vismobile.commands.play import regional_choices
    from vismobile.partition import partition
    from vismobile.world.camera import Camera
    from vismobile.world.world import World

    text = path.read_bytes()[:4096].decode("utf-8", errors="replace")
    choices = regional_choices(text)
    cube = World.from_arrays(hostile.CUBE_V, hostile.CUBE_F, [0] * 12, ["c"])
    scene = Scene(cube, partition(cube, "portal", depth=1), "portal:1")
    make_culler(scene, (), None, regional=choices).cull(Camera((0.5, 0.5, 4.0)))


ENTRY = {"animglb": (load_animated, ".glb"), "motion": (load_motion, ".json"),
         "playmotion": (load_play_motion, ".json"), "fps": (load_fps, ".txt"),
         "regional": (load_regional, ".txt")}

"""Moving objects as occluders (culling/moving_occluders.py): a moving wall hides what stands
behind it only where it stands this frame. The wall slides away between two frames; culling
with last frame's pose would drop what it uncovered."""
import numpy as np
import pytest

from vismobile.culling import Culler, device_options
from vismobile.device.profile import get_profile
from vismobile.files.gltf_write import animated_glb
from vismobile.partition import partition
from vismobile.render.device_view import device_buffers, shown_ids
from vismobile.world.animated import AnimatedWorld
from vismobile.world.camera import Camera

FACES = np.array([[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1],
                  [2, 3, 7], [2, 7, 6], [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]])
STAGES = ("vfc,occlusion", "vfc,occlusion,tbfc", "occlusion")


def box(lo, hi):
    """An outward box's (8, 3) corners for FACES."""
    return np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1])
                     for z in (lo[2], hi[2])], dtype=float)


@pytest.fixture(scope="module")
def scene(tmp_path_factory):
    """A static floor and target box, a moving box (a walker) beside it, and a moving wall
    between them and the eye at the origin: at t = 0 it covers both, by t = 1 it has slid 8
    units aside (and back by t = 2: the track loops)."""
    path = tmp_path_factory.mktemp("occluders") / "wall.glb"
    meshes = [dict(name="floor", vertices=box((-20, -2, -30), (20, -1.5, 5)), faces=FACES),
              dict(name="target", vertices=box((-0.6, -0.6, -9), (0.4, 0.6, -8)), faces=FACES),
              dict(name="walker", vertices=box((0.5, -0.8, -9), (1.0, 0.4, -8.5)), faces=FACES),
              dict(name="wall", vertices=box((-3, -1.5, -4.2), (3, 2.5, -4)), faces=FACES)]
    animated_glb(path, meshes,
                 [(2, "translation", [0, 2], [[0, 0, 0], [0, 0, 0.5]], "LINEAR"),
                  (3, "translation", [0, 1, 2], [[0, 0, 0], [8, 0, 0], [0, 0, 0]], "LINEAR")])
    animated = AnimatedWorld.from_gltf(path)
    names = list(animated.world.object_names) if hasattr(animated.world, "object_names") else []
    return animated, partition(animated, "octree:2"), names


def ids_of(animated, name_index):
    """World triangle ids of mesh node name_index (0 floor, 1 target, 2 walker, 3 wall): 12
    each, in the file's order."""
    return np.arange(12 * name_index, 12 * name_index + 12)


def test_the_wall_hides_only_where_it_stands_now(kit, scene):
    animated, part, _ = scene
    cam = Camera((0.0, 0.0, 0.0), yaw=0.0, pitch=0.0, aspect=kit.ASPECT)
    target, walker = ids_of(animated, 1), ids_of(animated, 2)
    for stages in STAGES:
        culler = Culler(part, stages)
        hidden = culler.cull(cam, time=0.0)
        # t = 0: the wall covers the target and the walker (the item buffer shows neither)
        truth = kit.visible_ids(animated.posed(0.0), cam, False)
        assert not np.intersect1d(truth, np.concatenate([target, walker])).size
        assert not len(np.setdiff1d(truth, hidden.triangles))
        assert hidden.stats.get("occlusion.moving_occluders", 0) > 0
        assert not np.intersect1d(hidden.triangles, target).size, stages  # the gain
        assert not np.intersect1d(hidden.triangles, walker).size, stages
        # t = 1: the wall stands 8 units aside; the same culler, next frame: what it uncovered
        # is shown and kept (last frame's wall would hide it)
        shown = culler.cull(cam, time=1.0)
        truth = kit.visible_ids(animated.posed(1.0), cam, False)
        assert np.intersect1d(truth, target).size and np.intersect1d(truth, walker).size
        assert not len(np.setdiff1d(truth, shown.triangles)), stages
        # and back at t = 2: hidden again
        again = culler.cull(cam, time=2.0)
        assert not np.intersect1d(again.triangles, target).size


def test_without_moving_occluders_the_wall_hides_nothing(kit, scene):
    """The gain above is the moving occluders' (the static ones hide nothing here)."""
    animated, part, _ = scene
    cam = Camera((0.0, 0.0, 0.0), yaw=0.0, pitch=0.0, aspect=kit.ASPECT)
    culler = Culler(part, "vfc,occlusion")
    culler.stages[-1].extra_occluders = None
    assert np.intersect1d(culler.cull(cam, time=0.0).triangles, ids_of(animated, 1)).size


@pytest.mark.parametrize("fmt", [None, "float32", "fixed16.16"])
def test_random_cameras_and_times_drop_nothing(kit, scene, fmt):
    """Cameras around the wall at random times, looking at the target: 0 dropped against the
    item buffer of the frame's pose (float64, or the device's float32 / fixed16.16 buffers),
    and the moving wall hides something in some frames."""
    animated, part, _ = scene
    profile = None if fmt is None else get_profile(kit.PROFILE.name, fmt)
    options = {} if profile is None else device_options(profile)
    rng = np.random.default_rng(7)
    cullers = {s: Culler(part, s, **options) for s in STAGES}
    gained = 0
    for _ in range(10):
        t = float(rng.uniform(0, 4))
        eye = np.array([rng.uniform(-4, 4), rng.uniform(-1, 2), rng.uniform(-2, 3)])
        d = np.array([0.0, 0.0, -8.5]) - eye
        yaw = float(np.degrees(np.arctan2(-d[0], -d[2])))
        pitch = float(np.degrees(np.arctan2(d[1], np.hypot(d[0], d[2]))))
        cam = Camera(eye, yaw=yaw, pitch=pitch, aspect=kit.ASPECT)
        posed = animated.posed(t)
        for back in (False, True):
            truth = (kit.visible_ids(posed, cam, back) if profile is None
                     else shown_ids(device_buffers(posed, cam, profile, back)))
            for stages, culler in cullers.items():
                if ("tbfc" in stages) != back:
                    continue
                result = culler.cull(cam, time=t)
                missing = np.setdiff1d(truth, result.triangles)
                assert not len(missing), (stages, fmt, t, cam, missing)
                gained += result.stats.get("occlusion.moving_occluders", 0) > 0 and \
                    not np.intersect1d(result.triangles, ids_of(animated, 1)).size
    assert gained > 0

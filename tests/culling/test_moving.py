"""The proof obligation for moving objects (culling/moving.py): every conservative stage and
combination (test_conservative.COMBOS) keeps every triangle the item buffer of the frame's
pose shows, on W2 with animated instances of the shipped models, from random cameras at random
times and from cameras looking at a moving object; in float64 and in the device's float32 and
fixed16.16 vertex formats (render/device_view.py's three buffers)."""
import importlib.util
from pathlib import Path

import numpy as np
import pytest

from vismobile.culling import Culler, device_options, parse_stages
from vismobile.device.profile import get_profile
from vismobile.partition import partition
from vismobile.render.device_view import device_buffers, shown_ids
from vismobile.scenes.animated import animated_instances
from vismobile.world.camera import Camera

_spec = importlib.util.spec_from_file_location(
    "conservative_combos", Path(__file__).with_name("test_conservative.py"))
_combos = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(_combos)
COMBOS, OPTIONS = _combos.COMBOS, _combos.OPTIONS
INSTANCES = 40
KINDS = {"octree": {"depth": 3}, "portal": {"depth": 1}}
_CACHE = {}


def animated_w2(kit):
    if "world" not in _CACHE:
        _CACHE["world"] = animated_instances(kit.world("w2"), INSTANCES, seed=5)
    return _CACHE["world"]


def structure(kit, kind):
    if kind not in _CACHE:
        _CACHE[kind] = partition(animated_w2(kit), kind, **KINDS[kind])
    return _CACHE[kind]


def frames(kit, part, count, seed):
    """(camera, time): random cameras in the world's box at random times, and two in three
    2.5 units from a random moving object at that time, looking at it."""
    animated = part.animated
    rng = np.random.default_rng(seed)
    cams = kit.random_cameras(part.static, count, seed)
    low, high = animated.world.extent
    out = []
    for i, cam in enumerate(cams):
        t = float(rng.uniform(0, 10))
        if i % 3:
            box = animated.bounds_at(t)[1][rng.integers(len(animated.motion))]
            centre = box.mean(axis=0)
            yaw = rng.uniform(0, 360)
            forward = np.array([-np.sin(np.radians(yaw)), 0.0, -np.cos(np.radians(yaw))])
            eye = np.clip(centre - 2.5 * forward, low, high)
            cam = Camera(eye, yaw=yaw, pitch=0.0, aspect=kit.ASPECT)
        out.append((cam, t))
    return out


def check(kit, part, shots, profile=None):
    options = device_options(profile) if profile is not None else {}
    cullers = {}
    for combo in COMBOS:
        if "portals" in combo and part.kind != "portal":
            continue
        extra = OPTIONS.get(combo, {})
        merged = {**options, **{k: {**options.get(k, {}), **v} for k, v in extra.items()}} \
            if options else extra
        cullers[combo] = Culler(part, combo, **merged)
    seen_moving = 0
    for cam, t in shots:
        posed = part.animated.posed(t)
        truth = {}
        for combo, culler in cullers.items():
            back = bool(kit.BACKFACE_STAGES & set(parse_stages(combo)))
            if back not in truth:
                truth[back] = (kit.visible_ids(posed, cam, back) if profile is None else
                               shown_ids(device_buffers(posed, cam, profile, back)))
                seen_moving += int(part.animated.moving_mask[truth[back]].sum())
            sent = culler.cull(cam, time=t).triangles
            missing = np.setdiff1d(truth[back], sent)
            assert not len(missing), (f"{combo} on {part.kind} at t={t:.3f} dropped "
                                      f"{len(missing)} visible triangles, e.g. {missing[:5]} "
                                      f"(moving: {part.animated.moving_mask[missing].sum()}), "
                                      f"camera {cam}")
    assert seen_moving > 0  # the frames did show moving objects


@pytest.mark.parametrize("kind", list(KINDS))
def test_moving_objects_never_drop_visible_triangles(kit, kind):
    part = structure(kit, kind)
    check(kit, part, frames(kit, part, 6, seed=11 + len(kind)))


@pytest.mark.parametrize("fmt", ["float32", "fixed16.16"])
def test_moving_objects_keep_what_the_device_shows(kit, fmt):
    part = structure(kit, "octree")
    check(kit, part, frames(kit, part, 4, seed=23), get_profile(kit.PROFILE, fmt))


def test_static_cull_unchanged_and_time_ignored(kit):
    """A static partition culls the same with or without a time."""
    part = kit.structure("w1", "octree")
    culler = Culler(part, "vfc,occlusion,tbfc")
    cam = kit.random_cameras(part, 1, seed=3)[0]
    assert np.array_equal(culler.cull(cam).triangles, culler.cull(cam, time=2.0).triangles)


@pytest.mark.parametrize("kind", ["octree:2", "portal:1", "bsp", "grid", "kdtree"])
def test_a_world_where_everything_moves(kit, tmp_path, kind):
    """No static triangle left: the static half is one empty node, the moving objects culled."""
    from vismobile.files.gltf_write import animated_glb
    from vismobile.world.animated import AnimatedWorld

    cube = np.array([[x, y, z] for x in (-0.5, 0.5) for y in (-0.5, 0.5) for z in (-0.5, 0.5)])
    faces = np.array([[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1],
                      [2, 3, 7], [2, 7, 6], [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]])
    animated_glb(tmp_path / "all.glb", [dict(name="a", vertices=cube, faces=faces),
                                         dict(name="b", vertices=cube + [0, 0, -3], faces=faces)],
                 [(0, "translation", [0, 1], [[0, 0, 0], [3, 0, 0]], "LINEAR"),
                  (1, "rotation", [0, 1], [[0, 0, 0, 1], [0, 1, 0, 0]], "LINEAR")])
    animated = AnimatedWorld.from_gltf(tmp_path / "all.glb")
    culler = Culler(partition(animated, kind), "vfc,occlusion,tbfc")
    for t in (0.0, 0.4, 0.9, 2.0):
        cam = Camera((0.0, 0.5, 4.0), yaw=0.0, pitch=-5.0, aspect=kit.ASPECT)
        truth = kit.visible_ids(animated.posed(t), cam, True)
        assert len(truth) and not len(np.setdiff1d(truth, culler.cull(cam, time=t).triangles))

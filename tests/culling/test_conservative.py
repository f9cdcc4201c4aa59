"""The proof obligation: no conservative stage, alone or combined, on any thesis world and any
structure, drops a triangle that the full world's item buffer shows (backface culling on in the
buffer when a backface stage is active), on random cameras and cameras on node corners, and on
the hard classes (scenes/hard_cameras.py: pitched +-89, 1e-3 from a wall with near 1e-4, fov 1
and 170, aspects 9/16 to 2.5). Moved and scaled worlds in the device's vertex formats are in
test_device_conservative.py."""
import numpy as np
import pytest

from vismobile.culling import CONSERVATIVE, Culler, parse_stages
from vismobile.scenes.hard_cameras import hard_cameras

COMBOS = ("vfc", "vfc_thesis", "cbfc", "cone", "vfc,cbfc", "vfc,bfc,cbfc,cone", "occlusion",
          "vfc,occlusion", "vfc,occlusion_thesis", "portals", "portals,occlusion,cbfc,cone",
          "tbfc", "vfc,occlusion,tbfc", "portals,occlusion,cbfc,cone,tbfc", "pvs,vfc,tbfc",
          "horizon", "vfc,horizon,tbfc", "vfc+occlusion+tbfc")
# `pvs` here runs on partitions without a bake (its fallback hands on everything); baked sets
# from cameras anywhere in their cells are checked in test_pvs.py.
# Stage options checked too: occlusion with objects' near sides as occluders and the sample test
# at the ground truth's own resolution (the profile's screen).
SCREEN = (240, 320)
EXTRAS = {"occlusion": {"self_occluders": 64, "screen": SCREEN}}
# "vfc+occlusion+tbfc" (the same stages) with the sample buffer (`samples`, the large worlds'
# default) on the thesis worlds.
OPTIONS = {"occlusion": EXTRAS, "vfc,occlusion,tbfc": EXTRAS,
           "vfc+occlusion+tbfc": {"occlusion": {"screen": SCREEN, "samples": True}}}
WORLDS = ("w1", "w2", "w3", "w4", "w5", "w6")
KINDS = ("octree", "portal", "bsp", "grid", "kdtree")


def check_never_drops_visible(kit, part, cameras):
    assert tuple(kit.PROFILE.resolution) == SCREEN
    cullers = {combo: Culler(part, combo, **OPTIONS.get(combo, {})) for combo in COMBOS}
    truth = {}
    for i, cam in enumerate(cameras):
        for combo, culler in cullers.items():
            back = bool(kit.BACKFACE_STAGES & set(parse_stages(combo)))
            if (i, back) not in truth:
                truth[i, back] = kit.visible_ids(part.world, cam, back)
            sent = culler.cull(cam).triangles
            missing = np.setdiff1d(truth[i, back], sent)
            assert not len(missing), (f"{combo} on {part.world.name}/{part.kind} dropped "
                                      f"{len(missing)} visible triangles, e.g. {missing[:5]}, "
                                      f"camera {cam}")


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("name", WORLDS)
def test_conservative_stages_never_drop_visible_triangles(kit, name, kind):
    part = kit.structure(name, kind)
    seed = WORLDS.index(name) * 10 + KINDS.index(kind)
    cameras = kit.random_cameras(part, 2 if name in kit.BIG else 8, seed=seed)
    check_never_drops_visible(kit, part, cameras)


def test_every_conservative_stage_is_checked():
    assert set(CONSERVATIVE) <= set().union(*(parse_stages(combo) for combo in COMBOS))


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("name", ("w1", "w6"))
def test_hard_cameras_never_drop_visible_triangles(kit, name, kind):
    part = kit.structure(name, kind)
    seed = 100 + WORLDS.index(name) * 10 + KINDS.index(kind)
    cameras = [cam for _, cam in hard_cameras(part.world, 1, seed=seed)]
    check_never_drops_visible(kit, part, cameras)

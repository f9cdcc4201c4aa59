"""`pvs` with `vfc` in one compiled call (culling/pvs_frame.py): it hands on exactly the
triangles the staged path hands on (the set's topmost nodes walked by vfc, then the
per-triangle filter), with and without a back-face stage, from random cameras in the view
cells (on faces, edges, corners too) and outside them, on paths through the cells, in
float64, float32 and fixed16.16; and its walk visits no node vfc alone would not."""
import numpy as np
import pytest

from vismobile.culling import Culler, device_options
from vismobile.culling.pvs import packed_planes
from vismobile.culling.pvs_frame import keep_bits, near_plane
from vismobile.device.profile import get_profile
from vismobile.partition import partition
from vismobile.world.camera import Camera

from .pvs_cases import (MODES, SLABS, in_cell_cameras, in_face_plane, keeps_what_cameras_see,
                        zigzag_world)


@pytest.fixture(scope="module")
def baked(kit):
    world = zigzag_world(kit)
    portal = partition(world, "portal", depth=1, slabs=SLABS, pvs="conservative")
    octree = partition(world, "octree:3", pvs="conservative")
    return {"portal": portal, "octree": octree}


def path_cameras(part, count, seed):
    """A walk through the rooms: consecutive eyes a small step apart (so the fused call mostly
    meets the cells of the frame before), now and then a jump, a near plane of 0.01 to 0.3 (the
    back-face part of the set comes and goes with the eye's reach) and one eye outside."""
    rng = np.random.default_rng(seed)
    low, high = part.world.extent
    eye = (low + high) / 2.0
    cams = []
    for i in range(count):
        if i % 25 == 0:
            eye = rng.uniform(low, high)
        eye = np.clip(eye + rng.normal(0.0, 0.15, 3), low + 0.05, high - 0.05)
        cams.append(Camera(eye, yaw=rng.uniform(0, 360), pitch=rng.uniform(-89, 89),
                           fov=rng.uniform(10, 120), near=float(rng.choice([0.01, 0.1, 0.3])),
                           aspect=4 / 3))
    cams.append(Camera(low - 3.0, yaw=30.0, aspect=4 / 3))  # outside every cell: falls back
    return cams


@pytest.mark.parametrize("mode", MODES)
@pytest.mark.parametrize("kind", ["portal", "octree"])
def test_the_fused_call_hands_on_what_the_staged_path_did(baked, kit, kind, mode):
    part = baked[kind]
    options = {"arithmetic": "float64"} if mode == "float64" else \
        device_options(get_profile(kit.PROFILE, mode))
    cams = in_cell_cameras(part, 60, 11) + path_cameras(part, 80, 12)
    keys = ("pvs.cells", "pvs.fallbacks", "pvs.everything", "triangles_sent")
    for stages in ("pvs+vfc", "pvs+vfc+tbfc", "pvs+vfc+bfc+cbfc"):
        fused = Culler(part, stages, **options)
        staged = Culler(part, stages, pvs={"fuse": False}, **options)
        alone = Culler(part, stages.replace("pvs+", ""), **options)
        assert fused.stages[0].walker is not None and staged.stages[0].walker is None
        used = narrowed = 0
        for cam in cams:
            a, b, c = fused.cull(cam), staged.cull(cam), alone.cull(cam)
            assert np.array_equal(a.triangles, b.triangles), f"{stages} {mode}: {cam}"
            assert {k: a.stats.get(k) for k in keys} == {k: b.stats.get(k) for k in keys}
            # the walk skips what the set leaves out: never more nodes than vfc alone
            assert a.stats["nodes_visited"] <= c.stats["nodes_visited"]
            assert not len(np.setdiff1d(a.triangles, c.triangles))
            used += "pvs.fallbacks" not in a.stats
            narrowed += len(a.triangles) < len(c.triangles)
        # the sets took part (but in face planes: pvs_cases.in_face_plane), and cut something
        assert used >= sum(not in_face_plane(part, c) for c in cams) - 5 and narrowed > 0


def test_the_fused_call_only_where_vfc_is_the_one_node_stage(baked):
    part = baked["portal"]
    assert Culler(part, "pvs+vfc+cbfc").stages[0].walker is not None
    assert Culler(part, "pvs+vfc+cbfc").stages[0].gather
    # occlusion after vfc: the call walks, occlusion tests the nodes and gathers
    stage = Culler(part, "pvs+vfc+occlusion+tbfc").stages[0]
    assert stage.walker is not None and not stage.gather
    for stages in ("pvs", "pvs+vfc+cone", "pvs+portals+vfc"):
        culler = Culler(part, stages)
        assert culler.stages[0].walker is None, stages
        assert not any(getattr(s, "absorbed", False) for s in culler.stages), stages
    with pytest.raises(ValueError, match="fuse"):
        Culler(part, "pvs+vfc", pvs={"fuse": "yes"})


def test_the_set_bits_follow_the_bitmap_layout():
    rng = np.random.default_rng(2)
    for count in (1, 63, 64, 65, 1000):
        keep = rng.uniform(size=count) < 0.4
        bits = keep_bits(keep)
        assert bits.dtype == np.uint64 and len(bits) == count // 64 + 1
        ids = np.arange(count)
        held = (bits[ids >> 6] >> (ids & 63).astype(np.uint64)) & np.uint64(1)
        assert np.array_equal(held.astype(bool), keep)


@pytest.mark.parametrize("keep", [2, 64])
def test_slots_hold_the_sets_walked_without_a_decode(baked, kit, keep):
    # eyes in turn in cells far apart (as bench_pvs interleaves path frames): with keep slots
    # or more, a combination met again is walked from its slot (nothing decoded); with fewer
    # (keep=2, round robin) the oldest is overwritten; the same triangles as staged either way
    part = baked["portal"]
    fused, staged = Culler(part, "pvs+vfc"), Culler(part, "pvs+vfc", pvs={"fuse": False})
    stage = fused.stages[0]
    stage.keep = keep
    cams = [c for c in in_cell_cameras(part, 40, 21) if not in_face_plane(part, c)][:6]
    decoded = []
    for rep in range(3):
        for cam in cams:
            a, b = fused.cull(cam), staged.cull(cam)
            assert np.array_equal(a.triangles, b.triangles)
            if "pvs.fallbacks" not in a.stats:
                decoded.append(a.stats["pvs.ids_decoded"])
    combos = {tuple(stage.eye_cells(c, sum(stage.reaches(c)))) for c in cams}
    assert len(stage.slot_key) == min(keep, 8) and stage.filled >= len(combos) > 2
    late = decoded[len(decoded) // 3:]  # the second and third rounds
    if keep >= len(combos):
        assert not any(late) and stage.filled == len(combos)
    else:
        assert all(late) and stage.filled == len(decoded)
    stage.forget()
    assert fused.cull(cams[0]).stats["pvs.ids_decoded"] > 0 and stage.filled == 1


def test_the_compiled_face_test_is_a_search_of_every_plane():
    rng = np.random.default_rng(3)
    faces = [np.sort(rng.uniform(-5, 5, n)) for n in (0, 1, 7)]
    coords, start = packed_planes(faces)
    for eye in rng.uniform(-6, 6, (300, 3)):
        for reach in (1e-9, 0.05, 0.5):
            eye[2] = faces[2][rng.integers(7)] + rng.choice([0.0, reach, 1.01 * reach])
            every = any(np.any(np.abs(f - eye[a]) <= reach) for a, f in enumerate(faces))
            assert near_plane(coords, start, eye, reach) == every


@pytest.mark.parametrize("mode", MODES)
def test_with_occlusion_after_the_call_walks_and_occlusion_gathers(baked, kit, mode):
    # pvs+vfc+occlusion: the call's walk (the set's subtrees only) hands occlusion vfc's
    # accepted nodes and the set's bits as a filter: conservative against the unculled item
    # buffer, within what pvs+vfc sends, fewer nodes walked than the staged path
    part = baked["portal"]
    cams = in_cell_cameras(part, 30, 31) + path_cameras(part, 30, 32)
    assert keeps_what_cameras_see(part, ("pvs+vfc+occlusion",), cams, mode, kit.PROFILE) > 0
    options = {"arithmetic": "float64"} if mode == "float64" else \
        device_options(get_profile(kit.PROFILE, mode))
    fused = Culler(part, "pvs+vfc+occlusion", **options)
    staged = Culler(part, "pvs+vfc+occlusion", pvs={"fuse": False}, **options)
    alone = Culler(part, "pvs+vfc", **options)
    walked = staged_walked = hidden = 0
    for cam in cams:
        a, b, c = fused.cull(cam), staged.cull(cam), alone.cull(cam)
        assert not len(np.setdiff1d(a.triangles, c.triangles)), cam
        assert a.stats.get("pvs.fallbacks") == b.stats.get("pvs.fallbacks")
        walked += a.stats["vfc.nodes_accepted"] + a.stats["vfc.nodes_culled"]
        staged_walked += b.stats["vfc.nodes_accepted"] + b.stats["vfc.nodes_culled"]
        hidden += len(c.triangles) - len(a.triangles)
    assert walked <= staged_walked and hidden > 0

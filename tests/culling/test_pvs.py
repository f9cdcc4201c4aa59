"""`pvs`: the baked from-cell sets never drop a triangle the item buffer shows, from random
cameras inside the view cells (on their boundaries and in their corners too), any fov and
pitch, in float64, float32 and fixed16.16; the `.vmp` keeps them and refuses corrupt ones."""
import numpy as np
import pytest

from vismobile.culling import Culler
from vismobile.device.profile import get_profile
from vismobile.partition import load_partition, partition
from vismobile.partition.pvs import bake
from vismobile.partition.pvs_codec import cell_mask, decode
from vismobile.partition.pvs_planes import face_sets
from vismobile.partition.store import to_bytes
from vismobile.render import SENTINEL, item_buffer
from vismobile.world.camera import Camera

from .pvs_cases import (MODES, SLABS, in_cell_cameras, in_face_plane, keeps_what_cameras_see,
                        near_boundary_cameras, zigzag_world)


@pytest.fixture(scope="module")
def zigzag(kit):
    world = zigzag_world(kit)
    return partition(world, "portal", depth=1, slabs=SLABS, pvs="conservative")


def cell_ids(extras, c, triangles):
    """(S,) int64 ids of view cell c's stored set (partition/pvs_codec.py)."""
    patterns, ids = decode(extras, len(extras["pvs_cells"]), triangles)
    return np.flatnonzero(cell_mask(patterns, ids, c))


def cell_of(part, point):
    boxes = part.extras["pvs_cells"]
    inside = np.flatnonzero(((boxes[:, 0] <= point) & (point <= boxes[:, 1])).all(axis=1))
    return int(inside[0])


def wall_planes(world, ids):
    """Sorted x of the walls (x-facing triangles) among ids."""
    walls = ids[np.abs(world.normals[ids, 0]) > 0.9]
    return np.unique(np.round(world.centroids[walls, 0], 3))


def test_first_room_does_not_see_the_fourth(zigzag):
    world = zigzag.world
    c = cell_of(zigzag, np.array([2.0, 1.5, 2.0]))
    seen = wall_planes(world, cell_ids(zigzag.extras, c, world.triangle_count))
    assert seen.max() <= 12.2 and 12.0 in seen  # walls at 16 and beyond (rooms 4, 5) hidden


def test_lines_in_the_floor_plane_pass_under_every_wall(zigzag):
    # an eye in the floor's plane y = 0 sees the floor edge-on, and a line lying in it meets
    # each wall's bottom edge with nothing below the floor: the fill rule may leave the pixel
    # open, so such lines pass under every wall (partition/pvs_planes.py). They reach the far
    # walls' bottom rows, which the doorways hide: the room's face set holds them (the stage
    # adds it for eyes in a face plane walked), its set does not
    world, x = zigzag.world, zigzag.extras
    c = cell_of(zigzag, np.array([2.0, 1.5, 2.0]))
    face = cell_ids(face_sets(x), c, world.triangle_count)
    far = np.flatnonzero((world.bounds[:, 0, 0] >= 16.0) & (world.bounds[:, 0, 1] == 0.0)
                         & (np.abs(world.normals[:, 0]) > 0.9))
    assert len(far) and np.isin(far, face).all()
    assert not np.isin(far, cell_ids(x, c, world.triangle_count)).any()
    # the face set holds only what touches the slab of a plane walked near the room
    lo, hi = x["pvs_cells"][c]
    reach = 2.0 * float(x["pvs_plane"][0])
    touch = np.zeros(len(face), dtype=bool)
    for a, v in x["pvs_face_planes"]:
        a = int(a)
        if lo[a] - reach <= v <= hi[a] + reach:
            touch |= ((world.bounds[face, 0, a] <= v + reach)
                      & (world.bounds[face, 1, a] >= v - reach))
    assert touch.all()


@pytest.mark.parametrize("mode", MODES)
def test_pvs_keeps_what_cameras_in_the_cells_see(kit, zigzag, mode):
    cams = in_cell_cameras(zigzag, 60, 7) + near_boundary_cameras(zigzag, 24, 8)
    used = keeps_what_cameras_see(zigzag, ("pvs", "pvs,vfc"), cams, mode, kit.PROFILE)
    # every camera used the baked sets but those in a face's plane, which fell back
    assert used == 2 * sum(not in_face_plane(zigzag, cam) for cam in cams) > 0


def test_w1_pvs_keeps_what_cameras_in_the_cells_see(kit):
    part = partition(kit.world("w1"), "portal", depth=1, pvs="conservative")
    culler = Culler(part, "pvs,vfc")
    sent = visible = 0
    for cam in in_cell_cameras(part, 40, 3):
        shown = kit.visible_ids(part.world, cam, False)
        result = culler.cull(cam)
        missing = np.setdiff1d(shown, result.triangles)
        assert not len(missing), f"dropped {missing}: {cam}"
        sent, visible = sent + len(result.triangles), visible + len(shown)
    assert sent >= visible


def test_an_eye_in_face_planes_keeps_what_lines_lying_in_them_show(kit, zigzag):
    # the eye in the world's corner lies in three cell faces' planes, the floor's among them;
    # what its item buffer shows, lines lying in those planes reach past walls they take edge
    # on: the sets hold it, and the stage uses them (pvs_plane). The bake without those walks
    # (as before partition/pvs_planes.py) lacks it in every cell the eye touches.
    cam = Camera((0.0, 0.0, 0.0), yaw=239.59496060307262, pitch=-25.818476035701813,
                 fov=66.66237728272296, near=0.1, aspect=4 / 3)
    shown = kit.visible_ids(zigzag.world, cam, False)
    result = Culler(zigzag, "pvs,vfc", arithmetic="float64").cull(cam)
    assert "pvs.fallbacks" not in result.stats
    assert not len(np.setdiff1d(shown, result.triangles))
    part = partition(zigzag.world, "portal", depth=1, slabs=SLABS)
    part.params["budget"] = "none"  # the walk's exact sets: a coarsened set may hold more
    extras, _ = bake(part, planes=False)
    boxes, world = extras["pvs_cells"], zigzag.world
    touching = np.flatnonzero(((boxes[:, 0] <= 1e-9) & (boxes[:, 1] >= -1e-9)).all(axis=1))
    held = np.unique(np.concatenate([cell_ids(extras, c, world.triangle_count)
                                     for c in touching]))
    assert len(np.setdiff1d(shown, held))


def set_masks(extras, triangles):
    """(V, T) bool the cells' sets and (V, T) bool their face sets."""
    cells = len(extras["pvs_cells"])
    out = []
    for x in (extras, {**face_sets(extras), "pvs_cells": extras["pvs_cells"]}):
        patterns, ids = decode(x, cells, triangles)
        out.append(np.unpackbits(patterns, axis=1, count=cells)[ids.astype(np.int64)].T > 0)
    return out


def test_a_tight_budget_collapses_the_face_sets_first_and_drops_nothing(kit, zigzag, tmp_path):
    # a budget the exact sets miss (the zigzag's fit the default): the face sets go first,
    # one set for every cell (pvs_coarsen.collapsed_faces), each cell's set and its face set
    # together hold the exact ones', and eyes in face planes take it
    from vismobile.partition.pvs_coarsen import stored_size

    world = zigzag.world
    exact = partition(world, "portal", depth=1, slabs=SLABS)
    exact.params["budget"] = "none"
    extras, stats = bake(exact)
    report = stats["budget"]
    assert report["faces"][0] > 0 and not report["faces_collapsed"]
    part = partition(world, "portal", depth=1, slabs=SLABS)
    entries = stored_size({k: np.zeros(0, np.uint8) for k in extras if k != "pvs_cells"})
    part.params["budget"] = (entries + 0.8 * (report["before"] - entries)) / world.obj_bytes()
    squeezed, stats = bake(part)
    report = stats["budget"]
    assert report["met"] and report["faces_collapsed"] and report["faces"][1] < report["faces"][0]
    plain = partition(world, "portal", depth=1, slabs=SLABS)
    part.extras.update(squeezed)
    part.params["pvs"] = "conservative"
    # the bytes the budget counts hold what the .vmp grows by (8 sections with the face sets)
    grown = len(to_bytes(part)) - len(to_bytes(plain))
    assert grown <= report["after"] <= part.params["budget"] * world.obj_bytes()
    from vismobile.partition import save_partition

    save_partition(part, tmp_path / "squeezed.vmp")  # the load's checks take the one face set
    loaded = load_partition(tmp_path / "squeezed.vmp")
    assert np.array_equal(loaded.extras["pvs_face_pack"], squeezed["pvs_face_pack"])
    (want, want_face), (got, got_face) = (set_masks(x, world.triangle_count)
                                          for x in (extras, squeezed))
    assert (got >= want).all() and ((got | got_face) >= (want | want_face)).all()
    assert len(np.unique(got_face, axis=0)) == 1 and (got_face > got_face & want_face).any()
    cam = Camera((0.0, 0.0, 0.0), yaw=239.59496060307262, pitch=-25.818476035701813,
                 fov=66.66237728272296, near=0.1, aspect=4 / 3)
    result = Culler(part, "pvs,vfc", arithmetic="float64").cull(cam)
    assert "pvs.fallbacks" not in result.stats
    assert not len(np.setdiff1d(kit.visible_ids(world, cam, False), result.triangles))
    cams = in_cell_cameras(part, 40, 9) + near_boundary_cameras(part, 16, 10)
    for mode in ("float32", "fixed16.16"):
        assert keeps_what_cameras_see(part, ("pvs,vfc",), cams, mode, kit.PROFILE) == len(cams)


def test_vmp_keeps_the_pvs_and_refuses_a_corrupt_one(zigzag, tmp_path):
    from vismobile.errors import PartitionError

    from vismobile.partition import save_partition

    path = tmp_path / "z.vmp"
    save_partition(zigzag, path)
    loaded = load_partition(path)
    for name in ("pvs_cells", "pvs_shape", "pvs_pack", "pvs_grow"):
        assert np.array_equal(loaded.extras[name], zigzag.extras[name])
    assert loaded.params["pvs"] == "conservative"
    import json

    from vismobile.partition.store import ALIGN, PREFIX

    data = bytearray(path.read_bytes())
    length = PREFIX.unpack_from(data, 0)[2]
    header = json.loads(bytes(data[PREFIX.size:PREFIX.size + length]))
    base = PREFIX.size + length
    base += -base % ALIGN
    section = next(s for s in header["sections"] if s["name"].startswith("extras.pvs_pack"))
    data[base + section["offset"]] ^= 0xFF  # one bit pattern in the PVS's runs
    bad = tmp_path / "bad.vmp"
    bad.write_bytes(bytes(data))
    with pytest.raises(PartitionError, match="checksum of section extras.pvs_pack"):
        load_partition(bad)
    # whatever its CRC: a pack cut short or lengthened, or in the older layout (float boxes
    # in pvs_cells, zlib'd bitsets: bake again); tests/partition/test_pvs_codec.py has the rest
    from vismobile.partition.pvs import check_pvs

    x = dict(zigzag.extras)
    triangles = zigzag.world.triangle_count
    for pack in (x["pvs_pack"][:-3], np.append(x["pvs_pack"], np.uint8(0))):
        with pytest.raises(ValueError, match="pattern stream"):
            check_pvs({**x, "pvs_pack": pack}, triangles)
    with pytest.raises(ValueError, match="triangles"):
        check_pvs(x, triangles + 1)
    with pytest.raises(ValueError, match="older layout|another layout"):
        check_pvs({**x, "pvs_shape": np.array([3, triangles, 1])}, triangles)
    with pytest.raises(ValueError, match="older layout"):
        check_pvs({"pvs_runs": np.zeros(2, np.int32)}, triangles)
    # the face sets (partition/pvs_planes.py): kept, and refused when inconsistent
    for name in ("pvs_plane", "pvs_face_planes", "pvs_face_shape", "pvs_face_pack"):
        assert np.array_equal(loaded.extras[name], zigzag.extras[name])
        with pytest.raises(ValueError, match="go together"):
            check_pvs({k: v for k, v in x.items() if k != name}, triangles)
    with pytest.raises(ValueError, match="pvs_face_planes must be"):
        check_pvs({**x, "pvs_face_planes": np.array([[3.0, 1.0]])}, triangles)
    with pytest.raises(ValueError, match="pvs_plane must be"):
        check_pvs({**x, "pvs_plane": np.array([-1.0])}, triangles)
    with pytest.raises(ValueError, match="pattern stream"):
        check_pvs({**x, "pvs_face_pack": x["pvs_face_pack"][:-3]}, triangles)


def test_back_faces_go_back_in_without_a_backface_stage(zigzag):
    # the stored sets hold what faces away from a whole cell (partition/pvs_back.py): pvs,vfc
    # (no back-face stage) hands them on, pvs,vfc,tbfc leaves them out
    from vismobile.partition.pvs import check_pvs

    assert zigzag.extras["pvs_back"][0] >= 0.5
    cam = Camera((2.0, 1.5, 2.0), yaw=-90.0, aspect=4 / 3)
    plain = Culler(zigzag, "pvs,vfc")
    culled = Culler(zigzag, "pvs,vfc,tbfc")
    assert not plain.stages[0].back_culled and culled.stages[0].back_culled
    found, span = plain.stages[0].lookup(cam)
    every, _, _ = plain.stages[0].visible(found, drop_back=False)
    front, _, _ = plain.stages[0].visible(found, drop_back=True)
    assert front.sum() < every.sum() and not np.any(front & ~every)
    with pytest.raises(ValueError, match="pvs_back"):
        check_pvs({**zigzag.extras, "pvs_back": np.array([-1.0])}, zigzag.world.triangle_count)


def test_bad_pvs_mode(zigzag):
    with pytest.raises(ValueError, match="pvs mode"):
        partition(zigzag.world, "portal", depth=1, pvs="sometimes")


def test_spec_grammar_bakes(zigzag):
    part = partition(zigzag.world, "portal:depth=1,pvs=conservative", slabs=SLABS)
    assert np.array_equal(part.extras["pvs_pack"], zigzag.extras["pvs_pack"])


def test_sampled_pvs_is_within_the_conservative_one(kit, zigzag):
    # aggressive: what 4 points per cell see, never more than the conservative set holds
    from vismobile.render.pvs_sampled import bake_sampled

    extras, stats = bake_sampled(zigzag, 4, kit.PROFILE, seed=1)
    assert stats["renders"] == len(extras["pvs_cells"]) * 4 * 6 == 5 * 4 * 6
    x = zigzag.extras
    for c, (lo, hi) in enumerate(extras["pvs_cells"]):
        sampled = cell_ids(extras, c, zigzag.world.triangle_count)
        # the conservative cells inside this room: their union bounds what it can see
        boxes = x["pvs_cells"]
        within = np.flatnonzero(((boxes[:, 0] >= lo - 1e-9) & (boxes[:, 1] <= hi + 1e-9)).all(1))
        conservative = np.unique(np.concatenate(
            [cell_ids(x, k, zigzag.world.triangle_count) for k in within]))
        assert 0 < len(sampled) and not len(np.setdiff1d(sampled, conservative))
        assert len(sampled) < len(conservative)
    with pytest.raises(ValueError, match="renders item buffers"):
        partition(zigzag.world, "portal", depth=1, pvs="sampled:4")


def test_cli_bakes_both_kinds(kit, zigzag, tmp_path):
    import subprocess
    import sys

    mesh = tmp_path / "zigzag.obj"
    zigzag.world.to_obj(mesh)
    for spec, mode in (("portal:1,pvs=conservative", "conservative"),
                       ("grid:2,pvs=sampled:1", "sampled:1")):
        out = tmp_path / f"{mode[:7]}.vmp"
        done = subprocess.run([sys.executable, "-m", "vismobile", "partition", str(mesh),
                               "--structure", spec, "-o", str(out)],
                              capture_output=True, text=True, timeout=600)
        assert done.returncode == 0, done.stderr
        loaded = load_partition(out)
        assert loaded.params["pvs"] == mode and len(loaded.extras["pvs_cells"]) > 1
    # the bake over two processes writes the same sets
    spread = tmp_path / "spread.vmp"
    done = subprocess.run([sys.executable, "-m", "vismobile", "partition", str(mesh),
                           "--structure", "portal:1,pvs=conservative", "--jobs", "2",
                           "-o", str(spread)], capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    one = load_partition(tmp_path / "conserv.vmp").extras
    two = load_partition(spread).extras
    assert all(np.array_equal(one[k], two[k]) for k in ("pvs_cells", "pvs_shape", "pvs_pack"))
    bad = subprocess.run([sys.executable, "-m", "vismobile", "partition", str(mesh),
                          "--structure", "grid:2,pvs=sampled:x", "-o", str(tmp_path / "b.vmp")],
                         capture_output=True, text=True, timeout=600)
    assert bad.returncode == 2 and "pvs=sampled:N" in bad.stderr
    assert len(bad.stderr.strip().splitlines()) == 1 and not (tmp_path / "b.vmp").exists()


def test_eye_outside_every_cell_falls_back_and_says_so(zigzag):
    cam = Camera((-5.0, 1.5, 2.0), yaw=-90.0, aspect=4 / 3)  # west of the first room
    result = Culler(zigzag, "pvs,vfc").cull(cam)
    assert result.stats["pvs.fallbacks"] == 1
    assert np.array_equal(result.triangles, Culler(zigzag, "vfc").cull(cam).triangles)
    inside = Culler(zigzag, "pvs,vfc").cull(Camera((2.0, 1.5, 2.0), yaw=-90.0, aspect=4 / 3))
    assert "pvs.fallbacks" not in inside.stats and inside.stats["pvs.cells"] >= 1

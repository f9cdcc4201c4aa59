"""A PVS coarsened to a size budget (partition/pvs_coarsen.py, pvs=conservative,budget=F; by
default 0.25, budget=none the exact sets): the coarsened sets hold the exact ones, the budget
is met or the report says it was not, random in-cell cameras lose nothing, and a bad budget is
refused in one line."""
import numpy as np
import pytest

from .test_pvs_codec import grid_boxes, spatial_masks
from .test_pvs_fly import masks_of
from .test_pvs_street import in_cell_checks, town
from vismobile.app.cli import main
from vismobile.partition import load_partition, partition, pvs_codec, save_partition
from vismobile.culling import Culler
from vismobile.partition.pvs_coarsen import (DEFAULT_BUDGET, HEADER, budget_option,
                                             collapsed_faces, describe, facing, fill_back, fit,
                                             stored_size)
from vismobile.world.camera import Camera


def decoded(extras, triangles, cells):
    pvs_codec._CACHE.clear()
    _, patterns, ids = pvs_codec.decode_all(extras, triangles)
    return np.unpackbits(patterns, axis=1, count=cells)[ids.astype(np.int64)].T.astype(bool)


@pytest.fixture(scope="module")
def sets():
    rng = np.random.default_rng(3)
    boxes = grid_boxes(rng, 9, 8, 0)
    return boxes, spatial_masks(rng, boxes, 400, 0.02)


def test_coarser_sets_only_grow_and_fit_the_budget(sets):
    boxes, masks = sets
    exact, report = fit(boxes, masks, None)
    assert report["met"] and report["merges"] == 0 and report["after"] == report["before"]
    assert np.array_equal(decoded(exact, masks.shape[1], len(boxes)), masks)
    growth = []
    for share in (0.7, 0.4, 0.2):
        budget = HEADER + share * (report["before"] - HEADER)
        extras, done = fit(boxes, masks, budget)
        assert done["met"] and done["after"] == stored_size(extras) <= budget
        got = decoded(extras, masks.shape[1], len(boxes))
        assert (got >= masks).all()  # a superset: conservative sets stay conservative
        assert done["groups"] < len(boxes) and done["merges"] > 0
        assert len(np.unique(got, axis=0)) <= done["groups"]  # a group's cells share one set
        growth.append(done["mean_set_after"])
        assert "budget" in describe(done) and "not met" not in describe(done)
    assert report["mean_set_before"] < growth[0] <= growth[1] <= growth[2]


def test_an_unreachable_budget_says_so(sets):
    boxes, masks = sets
    extras, report = fit(boxes, masks, HEADER + 10)
    assert not report["met"] and report["unreachable"]
    assert report["after"] == report["before"] > HEADER + 10
    assert "not met" in describe(report) and "exact sets stay" in describe(report)
    got = decoded(extras, masks.shape[1], len(boxes))
    # even one set (every merge) would not fit, so merging would only send more: exact sets
    assert (got == masks).all() and report["merges"] == 0
    assert not report.get("faces_collapsed")


def test_face_sets_count_and_collapse_first(sets):
    # the face sets' bytes count (pvs_planes.py; the stage adds a cell's face set for eyes in
    # a walked face plane): a budget the exact PVS misses collapses them to one set first
    boxes, masks = sets
    rng = np.random.default_rng(4)
    faces = spatial_masks(rng, boxes, masks.shape[1], 0.05) & ~masks
    coded = pvs_codec.encode(boxes, faces)
    others = {"pvs_face_shape": coded["pvs_shape"], "pvs_face_pack": coded["pvs_pack"]}
    exact, report = fit(boxes, masks, None, others, faces=faces)
    assert all(np.array_equal(exact[k], others[k]) for k in others)
    assert report["before"] == stored_size(exact) and not report["faces_collapsed"]
    one = collapsed_faces(boxes, masks, faces)
    middle = (stored_size({**pvs_codec.encode(boxes, masks), **one}) + report["before"]) / 2
    done, report = fit(boxes, masks, middle, others, faces=faces)
    assert report["met"] and report["faces_collapsed"] and report["merges"] == 0
    assert report["faces"][1] < report["faces"][0] and report["after"] <= middle
    got = decoded(done, masks.shape[1], len(boxes))
    face = decoded({"pvs_shape": done["pvs_face_shape"], "pvs_pack": done["pvs_face_pack"]},
                   masks.shape[1], len(boxes))
    assert np.array_equal(got, masks) and (face == face[0]).all()  # one face set for all
    assert ((got | face) >= (masks | faces)).all()
    assert "face sets" in describe(report)
    tight, report = fit(boxes, masks, HEADER + 0.3 * (report["before"] - HEADER), others,
                        faces=faces)  # merges too: the face set stays the one set
    assert report["merges"] > 0 and report["faces_collapsed"]
    assert all(np.array_equal(tight[k], one[k]) for k in one)


@pytest.fixture(scope="module")
def town_bakes():
    world = town()
    exact = partition(world, "portal", depth=1, pvs="conservative", budget="none")
    before = stored_size({k: v for k, v in exact.extras.items()
                          if k.startswith("pvs_") and k != "pvs_cells"})
    share = (HEADER + 0.5 * (before - HEADER)) / world.obj_bytes()
    return exact, partition(world, "portal", depth=1, pvs="conservative", budget=share), share


def test_a_budgeted_bake_holds_the_exact_sets(town_bakes):
    exact, coarse, share = town_bakes
    world = exact.world
    assert coarse.params["budget"] == share
    assert np.array_equal(coarse.extras["pvs_cells"], exact.extras["pvs_cells"])
    want, got = masks_of(exact.extras, world), masks_of(coarse.extras, world)
    assert (got >= want).all() and (got > want).any()
    size = stored_size({k: v for k, v in coarse.extras.items() if k.startswith("pvs_")})
    assert size <= share * world.obj_bytes()


def test_the_default_bake_takes_the_default_budget_and_none_keeps_the_exact_sets(town_bakes):
    exact, _, _ = town_bakes
    world = exact.world
    assert exact.params["budget"] == "none"
    default = partition(world, "portal", depth=1, pvs="conservative")
    assert default.params["budget"] == DEFAULT_BUDGET == budget_option(None) == 0.25
    want, got = masks_of(exact.extras, world), masks_of(default.extras, world)
    # the town's exact PVS is about the budget (0.247x its OBJ since pvs_shadow's silhouette
    # steps, 0.27x before): the default bake is the bake at DEFAULT_BUDGET
    explicit = partition(world, "portal", depth=1, pvs="conservative", budget=DEFAULT_BUDGET)
    assert np.array_equal(got, masks_of(explicit.extras, world))
    assert (got >= want).all()
    size = stored_size({k: v for k, v in default.extras.items() if k.startswith("pvs_")})
    assert size <= DEFAULT_BUDGET * world.obj_bytes()
    for word in ("none", "off", "None", "OFF"):
        assert budget_option(word) is None
    off = partition(world, "portal:1,pvs=conservative,budget=off")
    assert off.params["budget"] == "none"
    assert np.array_equal(masks_of(off.extras, world), want)


def test_budget_params_round_trip_and_a_file_baked_before_still_loads(town_bakes, tmp_path):
    exact, coarse, share = town_bakes
    for part, want in ((exact, "none"), (coarse, share)):
        save_partition(part, tmp_path / "p.vmp")
        assert load_partition(tmp_path / "p.vmp").params["budget"] == want
    old = exact.__class__.__new__(exact.__class__)
    old.__dict__.update(exact.__dict__)
    old.params = {k: v for k, v in exact.params.items() if k != "budget"}  # before the default
    save_partition(old, tmp_path / "old.vmp")
    loaded = load_partition(tmp_path / "old.vmp")
    assert "budget" not in loaded.params and loaded.params["pvs"] == "conservative"
    assert np.array_equal(masks_of(loaded.extras, exact.world), masks_of(exact.extras, exact.world))
    import json
    import struct
    import zlib

    from vismobile.errors import PartitionError

    data = (tmp_path / "p.vmp").read_bytes()
    _, _, length, _ = struct.unpack_from("<8sIII", data)
    header = json.loads(data[20:20 + length])
    for value in ('"exact"', "true", "-0.5", "NaN"):  # the header's budget: a share or "none"
        header["params"]["budget"] = "@@"
        text = json.dumps(header).replace('"@@"', value).encode()
        (tmp_path / "bad.vmp").write_bytes(data[:12] + struct.pack("<II", len(text), zlib.crc32(
            text)) + text + data[20 + length:])
        with pytest.raises(PartitionError, match="params.budget"):
            load_partition(tmp_path / "bad.vmp")


def test_the_cli_prints_the_budget_it_baked_with(tmp_path, capsys):
    path = tmp_path / "town.obj"
    town().to_obj(path)
    for text, want, line in (("", "budget=0.25", "pvs budget  budget "),
                             (",budget=none", "budget=none", "pvs budget  none: the exact sets")):
        out = tmp_path / f"t{len(text)}.vmp"
        assert main(["partition", str(path), f"--structure=portal:1,pvs=conservative{text}",
                     "-o", str(out)]) == 0
        printed = capsys.readouterr().out
        assert want in printed.split("structure")[1].splitlines()[0] and line in printed
        assert str(load_partition(out).params["budget"]) == want.split("=")[1]


def test_in_cell_cameras_on_a_coarsened_bake_drop_nothing(town_bakes):
    _, coarse, _ = town_bakes
    assert in_cell_checks(coarse, 60, 21) > 40


def pvs_others(extras):
    return {k: v for k, v in extras.items()
            if k.startswith("pvs_") and k not in ("pvs_shape", "pvs_pack", "pvs_cells")}


def test_filled_bits_face_away_from_the_whole_grown_cell_and_shrink_the_pvs(town_bakes):
    exact = town_bakes[0]
    world, boxes = exact.world, exact.extras["pvs_cells"]
    masks, back = masks_of(exact.extras, world), float(exact.extras["pvs_back"][0])
    filled = fill_back(boxes, masks, world.corners, back)
    added = filled & ~masks
    assert (filled >= masks).all() and added.any()
    grown = boxes + np.array([-back, back])[None, :, None]
    front = np.unpackbits(facing(grown, world.corners).view(np.uint8), axis=1,
                          count=masks.shape[1], bitorder="little").astype(bool)
    assert not (added & front).any()  # only triangles every eye there sees from behind
    # the same shape as the others: an added triangle's plane has all 8 corners behind it
    cell, tri = np.argwhere(added)[0]
    c = world.corners[tri]
    normal = np.cross(c[1] - c[0], c[2] - c[0])
    ends = np.array([[grown[cell, k >> a & 1, a] for a in range(3)] for k in range(8)])
    assert ((ends - c[0]) @ normal < 0).all()
    assert len(np.unique(filled.T, axis=0)) < len(np.unique(masks.T, axis=0))
    others = pvs_others(exact.extras)
    assert stored_size({**pvs_codec.encode(boxes, filled), **others}) \
        < stored_size({**pvs_codec.encode(boxes, masks), **others})


def test_a_budget_met_by_filling_sends_the_same_with_back_faces_culled(town_bakes):
    exact = town_bakes[0]
    world = exact.world
    boxes, masks = exact.extras["pvs_cells"], masks_of(exact.extras, world)
    others = pvs_others(exact.extras)
    _, report = fit(boxes, masks, HEADER, others, world.corners)
    assert report["filled"] < report["before"]
    share = (report["filled"] + report["before"]) / 2 / world.obj_bytes()
    filled = partition(world, "portal", depth=1, pvs="conservative", budget=share)
    got = masks_of(filled.extras, world)
    assert (got >= masks).all() and (got > masks).any()
    assert len(np.unique(got, axis=0)) == len(boxes)  # no cells merged: each its own set
    rng = np.random.default_rng(5)
    one, two = Culler(exact, "pvs+vfc+tbfc"), Culler(filled, "pvs+vfc+tbfc")
    used = 0
    for c in rng.integers(len(boxes), size=40):
        lo, hi = boxes[c]
        cam = Camera(lo + rng.uniform(0.1, 0.9, 3) * (hi - lo), yaw=rng.uniform(0, 360),
                     pitch=rng.uniform(-30, 30), fov=60.0)
        a, b = one.cull(cam), two.cull(cam)
        assert np.array_equal(np.sort(a.triangles), np.sort(b.triangles))
        used += "pvs.fallbacks" not in b.stats
    assert used > 30
    assert in_cell_checks(filled, 30, 22) > 20


@pytest.mark.parametrize("value", [0, -0.25, "nan", "inf", 65, "quarter", True, "", "exact"])
def test_a_bad_budget_is_refused(value):
    with pytest.raises(ValueError, match="budget="):
        budget_option(value)
    world = town()
    with pytest.raises(ValueError, match="budget="):
        partition(world, "portal", depth=1, pvs="conservative", budget=value)


def test_a_budget_without_a_pvs_is_refused():
    with pytest.raises(ValueError, match="pvs=conservative"):
        partition(town(), "portal", depth=1, budget=0.25)


@pytest.mark.parametrize("text", ["budget=0", "budget=-1", "budget=1e9", "budget=x",
                                  "budget=", "budget=nonee"])
def test_the_cli_refuses_a_bad_budget_in_one_line(tmp_path, capsys, text):
    obj = tmp_path / "cube.obj"
    obj.write_text("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n"
                   "f 1 3 2\nf 1 4 3\nf 5 6 7\nf 5 7 8\nf 1 2 6\nf 1 6 5\nf 3 4 8\nf 3 8 7\n"
                   "f 2 3 7\nf 2 7 6\nf 1 5 8\nf 1 8 4\n")
    out = tmp_path / "cube.vmp"
    rc = main(["partition", str(obj), f"--structure=portal:1,pvs=conservative,{text}", "-o",
               str(out)])
    err = capsys.readouterr().err.strip()
    assert rc == 2 and len(err.splitlines()) == 1 and "budget=" in err
    assert not out.exists()


def test_the_budget_counts_the_obj_given(tmp_path):
    # a world read from an OBJ: that file's bytes, also after a repair; else to_obj's text
    from vismobile.world.tjunctions import repair_tjunctions
    from vismobile.world.world import World

    world = town()
    assert world.obj_bytes() == len(world.obj_text())
    path = tmp_path / "town.obj"
    world.to_obj(path)
    text = path.read_text()
    path.write_text("# a comment the loader skips\n" + text)
    loaded = World.from_obj(path)
    assert loaded.obj_bytes() == path.stat().st_size == len(text) + 29
    assert repair_tjunctions(loaded)[0].obj_bytes() == path.stat().st_size

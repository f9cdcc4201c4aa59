"""Fly-over view cells (partition/pvs_fly.py, fly=on): layers over the street cells up to the
ceiling, the shadows from a fly-over region hide only what every line from it crosses a column
for, a bake without the top-face rule is caught, and random cameras in the fly-over cells
(inside, on faces, edges and corners; any fov and pitch; float64, float32, fixed16.16) lose no
triangle the item buffer shows."""
import numpy as np
import pytest

from .test_pvs_street import (PROFILE, blocked_share, box_part, in_cell_checks, street_masks,
                              town)
from vismobile.culling import Culler
from vismobile.partition import load_partition, partition
from vismobile.partition import pvs_fly, pvs_street
from vismobile.partition.pvs import bake
from vismobile.partition.pvs_codec import decode
from vismobile.partition.pvs_columns import find_columns
from vismobile.render import SENTINEL, item_buffer
from vismobile.scenes.surfaces import MeshCollector, tiled_rect
from vismobile.world.camera import Camera
from vismobile.world.world import World


def masks_of(extras, world):
    """(V, T) bool the cells' sets."""
    boxes = extras["pvs_cells"]
    patterns, ids = decode(extras, len(boxes), world.triangle_count)
    bits = np.unpackbits(patterns, axis=1)[:, :len(boxes)]
    return bits[ids.astype(np.int64)].T.astype(bool)


@pytest.fixture(scope="module")
def flown():
    world = town()  # the exact sets (budget=none): the street cells' are compared to a bake's
    return partition(world, "portal", depth=1, pvs="conservative", fly="on", budget="none")


@pytest.fixture(scope="module")
def street(flown):
    """The town's street cells and sets baked without fly-over cells."""
    return street_masks(flown.world)


def test_layers_reach_the_ceiling_over_unchanged_street_cells(flown, street):
    world = flown.world
    assert flown.params["fly"] == "on"
    boxes = flown.extras["pvs_cells"]
    street, street_sets = street
    k = len(street)
    assert np.array_equal(boxes[:k], street)  # the street cells first, their sets unchanged
    assert np.array_equal(masks_of(flown.extras, world)[:k], street_sets)
    fly = boxes[k:]
    _, _, top, _ = find_columns(world)
    layers = pvs_fly.fly_layers(world, top, street[:, 1, 1].max(),
                                pvs_street.street_cell(world), pvs_street.MIN_CELL)
    assert len(layers) >= 2 and layers[0][0] == street[:, 1, 1].max()
    assert layers[-1][1] == pytest.approx(pvs_fly.FLY_CEILING * top.max())
    for (y0, y1, cell, least), (n0, _, _, _) in zip(layers, layers[1:] + [(None,) * 4]):
        assert n0 is None or n0 == y1  # stacked without gaps
        inside = fly[fly[:, 0, 1] == y0]
        assert len(inside) and (inside[:, 1, 1] == y1).all()
        side = inside[:, 1, [0, 2]] - inside[:, 0, [0, 2]]
        whole = (inside[:, 1, [0, 2]] < world.extent[1][[0, 2]] - 1e-9).all(axis=1)
        assert side.max() <= cell + 1e-9 and side[whole].min() >= least - 1e-9
        assert (side[whole] < cell - 1e-9).any()  # split near the columns poking in


def test_fly_shadows_hide_only_what_every_line_from_the_region_crosses_a_column(flown, street):
    world = flown.world
    boxes = flown.extras["pvs_cells"]
    masks = masks_of(flown.extras, world)
    k = len(street[0])
    assert 0.05 < 1.0 - masks[k:].mean() < 0.9  # the fly-over sets leave something out
    share, total = blocked_share(world, boxes[k:], masks[k:], np.random.default_rng(5))
    assert total > 1000 and share == 1.0


def test_a_bake_sampling_the_bottom_face_is_caught(flown, monkeypatch):
    """Sample points on the boundary of each region's bottom face instead of its top (the
    raising step of the argument left out): eyes higher in the cell see over what the samples
    do not, and the segment check finds such lines."""
    world = flown.world
    top_face = pvs_street.boundary_samples
    monkeypatch.setattr(pvs_street, "boundary_samples",
                        lambda a, b: top_face(a, np.array([b[0], a[1], b[2]])))
    part = partition(world, "portal", depth=1, pvs="conservative", fly="on", budget="none")
    boxes = part.extras["pvs_cells"]
    assert np.array_equal(boxes, flown.extras["pvs_cells"])
    street = int(np.sum(boxes[:, 1, 1] <= boxes[0, 1, 1]))  # the street cells come first
    masks = masks_of(part.extras, world)
    share, total = blocked_share(world, boxes[street:], masks[street:],
                                 np.random.default_rng(5), tries=3000)
    assert total > 1000 and share < 1.0


def yard_world():
    """A 64 x 64 ground, a 20 m tower at (46.5, 46.5) (no corner on the ground's), and at
    (16, 16) a closed yard: four 8 m blocks overlapping at the corners (no shared corner: four
    columns) around 1 x 1 m, with a 0.4 m litter quad on its floor; the fly-over layer 11-30 m
    has a 32 m cell over it."""
    mesh = MeshCollector()
    for name, part in (("tower", box_part((46.5, 46.5), (7.0, 7.0), 20.0)),
                       ("north", box_part((16.0, 17.25), (4.2, 1.5), 8.0)),
                       ("south", box_part((16.0, 14.75), (4.1, 1.5), 8.0)),
                       ("east", box_part((17.25, 16.0), (1.5, 4.4), 8.0)),
                       ("west", box_part((14.75, 16.0), (1.5, 4.3), 8.0))):
        mesh.add(name, np.round(part[0], 5), part[1])
    mesh.add("litter", *tiled_rect((15.8, 0.05, 15.8), (0.4, 0.0, 0.0), (0.0, 0.0, 0.4), 1, 1,
                                   (0.0, 1.0, 0.0)))
    mesh.add("ground", *tiled_rect((0.0, 0.0, 0.0), (64.0, 0.0, 0.0), (0.0, 0.0, 64.0), 16, 16,
                                   (0.0, 1.0, 0.0)))
    return mesh.world("yard")


def test_a_bake_without_the_top_face_rule_is_caught(monkeypatch):
    """Seen from the boundary of the 32 m cell's top face, the walls hide the yard's litter;
    from above it, inside the face, it shows. Without face_triangles the bake leaves it out,
    and a camera in the cell looking down drops it; with the rule it keeps it."""
    world = yard_world()
    litter = np.flatnonzero(np.array(world.object_names)[world.object_ids] == "litter")
    assert len(find_columns(world)[0]) == 5
    cam = Camera(np.array([16.0, 29.0, 16.0]), yaw=0.0, pitch=-89.0, fov=20.0, near=0.1,
                 aspect=PROFILE.aspect)
    ids = np.unique(item_buffer(world, None, cam, PROFILE, cull_back=False))
    assert np.isin(litter, ids).all()  # the litter shows from above
    dropped = {}
    for rule in (False, True):
        if not rule:
            monkeypatch.setattr(pvs_street, "face_triangles",
                                lambda world, a, b, r: np.zeros(world.triangle_count, bool))
        else:
            monkeypatch.undo()
        part = partition(world, "portal", depth=1, pvs="conservative", fly="on", budget="none")
        boxes = part.extras["pvs_cells"]
        cell = np.flatnonzero(((boxes[:, 0] <= cam.eye) & (cam.eye <= boxes[:, 1])).all(axis=1))
        assert len(cell) == 1 and boxes[cell[0], 1, 0] - boxes[cell[0], 0, 0] == 32.0
        r = Culler(part, "pvs+vfc").cull(cam)
        assert "pvs.fallbacks" not in r.stats
        dropped[rule] = len(np.setdiff1d(litter, r.triangles))
    assert dropped == {False: 2, True: 0}


def test_cameras_in_fly_cells_drop_nothing_in_every_mode(flown, street):
    k = len(street[0])
    used = in_cell_checks(flown, 150, 21, boxes=flown.extras["pvs_cells"][k:])
    assert used > 120


def test_cameras_above_the_ceiling_fall_back(flown):
    boxes = flown.extras["pvs_cells"]
    top = boxes[:, 1, 1].max()
    culler = Culler(flown, "pvs+vfc")
    centre = boxes[-1].mean(axis=0)
    above = culler.cull(Camera(np.array([centre[0], top + 2.0, centre[2]]), pitch=-30))
    assert above.stats.get("pvs.fallbacks") == 1
    below = culler.cull(Camera(np.array([centre[0], top - 2.0, centre[2]]), pitch=-30))
    assert "pvs.fallbacks" not in below.stats


def test_the_fly_option(rooms, street):
    world = town()
    with pytest.raises(ValueError, match="pvs=conservative"):
        partition(world, "portal", depth=1, fly="on")
    with pytest.raises(ValueError, match="fly=maybe"):
        partition(world, "portal", depth=1, pvs="conservative", fly="maybe")
    with pytest.raises(ValueError, match="fly-over"):  # indoors: no street cells, any kind
        partition(rooms, "bsp", pvs="conservative", fly="on")
    with pytest.raises(ValueError, match="fly-over"):
        partition(rooms, "portal", depth=1, pvs="conservative", fly="on")
    off = partition(world, "portal", depth=1, pvs="conservative", fly="off")
    assert "fly" not in off.params
    extras, _ = bake(off)
    assert len(extras["pvs_cells"]) == len(street[0])


def test_the_fly_option_on_the_command_line(tmp_path, capsys, street):
    from vismobile.app.cli import main as cli

    world = town()
    obj = tmp_path / "town.obj"
    world.to_obj(obj)
    out = tmp_path / "town.vmp"
    assert cli(["partition", str(obj), "--structure=portal:1,pvs=conservative,fly=on", "-o",
                str(out)]) == 0
    assert "fly=on" in capsys.readouterr().out
    loaded = load_partition(out, World.from_obj(obj))  # the fly-over cells travel in the .vmp
    assert loaded.params["fly"] == "on"
    assert len(loaded.extras["pvs_cells"]) > len(street[0])
    assert (loaded.extras["pvs_cells"][:, 1, 1] > street[0][:, 1, 1].max()).any()
    for text, why in (("portal:1,fly=on", "pvs=conservative"), ("portal:1,pvs=conservative,"
                      "fly=up", "fly=up")):
        bad = tmp_path / "bad.vmp"
        assert cli(["partition", str(obj), f"--structure={text}", "-o", str(bad)]) == 2
        err = capsys.readouterr().err.strip()
        assert why in err and len(err.splitlines()) == 1 and not bad.exists()

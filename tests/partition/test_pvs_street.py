"""The outdoor PVS (partition/pvs_street.py, pvs_columns.py, pvs_shadow.py): which parts are
occluder columns, the shadows never hide a point some line from the cell region reaches, and
random cameras in the street cells (inside, on faces, edges and corners; any fov and pitch;
float64, float32, fixed16.16) lose no triangle the item buffer shows."""
import numpy as np
import pytest

from vismobile.culling import Culler, device_options
from vismobile.device.profile import get_profile
from vismobile.partition import load_partition, partition, save_partition
from vismobile.partition import pvs_street
from vismobile.partition.pvs import bake, bake_grow
from vismobile.partition.pvs_check import check_pvs
from vismobile.partition.pvs_codec import cell_sizes, decode
from vismobile.partition.pvs_columns import find_columns
from vismobile.render import SENTINEL, item_buffer
from vismobile.scenes.city import Building, building_mesh
from vismobile.scenes.surfaces import MeshCollector, tiled_rect
from vismobile.world.camera import Camera

MODES = ("float64", "float32", "fixed16.16")
PROFILE = get_profile("ipaq-hx2490b")


def town(extra=()):
    """A 60 x 60 ground (15 x 15 tiles) with 4 x 4 unaligned buildings 7-9 wide, 8-20 high, on
    lots 15 apart, plus the (name, (vertices, triangles)) parts in extra. Unrounded, a roof's
    corners may differ from its walls' by an ulp (a crack: no column, pvs_columns.py)."""
    rng = np.random.default_rng(7)
    mesh = MeshCollector()
    for i in range(4):
        for k in range(4):
            size = rng.uniform(7.0, 9.0, 2)
            house = Building((7.5 + 15 * i + rng.uniform(-1, 1), 7.5 + 15 * k + rng.uniform(-1, 1)),
                             tuple(size), float(rng.uniform(0, 90)), float(rng.uniform(8, 20)))
            v, t = building_mesh(house)
            mesh.add(f"b{i}{k}", np.round(v, 5), t)  # as an OBJ's digits: shared corners equal
    for name, part in extra:
        mesh.add(name, *part)
    mesh.add("ground", *tiled_rect((0.0, 0.0, 0.0), (60.0, 0.0, 0.0), (0.0, 0.0, 60.0), 15, 15,
                                   (0.0, 1.0, 0.0)))
    return mesh.world("town")


def box_part(centre, size, height, drop=None, lift=0.0):
    """A building's mesh (walls and roof, outward), wall `drop` left out, raised by lift."""
    v, t = building_mesh(Building(centre, size, 0.0, height))
    v = v + [0.0, lift, 0.0]
    if drop is not None:
        t = np.delete(t, [2 * drop, 2 * drop + 1], axis=0)
    return v, t


@pytest.fixture(scope="module")
def baked():
    world = town()
    return partition(world, "portal", depth=1, pvs="conservative")


def test_columns_are_only_closed_blocks_on_the_floor():
    extra = [("open", box_part((15.0, 15.0), (2.0, 2.0), 5.0, drop=1)),
             ("floating", box_part((30.0, 15.0), (2.0, 2.0), 5.0, lift=2.0))]
    v, t = box_part((15.0, 30.0), (2.0, 2.0), 5.0)
    extra.append(("inward", (v, t[:, ::-1])))
    world = town(extra)
    footprints, base, top, part = find_columns(world)
    assert len(footprints) == 16  # the buildings; open, floating and inward ones are not
    names = np.array(world.object_names)[world.object_ids]
    assert set(names[part >= 0]) == {f"b{i}{k}" for i in range(4) for k in range(4)}
    assert np.all(base == 0.0) and np.all(top >= 8.0)
    assert not pvs_street.outdoor(world, np.full(world.triangle_count, -1))


def segment_hits_prism(e, q, poly, top):
    """The segment e -> q passes through the prism poly (H, 2) x [0, top] (closed), by
    clipping against its planes (the 'truth' of the shadow test, no margins)."""
    t0, t1 = 0.0, 1.0
    d = q - e
    planes = [(np.array([0.0, 1.0, 0.0]), 0.0), (np.array([0.0, -1.0, 0.0]), top)]
    edge = np.roll(poly, -1, axis=0) - poly
    for (ax, az), (ex, ez) in zip(poly, edge):
        n = np.array([-ez, 0.0, ex])  # inward
        planes.append((n, -(n[0] * ax + n[2] * az)))
    for n, c in planes:  # inside: n . x + c >= 0
        a, b = n @ e + c, n @ d
        if b == 0.0:
            if a < 0:
                return False
            continue
        t = -a / b
        if b > 0:
            t0 = max(t0, t)
        else:
            t1 = min(t1, t)
    return t0 <= t1


def blocked_share(world, boxes, masks, rng, tries=3000):
    """Share of random (eye in a cell's region, point on a triangle the cell's set leaves out)
    segments that pass through some column: 1.0 when the shadows are sound."""
    footprints, _, top, _ = find_columns(world)
    # the cells tile the layer: a line starts in one (grown by the bake's growth, and by COVER
    # up and down: a near plane may reach over the layer)
    region = bake_grow(world) + np.array([0.0, pvs_street.COVER, 0.0])
    hits = total = 0
    for _ in range(tries):
        c = rng.integers(len(boxes))
        hidden = np.flatnonzero(~masks[c])
        if not len(hidden):
            continue
        lo, hi = boxes[c, 0] - region, boxes[c, 1] + region
        u = rng.uniform(0, 1, 3)
        u[rng.permutation(3)[:rng.integers(0, 4)]] = rng.integers(0, 2)  # faces, edges, corners
        e = lo + u * (hi - lo)
        tri = world.corners[rng.choice(hidden)]
        w = rng.dirichlet([1, 1, 1]) if rng.uniform() < 0.7 else np.eye(3)[rng.integers(3)]
        q = w @ tri
        total += 1
        hits += any(segment_hits_prism(e, q, p, h) for p, h in zip(footprints, top))
    return hits / max(total, 1), total


def street_masks(world, **overrides):
    """The street bake's cell boxes and (V, T) visible masks, with module constants overridden."""
    saved = {k: getattr(pvs_street, k) for k in overrides}
    try:
        for k, v in overrides.items():
            setattr(pvs_street, k, v)
        part = partition(world, "portal", depth=1)
        part.params["budget"] = "none"  # the walk's exact sets, not the default budget's
        extras, _ = bake(part)
    finally:
        for k, v in saved.items():
            setattr(pvs_street, k, v)
    boxes = extras["pvs_cells"]
    patterns, ids = decode(extras, len(boxes), world.triangle_count)
    bits = np.unpackbits(patterns, axis=1)[:, :len(boxes)]
    return boxes, bits[ids.astype(np.int64)].T.astype(bool)


def test_shadows_hide_only_what_every_line_from_the_region_crosses_a_column():
    world = town()
    boxes, masks = street_masks(world)
    assert 0.2 < masks.mean() < 0.9  # the shadows hide a good share, not everything
    share, total = blocked_share(world, boxes, masks, np.random.default_rng(3))
    assert total > 1000 and share == 1.0


def test_unsound_shadows_are_caught():
    """Samples far apart with footprints barely shrunk (reach() stays SPACING / 2, so shrinking
    no longer covers the gaps between samples): the segment check must find lines through."""
    world = town()
    boxes, masks = street_masks(world, SPACING=8.0, reach=lambda: 0.0)
    share, total = blocked_share(world, boxes, masks, np.random.default_rng(3), tries=6000)
    assert total > 1000 and share < 1.0


def in_cell_cameras(boxes, count, rng):
    for i in range(count):
        lo, hi = boxes[rng.integers(len(boxes))]
        t = rng.uniform(0, 1, 3)
        snap = rng.permutation(3)[:i % 4]  # 0..3 coordinates on the box's boundary
        t[snap] = rng.integers(0, 2, len(snap))
        yield Camera(lo + t * (hi - lo), yaw=rng.uniform(0, 360), pitch=rng.uniform(-89, 89),
                     fov=rng.uniform(10, 120), near=0.1, aspect=PROFILE.aspect)


def in_cell_checks(part, count, seed, boxes=None) -> int:
    """Asserts `pvs+vfc` keeps all the item buffer shows from count in-cell cameras (in boxes,
    default every view cell), the arithmetic modes in turn; returns how many used the PVS
    (did not fall back)."""
    cullers = {m: Culler(part, "pvs+vfc", **({"arithmetic": "float64"} if m == "float64"
                                              else device_options(get_profile(PROFILE, m))))
               for m in MODES}
    used = 0
    cameras = in_cell_cameras(part.extras["pvs_cells"] if boxes is None else boxes, count,
                              np.random.default_rng(seed))
    for i, cam in enumerate(cameras):
        mode = MODES[i % 3]
        profile = PROFILE if mode == "float64" else get_profile(PROFILE, mode)
        r = cullers[mode].cull(cam)
        ids = np.unique(item_buffer(part.world, None, cam, profile, cull_back=False))
        shown = ids[ids != SENTINEL].astype(np.int64)
        assert not len(np.setdiff1d(shown, r.triangles)), (i, mode, cam.eye)
        used += "pvs.fallbacks" not in r.stats
    return used


def test_in_cell_cameras_drop_nothing_in_every_mode(baked):
    world = baked.world
    assert "pvs_cover" in baked.extras
    boxes = baked.extras["pvs_cells"]
    used = in_cell_checks(baked, 150, 11)
    # near 0.1 and fov <= 120 fit the cover; a camera on a cell's side that faces a building's
    # inside or the world's edge falls back (its near plane may leave the cells)
    assert used > 120
    sizes = cell_sizes(*decode(baked.extras, len(boxes), world.triangle_count), len(boxes))
    assert sizes.mean() < 0.9 * world.triangle_count


def test_a_mesh_object_is_only_hidden_never_hides(cow):
    """A cow (5,804 triangles, not 2.5D) standing between the buildings: no column, partly
    hidden from some cells, and in-cell cameras in every mode lose none of it or anything."""
    v = cow.vertices * 0.4
    v = v - [v[:, 0].mean(), v[:, 1].min(), v[:, 2].mean()] + [15.0, 0.0, 15.0]
    world = town([("cow", (v, cow.triangles))])
    part = partition(world, "portal", depth=1, pvs="conservative")
    _, _, _, column = find_columns(world)
    herd = np.array(world.object_names)[world.object_ids] == "cow"
    assert (column[herd] < 0).all()
    boxes = part.extras["pvs_cells"]
    patterns, ids = decode(part.extras, len(boxes), world.triangle_count)
    bits = np.unpackbits(patterns, axis=1)[:, :len(boxes)][ids.astype(np.int64)]
    assert (bits[herd] == 0).any()  # some cell's set leaves some of the cow out
    assert in_cell_checks(part, 60, 4) > 45


def test_cameras_off_the_street_layer_fall_back(baked):
    culler = Culler(baked, "pvs+vfc")
    boxes = baked.extras["pvs_cells"]
    centre = boxes[0].mean(axis=0)
    above = culler.cull(Camera(centre + [0, 20, 0], pitch=-30))
    assert above.stats.get("pvs.fallbacks") == 1
    close = culler.cull(Camera(centre, near=0.01))
    assert close.stats.get("pvs.fallbacks") == 1
    inside = culler.cull(Camera(centre))
    assert "pvs.fallbacks" not in inside.stats


def test_cover_is_stored_and_checked(baked, tmp_path):
    path = tmp_path / "town.vmp"
    save_partition(baked, path)
    loaded = load_partition(path, baked.world)
    assert np.array_equal(loaded.extras["pvs_cover"], baked.extras["pvs_cover"])
    for bad in (np.array([-1.0, 0.1]), np.array([0.75]), np.array([np.nan, 0.1])):
        with pytest.raises(ValueError, match="pvs_cover"):
            check_pvs({**baked.extras, "pvs_cover": bad}, baked.world.triangle_count)


@pytest.mark.parametrize("kind", ["bsp", "kdtree"])
def test_every_kind_takes_the_street_cells(baked, kind):
    """Outdoors the view cells and sets do not depend on the structure: the BSP tree (whose
    leaves got the grid's cells, sets of the whole world) and a k-d tree bake the portal
    structure's street cells and shadows, and the BSP's in-cell cameras drop nothing."""
    part = partition(baked.world, kind, pvs="conservative")
    assert "pvs_cover" in part.extras
    for name in ("pvs_cells", "pvs_cover", "pvs_grow", "pvs_back"):
        assert np.array_equal(part.extras[name], baked.extras[name]), name
    cells = len(part.extras["pvs_cells"])
    ours = decode(part.extras, cells, baked.world.triangle_count)
    theirs = decode(baked.extras, cells, baked.world.triangle_count)
    assert all(np.array_equal(a, b) for a, b in zip(ours, theirs))
    sizes = cell_sizes(*ours, cells)
    assert sizes.mean() < 0.9 * baked.world.triangle_count
    if kind == "bsp":
        assert in_cell_checks(part, 90, 23) > 70

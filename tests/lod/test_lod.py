"""Level of detail: chains (meshoptimizer), ties, selection, storage, heap, and the image error
with the real renderer (tau = 0 reproduces the full-detail frame bit for bit)."""
import numpy as np
import pytest
import trimesh

from vismobile.world.camera import Camera
from vismobile.errors import PartitionError
from vismobile.lod import LodChains, LodSelector, image_error, render_world
from vismobile.lod.nearest import nearest_triangle, triangle_samples
from vismobile.lod.simplify import RATIO, build_chains
from vismobile.partition import load_partition, partition, save_partition
from vismobile.device.profile import get_profile
from vismobile.render import Renderer
from vismobile.render.lod_view import LodView
from vismobile.world import World

PROFILE = get_profile("ipaq-hx2490b")


@pytest.fixture(scope="module")
def world(lod_world):
    return lod_world


@pytest.fixture(scope="module")
def chains(world):
    return build_chains(world)


def distance_to_surface(points, corners):
    """Brute-force oracle: distance from each point to the nearest triangle (dense sampling
    is not exact, so use the closest-point routine of trimesh)."""
    mesh = trimesh.Trimesh(corners.reshape(-1, 3), np.arange(3 * len(corners)).reshape(-1, 3),
                           process=False)
    return trimesh.proximity.closest_point_naive(mesh, points)[1]


def test_nearest_triangle_matches_brute_force():
    rng = np.random.default_rng(3)
    corners = rng.uniform(-1, 1, (60, 3, 3)) * [1, 1, 0.1] + rng.uniform(-3, 3, (60, 1, 3))
    points = rng.uniform(-4, 4, (300, 3))
    index, dist = nearest_triangle(corners, points)
    expected = distance_to_surface(points, corners)
    assert np.allclose(dist, expected, atol=1e-9)
    # The index names a triangle at that distance.
    own = np.array([distance_to_surface(p[None], corners[i][None])[0]
                    for p, i in zip(points, index)])
    assert np.allclose(own, dist, atol=1e-9)


def test_triangle_samples_lie_inside_their_triangles():
    corners = np.array([[[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 0, 1], [2, 0, 1], [0, 2, 1]]],
                       dtype=float)
    points, owner = triangle_samples(corners, [1, 9])
    assert np.bincount(owner).tolist() == [1, 9]
    assert np.all(points[:, :2] >= 0)
    assert np.all(points[owner == 0].sum(axis=1) < 1) and np.all(points[owner == 1, :2].sum(1) < 2)


def test_chains_hold_coarser_levels_with_growing_error(world, chains):
    chains.check(world)
    assert set(chains.level_object.tolist()) == {1, 2}  # the 12-triangle floor keeps level 0
    for obj in (1, 2):
        entries = chains.levels_of(obj)
        sizes = np.diff(chains.level_start)[entries]
        assert len(entries) >= 3 and np.all(np.diff(sizes) < 0)
        assert sizes[0] <= RATIO * np.sum(world.object_ids == obj) + 1
        assert np.all(np.diff(chains.level_error[entries]) >= 0)
        assert chains.level_error[entries[-1]] > 0


def test_level_error_bounds_the_distance_of_the_original_vertices(world, chains):
    # Every original vertex lies within the level's error of the level's surface.
    for entry in range(chains.level_count):
        obj = chains.level_object[entry]
        tris = chains.triangles[chains.level_start[entry]:chains.level_start[entry + 1]]
        used = np.unique(world.triangles[world.object_ids == obj])
        far = distance_to_surface(world.vertices[used], world.vertices[tris])
        assert far.max() <= chains.level_error[entry] * (1 + 1e-6) + 1e-9


def test_tau_zero_is_the_full_detail_frame_bit_for_bit(world, chains):
    tree = partition(world, "octree", depth=3)
    camera = Camera((0.0, 1.0, 6.0), yaw=0.0, pitch=-10.0, aspect=PROFILE.aspect)
    ids = np.arange(world.triangle_count)
    plain = Renderer(world, PROFILE).render_rgb(ids, camera)
    view = LodView(world, chains, PROFILE, tau=0.0)
    frame = view.draw(ids, camera)
    assert np.array_equal(frame.selection.triangles, ids)
    assert np.array_equal(view.renderer.read_rgb(), plain)
    assert frame.error["psnr_db"] == float("inf") and frame.error["max_diff"] == 0
    assert tree.world is world


def test_far_objects_drop_to_coarse_levels_with_small_image_error(world, chains):
    selector = LodSelector(world, chains, PROFILE.resolution)
    ids = np.arange(world.triangle_count)
    close = Camera((0.0, 0.5, 2.5), yaw=0.0, aspect=PROFILE.aspect)
    near = Camera((0.0, 0.5, 12.0), yaw=0.0, aspect=PROFILE.aspect)
    far = Camera((0.0, 0.5, 60.0), yaw=0.0, aspect=PROFILE.aspect)
    a, b = selector.select(ids, near, 1.0), selector.select(ids, far, 1.0)
    assert np.array_equal(selector.select(ids, close, 1.0).triangles, ids)
    assert len(b.triangles) < len(a.triangles) < len(ids)
    assert b.levels[1] > a.levels[1] > 0 and b.levels[0] == 0  # the floor has no levels
    # The chosen level's error projects below tau, the next finer one's does not.
    from vismobile.terrain.tiles import pixel_scale

    scale = pixel_scale(near, PROFILE.resolution)[1]
    entries = chains.levels_of(1)
    d = 12.0 - 1.0  # eye to the sphere's box
    assert scale * chains.level_error[entries[a.levels[1] - 1]] / d < 1.0
    if a.levels[1] < len(entries):
        assert scale * chains.level_error[entries[a.levels[1]]] / d >= 1.0
    # The level's error projects below tau: lambda_b * E / d < tau for the chosen entry.
    frame = LodView(world, chains, PROFILE, tau=1.0).draw(ids, near)
    assert frame.drawn.triangles == len(a.triangles)
    assert frame.error["psnr_db"] > 35.0 and 0 < frame.error["changed"] < 0.2
    coarse = LodView(world, chains, PROFILE, tau=16.0).draw(ids, near)
    assert coarse.drawn.triangles < frame.drawn.triangles
    assert 0 < coarse.error["psnr_db"] < frame.error["psnr_db"]  # the measure sees it


def test_selection_ties_follow_culling(world, chains):
    # Only the sphere's front half kept: its level draws only triangles tied to kept ones.
    selector = LodSelector(world, chains, PROFILE.resolution)
    sphere = np.flatnonzero(world.object_ids == 1)
    front = sphere[world.centroids[sphere, 2] > 0.3]
    camera = Camera((0.0, 0.0, 30.0), yaw=0.0, aspect=PROFILE.aspect)
    s = selector.select(front, camera, 1.0)
    level_tris = s.triangles[s.triangles >= world.triangle_count] - world.triangle_count
    z = world.vertices[chains.triangles[level_tris]].mean(axis=1)[:, 2]
    assert len(level_tris) and z.min() > -0.2 and s.replaced == len(front)


def test_image_error_measures():
    a = np.zeros((4, 5, 3), np.uint8)
    b = a.copy()
    b[0, 0] = (255, 0, 0)
    e = image_error(a, b)
    assert e["max_diff"] == 255 and e["changed"] == pytest.approx(1 / 20)
    assert e["psnr_db"] == pytest.approx(10 * np.log10(255 ** 2 / (255 ** 2 / 60)))
    assert image_error(a, a)["psnr_db"] == float("inf")


def test_vmp_stores_chains_checked_and_counted(world, chains, tmp_path):
    tree = partition(world, "octree", depth=3)
    before = PROFILE.estimate_memory(world, tree)
    tree.extras.update(chains.to_extras())
    after = PROFILE.estimate_memory(world, tree)
    assert after["partition"] - before["partition"] == chains.nbytes
    assert after["lod_buffers"] > 3 * chains.triangle_count * 20
    path = tmp_path / "w.vmp"
    save_partition(tree, path)
    loaded = LodChains.from_extras(load_partition(path).extras)
    for name in ("triangles", "level_error", "owner", "extra_start", "extra_tri", "object_bounds"):
        assert np.array_equal(getattr(loaded, name), getattr(chains, name))
    # A flipped byte in a level section fails its CRC; inconsistent arrays fail the check.
    from vismobile.partition.store import to_bytes

    data = bytearray(path.read_bytes())
    import json
    import struct

    header_len = struct.unpack_from("<8sIII", data, 0)[2]
    header = json.loads(bytes(data[20:20 + header_len]))
    base = 20 + header_len
    base += -base % 64
    section = next(s for s in header["sections"] if s["name"].startswith("extras.lod_owner"))
    data[base + section["offset"]] ^= 0xFF
    bad = tmp_path / "bad.vmp"
    bad.write_bytes(bytes(data))
    with pytest.raises(PartitionError, match="checksum"):
        load_partition(bad)
    tree.extras["lod_owner"] = tree.extras["lod_owner"][:-1]
    bad.write_bytes(to_bytes(tree))
    with pytest.raises(PartitionError, match="lod owner"):
        load_partition(bad)


def test_render_world_keeps_the_original_ids(world, chains):
    big = render_world(world, chains)
    assert big.triangle_count == world.triangle_count + chains.triangle_count
    assert np.array_equal(big.corners[:world.triangle_count], world.corners)

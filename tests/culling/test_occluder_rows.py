"""occlusion's per-triangle rows, scores and occluder meshes computed from corners against the
World's tables and numpy's occluder_mesh (same bits)."""
import numpy as np
import pytest

from vismobile.culling.occluder_rows import triangle_rows
from vismobile.world.world import World


def random_world(count, seed, dtype):
    """A World of count random triangles (scales 0.01-100, two degenerate) and its vertices in
    dtype (float32 values widen exactly)."""
    rng = np.random.default_rng(seed)
    vertices = rng.normal(size=(3 * count, 3)) * rng.uniform(0.01, 100.0, (3 * count, 1))
    vertices[3:6] = vertices[0]  # triangle 1 collapses to a point
    vertices[8] = vertices[7]  # triangle 2 is a segment
    vertices = vertices.astype(dtype)
    triangles = np.arange(3 * count, dtype=np.int32).reshape(-1, 3)
    return World(vertices.astype(np.float64), triangles), vertices


@pytest.mark.parametrize("dtype", [np.float64, np.float32])
def test_rows_give_the_bits_of_the_world_tables(dtype):
    world, vertices = random_world(700, 21, dtype)
    ids = np.random.default_rng(2).permutation(world.triangle_count).astype(np.int64)
    normals, v0, centroids, radius, areas = triangle_rows(ids, vertices, world.triangles)
    corners = world.corners[ids]
    assert np.array_equal(normals, world.normals[ids])
    assert np.array_equal(v0, corners[:, 0])
    assert np.array_equal(centroids, world.centroids[ids])
    assert np.array_equal(areas, world.areas[ids])
    expect = np.linalg.norm(world.corners - world.centroids[:, None], axis=2).max(1)[ids]
    assert np.array_equal(radius, expect)
    assert (areas == 0).sum() == 2 and not normals[areas == 0].any()
    assert all(len(a) == 0 for a in triangle_rows(ids[:0], vertices, world.triangles))


@pytest.mark.parametrize("dtype", [np.float64, np.float32])
def test_scores_from_corners_are_the_scores_of_the_world_tables(dtype):
    from vismobile.world.camera import Camera
    from vismobile.culling.hiz import score_candidates
    from vismobile.culling.occluder_rows import score_corners

    world, vertices = random_world(700, 22, dtype)
    radius = np.linalg.norm(world.corners - world.centroids[:, None], axis=2).max(1)
    ids = np.random.default_rng(3).permutation(world.triangle_count).astype(np.int64)
    for eye, yaw in (((0.0, 0.0, 0.0), 0.0), ((10.0, -5.0, 3.0), 130.0)):
        camera = Camera(eye, yaw=yaw, pitch=10.0, aspect=0.75, far=200.0)
        planes = np.ascontiguousarray(camera.frustum_planes(), dtype=np.float64)
        eye = np.asarray(camera.eye, dtype=np.float64)
        expect = score_candidates(ids, world.normals, np.ascontiguousarray(world.corners[:, 0]),
                                  world.centroids, radius, world.areas, planes, eye, 1e-6)
        got = score_corners(ids, vertices, world.triangles, planes, eye, 1e-6)
        assert np.array_equal(got, expect) and 0 < (got > 0).sum() < len(ids)


def test_the_compiled_mesh_of_a_few_occluders_is_occluder_mesh_of_their_corners(kit):
    # A mapped world's frames build their occluders' mesh in one kernel: the same arrays, bits
    # included, as occluder_mesh (numpy) of the same triangles' corners and unit normals.
    from vismobile.culling.occluder_rows import occluder_mesh_of
    from vismobile.culling.occluder_mesh import occluder_mesh
    from vismobile.world.world import unit_normals

    world = kit.world("w2")
    rng = np.random.default_rng(7)
    paired = 0
    for start in rng.integers(0, world.triangle_count - 400, 6):
        ids = np.unique(np.concatenate([np.arange(start, start + 300),  # neighbours pair
                                        rng.integers(0, world.triangle_count, 200)]))
        corners = world.corners[ids]
        expect = occluder_mesh(corners.reshape(-1, 3), np.arange(3 * len(ids)).reshape(-1, 3),
                               unit_normals(corners)[0])
        got = occluder_mesh_of(ids.astype(np.int64), world.vertices, world.triangles)
        for name, a, b in zip(("points", "tri_points", "normals", "offsets", "groups", "start",
                               "end", "a", "b", "partner", "partner_any"), got, expect):
            assert a.shape == b.shape and np.array_equal(a, b), name
        paired += (got[9] >= 0).sum()
    assert paired > 100
    assert all(len(a) == 0 for a in occluder_mesh_of(np.zeros(0, np.int64), world.vertices,
                                                     world.triangles))

"""The compiled kernels against plain numpy references: distinct gather, frustum walk, back-face
test; empty inputs on purpose."""
import numpy as np

from vismobile.camera import Camera
from vismobile.culling.kernels import backfacing, frustum_walk, gather_distinct
from vismobile.culling.tree import Tree
from vismobile.culling.triangle_backface import GAMMA_8, certainly_backfacing, triangle_cross


def gather(tri_refs, starts, ends, nodes, count):
    words = count // 64 + 1
    bits = np.zeros(words, dtype=np.uint64)
    out = np.empty(count, dtype=np.int64)
    n = gather_distinct(tri_refs, starts, ends, nodes, bits, np.empty(words, np.int64), out)
    assert not bits.any()  # the bitmap is left clear for the next frame
    return out[:n]


def test_gather_distinct_is_sorted_unique_of_the_ranges():
    rng = np.random.default_rng(3)
    refs = rng.integers(0, 1000, 5000).astype(np.int64)
    starts = np.sort(rng.integers(0, 5000, 40)).astype(np.int64)
    ends = np.minimum(starts + rng.integers(0, 300, 40), 5000).astype(np.int64)
    nodes = rng.choice(40, 25, replace=False).astype(np.int64)
    expect = np.unique(np.concatenate([refs[starts[k]:ends[k]] for k in nodes]))
    assert np.array_equal(gather(refs, starts, ends, nodes, 1000), expect)


def test_gather_distinct_of_no_nodes_is_empty():
    refs = np.arange(10, dtype=np.int64)
    assert len(gather(refs, np.zeros(1, np.int64), np.full(1, 10), np.zeros(0, np.int64), 10)) == 0


def test_frustum_walk_keeps_every_triangle_in_the_frustum(w1_octree):
    tree = Tree(w1_octree)
    world = w1_octree.world
    rng = np.random.default_rng(5)
    low, high = world.extent
    for _ in range(6):
        cam = Camera(rng.uniform(low, high), yaw=rng.uniform(0, 360), pitch=rng.uniform(-40, 40),
                     aspect=0.75)
        planes = cam.frustum_planes()
        nodes, visited, tests, culled = tree.walk(np.zeros(1, np.int64), np.zeros(1, np.int64),
                                                  planes[None])
        sent = np.unique(tree.refs(nodes))
        # Oracle: triangles with a sampled point (barycentric grid) inside every plane.
        bary = np.array([(i, j, 8 - i - j) for i in range(9) for j in range(9 - i)]) / 8.0
        points = np.einsum("sk,tkj->tsj", bary, world.corners)  # (T, S, 3)
        dist = points @ planes[:, :3].T + planes[:, 3]  # (T, S, 6)
        inside = np.flatnonzero((dist >= 0).all(axis=2).any(axis=1))
        assert len(inside)
        assert np.all(np.isin(inside, sent))
        assert visited >= len(nodes) and tests >= visited


def test_frustum_walk_from_no_roots_accepts_nothing():
    lo = np.zeros((1, 3))
    out = np.empty(4, dtype=np.int64)
    stack = [np.empty(4, dtype=np.int64) for _ in range(3)]
    count, visited, *_ = frustum_walk(lo, lo + 1.0, np.full(1, -1), np.zeros(1, np.int64),
                                      np.ones(1, bool), np.zeros(0, np.int64),
                                      np.zeros(0, np.int64), np.zeros((1, 6, 4)), 0.0, out,
                                      *stack)
    assert count == 0 and visited == 0


def test_backfacing_kernel_matches_the_numpy_bound():
    rng = np.random.default_rng(11)
    corners = rng.normal(size=(500, 3, 3)) * 10.0
    cross, abs_cross, ea, eb = triangle_cross(corners)
    packed = np.column_stack([cross, abs_cross, corners[:, 0], ea, eb])
    eye = np.array([0.5, -1.0, 2.0])
    ids = np.arange(500, dtype=np.int64)
    for delta in (0.0, 1e-3, 0.5):
        expect = certainly_backfacing(cross, abs_cross, ea, eb, corners[:, 0], eye, delta)
        assert np.array_equal(backfacing(ids, packed, eye, delta, GAMMA_8), expect)
    assert len(backfacing(ids[:0], packed, eye, 0.0, GAMMA_8)) == 0

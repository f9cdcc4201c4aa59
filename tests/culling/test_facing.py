"""The back-face stages' per-candidate kernels against their numpy references (same bits), and
tbfc, cbfc and cone on a memory-mapped world (streamed .vmp) against the same world in memory."""
import numpy as np
import pytest

from vismobile.world.camera import Camera
from vismobile.culling import Culler, backface, cones
from vismobile.culling.facing import (TILT_BIAS, TILT_EXACT, backfacing, frontfacing,
                                      keep_unmarked, not_backfacing, tilt_of, tilt_scales,
                                      tilt_select)
from vismobile.culling.triangle_backface import GAMMA_8, certainly_backfacing, triangle_cross
from vismobile.geometry.tilt import tilt_coefficients, tilt_sine
from vismobile.world.mapped import MappedWorld
from vismobile.partition import load_partition
from vismobile.partition.store import map_partition


def random_mesh(count, seed, dtype=np.float64):
    """(vertices (3 count, 3), triangles (count, 3) int32) with a few zero-area triangles."""
    rng = np.random.default_rng(seed)
    vertices = (rng.normal(size=(3 * count, 3)) * rng.uniform(0.01, 100.0, (3 * count, 1)))
    vertices[3:6] = vertices[0]  # triangle 1 collapses to a point
    vertices[8] = vertices[7]  # triangle 2 is a segment
    triangles = np.arange(3 * count, dtype=np.int32).reshape(-1, 3)
    return vertices.astype(dtype), triangles


def tilt_keep(ids, regions, scales, spare, vertices, triangles, move):
    """(n,) bool: tilt_select's answer per id (it writes the kept ids, in order, and no other
    value: the rest of out keeps its fill)."""
    out = np.full(len(ids) + 1, -7, dtype=np.int64)
    count = tilt_select(ids, regions, scales, spare, vertices, triangles, move, out)
    assert (out[count:] == -7).all()
    keep = np.isin(ids, out[:count])
    assert np.array_equal(out[:count], ids[keep])
    return keep


@pytest.mark.parametrize("dtype", [np.float64, np.float32])
def test_backfacing_kernel_matches_the_numpy_bound(dtype):
    vertices, triangles = random_mesh(600, 11, dtype)
    corners = vertices.astype(np.float64)[triangles]
    cross, abs_cross, ea, eb = triangle_cross(corners)
    ids = np.arange(len(triangles), dtype=np.int64)
    eye = np.array([0.5, -1.0, 2.0])
    for delta in (0.0, 1e-3, 0.5):
        expect = certainly_backfacing(cross, abs_cross, ea, eb, corners[:, 0], eye, delta)
        got = backfacing(ids, vertices, triangles, eye, delta, GAMMA_8)
        assert np.array_equal(got, expect) and 0 < got.sum() < len(ids)
        shuffled = ids[::-1].copy()  # any order: the kept ids come out in theirs
        kept = np.full(len(ids), -7, dtype=np.int64)
        count = not_backfacing(shuffled, vertices, triangles, eye, delta, GAMMA_8, kept)
        assert np.array_equal(kept[:count], shuffled[~expect[shuffled]])
    assert len(backfacing(ids[:0], vertices, triangles, eye, 0.0, GAMMA_8)) == 0


@pytest.mark.parametrize("dtype", [np.float64, np.float32])
def test_frontfacing_is_backfacing_of_the_reversed_triangle(dtype):
    # occlusion's occluder test: the numpy bound over reversed cross products (the packed table
    # it kept before) gives the same bits as the corners read per candidate.
    vertices, triangles = random_mesh(600, 13, dtype)
    corners = vertices.astype(np.float64)[triangles]
    cross, abs_cross, ea, eb = triangle_cross(corners)
    ids = np.arange(len(triangles), dtype=np.int64)
    eye = np.array([0.5, -1.0, 2.0])
    for delta in (0.0, 1e-3, 0.5):
        expect = certainly_backfacing(-cross, abs_cross, ea, eb, corners[:, 0], eye, delta)
        got = frontfacing(ids, vertices, triangles, eye, delta, GAMMA_8)
        assert np.array_equal(got, expect) and 0 < got.sum() < len(ids)
        assert not (got & backfacing(ids, vertices, triangles, eye, delta, GAMMA_8)).any()
    assert not frontfacing(ids[1:3], vertices, triangles, eye, 0.0, GAMMA_8).any()  # degenerate


@pytest.mark.parametrize("dtype", [np.float64, np.float32])
def test_tilt_kernel_gives_the_bits_of_tilt_coefficients(dtype):
    vertices, triangles = random_mesh(600, 12, dtype)
    with np.errstate(invalid="ignore"):
        k1, k2 = tilt_coefficients(vertices.astype(np.float64)[triangles])
    got = np.array([tilt_of(vertices, triangles, t) for t in range(len(triangles))])
    assert not np.isfinite(k1[1:3]).any()  # the degenerate ones (a point gives nan: 0 * inf)
    assert np.array_equal(got[:, 0], k1, equal_nan=True) and np.array_equal(got[:, 1], k2)
    # cbfc's keep: spare per region against the tilt sine, for moves 0 (inf * 0) and positive
    rng = np.random.default_rng(4)
    regions = rng.integers(0, 5, len(triangles)).astype(np.uint8)
    spare = np.array([-1.0, 0.0, 1e-6, 1e-3, 0.5])
    ids = np.arange(len(triangles), dtype=np.int64)
    scales = np.empty(len(triangles), dtype=np.uint8)
    tilt_scales(vertices, triangles, 0, scales)
    exact = np.full_like(scales, TILT_EXACT)  # every tilt computed from the corners
    for move in (0.0, 1e-7, 1e-3):
        expect = ~(spare[regions] >= tilt_sine(k1, k2, move))
        for table in (scales, exact):
            got = tilt_keep(ids, regions, table, spare, vertices, triangles, move)
            assert np.array_equal(got, expect)
    assert not tilt_keep(ids, regions, scales, spare, vertices, triangles, 0.0).all()


@pytest.mark.parametrize("dtype", [np.float64, np.float32])
def test_tilt_scales_bound_the_tilt_and_are_the_smallest_power_of_two(dtype):
    vertices, triangles = random_mesh(600, 13, dtype)
    vertices[30:33] *= 1e-60 if dtype == np.float64 else 1e-30  # a tiny triangle 10
    with np.errstate(invalid="ignore"):
        k1, k2 = tilt_coefficients(vertices.astype(np.float64)[triangles])
    scales = np.empty(len(triangles) - 5, dtype=np.uint8)
    tilt_scales(vertices, triangles, 5, scales)  # a chunk: triangles 5 onwards
    k1, k2 = k1[5:], k2[5:]
    finite = np.isfinite(k1) & np.isfinite(k2)
    with np.errstate(invalid="ignore"):
        beyond = np.maximum(np.frexp(k1)[1], (np.frexp(k2)[1] + 1) // 2) + TILT_BIAS > 254
    assert np.array_equal(scales == TILT_EXACT, ~finite | beyond)
    assert beyond[5] == (dtype == np.float64) and (~finite).sum() == 0  # 1 and 2 are skipped
    ok = scales != TILT_EXACT
    scale = np.ldexp(1.0, scales[ok].astype(int) - TILT_BIAS)
    assert (scale >= k1[ok]).all() and (scale * scale >= k2[ok]).all()
    assert ((scale / 2 < k1[ok]) | (scale * scale / 4 < k2[ok])).all()  # no smaller one fits
    for move in (1e-9, 1e-4, 0.3, 10.0):
        assert (scale * move + scale * scale * (move * move)
                >= tilt_sine(k1[ok], k2[ok], move)).all()
    # Spares on both sides of each triangle's tilt and of its bound (one region per triangle):
    # tilt_select still answers as the tilt does.
    ids = np.arange(5, len(triangles), dtype=np.int64)
    regions = np.arange(len(triangles), dtype=np.uint16)
    rng = np.random.default_rng(6)
    for move in (1e-6, 1e-3):
        tilt = tilt_sine(k1, k2, move)
        spare = np.append(np.zeros(5), np.where(np.isfinite(tilt), tilt, 1.0)
                          * rng.uniform(0.5, 4.0, len(tilt)))
        full = np.zeros(len(triangles), dtype=np.uint8)
        full[5:] = scales
        got = tilt_keep(ids, regions, full, spare, vertices, triangles, move)
        assert np.array_equal(got, ~(spare[5:] >= tilt)) and 0 < got.sum() < len(ids)


def test_keep_unmarked_drops_exactly_the_culled_clusters_and_clears_its_bitmap():
    rng = np.random.default_rng(5)
    refs = rng.integers(0, 700, 3000).astype(np.int32)
    bounds = np.sort(rng.integers(0, 3000, 41))
    bounds[0], bounds[-1] = 0, 3000
    starts, ends = bounds[:-1].astype(np.int64), bounds[1:].astype(np.int64)
    culled = np.array([3, 7, 8, 30], dtype=np.int64)
    bits = np.zeros(700 // 64 + 1, dtype=np.uint64)
    ids = np.arange(700, dtype=np.int64)
    dropped = np.zeros(700, dtype=bool)
    for c in culled:
        dropped[refs[starts[c]:ends[c]]] = True
    assert dropped.any()
    assert np.array_equal(keep_unmarked(ids, refs, starts, ends, culled, bits), ~dropped)
    assert not bits.any()
    assert keep_unmarked(ids, refs, starts, ends, culled[:0], bits).all()


@pytest.fixture(scope="module")
def streamed(w1_streamed):
    return w1_streamed


@pytest.mark.parametrize("arithmetic", ["float64", "fixed16.16"])
def test_backface_stages_on_a_mapped_world_cull_as_in_memory(streamed, monkeypatch, arithmetic):
    # Small chunks, so cbfc's regions and cone's leaf groups are built in many pieces.
    monkeypatch.setattr(backface, "CHUNK", 1000)
    monkeypatch.setattr(cones, "CHUNK", 700)
    mapped, loaded = map_partition(streamed), load_partition(streamed)
    assert isinstance(mapped.world, MappedWorld) and not isinstance(loaded.world, MappedWorld)
    rng = np.random.default_rng(3)
    low, high = loaded.world.extent
    cameras = [Camera(rng.uniform(low, high), yaw=rng.uniform(-180, 180),
                      pitch=rng.uniform(-50, 50), aspect=0.75) for _ in range(12)]
    for stages, counter in (("vfc,tbfc", "tbfc.triangles_culled"),
                            ("vfc,cbfc", "cbfc.refs_culled"),
                            ("vfc,cone", "cone.clusters_culled"),
                            ("vfc,cone,cbfc,tbfc", "triangles_tested"),
                            ("vfc,cbfc_thesis", "cbfc_thesis.refs_culled")):
        a = Culler(mapped, stages, arithmetic=arithmetic)
        b = Culler(loaded, stages, arithmetic=arithmetic)
        dropped = 0
        for camera in cameras:
            x, y = a.cull(camera), b.cull(camera)
            assert np.array_equal(x.triangles, y.triangles), stages
            assert np.array_equal(x.nodes, y.nodes) and x.stats == y.stats, stages
            dropped += x.stats.get(counter, 0)
        assert dropped > 0, stages  # the stage did cull something on these cameras
    stage = Culler(mapped, "cbfc").stages[0]
    assert stage.regions.dtype == np.uint8  # one byte per triangle
    stage = Culler(mapped, "cone").stages[0]
    assert stage.cluster_refs.dtype == np.int32


def test_cone_groups_of_leaves_give_the_cones_of_the_whole(streamed, monkeypatch):
    loaded = load_partition(streamed)
    whole = Culler(loaded, "cone").stages[0]
    monkeypatch.setattr(cones, "CHUNK", 300)
    pieces = Culler(map_partition(streamed), "cone").stages[0]
    for name in ("cluster_refs", "starts", "ends", "apex", "axis", "cutoff", "rounding"):
        assert np.array_equal(getattr(pieces, name), getattr(whole, name)), name
    counts = np.diff(np.append(whole.starts, whole.ends[-1]))
    assert counts.sum() == len(whole.cluster_refs) and (counts > 0).sum() > 1


def test_leaf_groups_cover_every_leaf_once():
    counts = np.array([5, 0, 300, 2, 2, 0, 900, 1, 1])
    groups = list(cones.leaf_groups(counts, 10))
    assert groups[0][0] == 0 and groups[-1][1] == len(counts)
    assert all(a[1] == b[0] for a, b in zip(groups, groups[1:]))
    assert all(counts[lo:hi].sum() <= 10 or hi - lo == 1 for lo, hi in groups)
    assert list(cones.leaf_groups(np.zeros(0, np.int64), 10)) == []


def test_a_stage_that_needs_an_in_memory_world_says_so_on_a_mapped_one(streamed):
    with pytest.raises(ValueError, match="'occlusion_thesis' needs an in-memory World"):
        Culler(map_partition(streamed), "vfc,occlusion_thesis")

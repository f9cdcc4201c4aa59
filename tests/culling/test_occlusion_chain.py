"""occlusion_chain: the chained frame computes its camera's planes and view in the compiled
call (view_planes, chain_view); they must be the Python path's bit for bit, or the chained
and the stage-by-stage frames could decide differently (test_occlusion compares their sends)."""
import numpy as np

from vismobile.culling import Culler
from vismobile.culling.backface import half_tangents
from vismobile.culling.occlusion_chain import chain_tables, chain_view, warm_caches
from vismobile.culling.precision import ConservativeCamera, conservative_planes, culling_planes
from vismobile.world.camera import Camera


def random_cameras(rng, count, offset=0.0):
    for _ in range(count):
        yield Camera(position=tuple(rng.normal(size=3) * 10 ** rng.uniform(-2, 3) + offset),
                     yaw=float(rng.uniform(-360, 360)), pitch=float(rng.uniform(-89, 89)),
                     fov=float(rng.uniform(20, 100)), aspect=float(rng.uniform(0.5, 2)),
                     near=float(10 ** rng.uniform(-4, 0)), far=1000.0)


def old_planes(camera):
    """Camera.frustum_planes before view_planes: numpy rows and one matrix product."""
    right, up, forward = (np.array(v) for v in camera.axes())
    ch, sh, cv, sv = camera.half_angles()
    rows = np.array([ch * right + sh * forward, -ch * right + sh * forward,
                     cv * up + sv * forward, -cv * up + sv * forward, forward, -forward])
    rows /= np.linalg.norm(rows, axis=1)[:, None]
    d = -rows @ camera.eye
    d[4] -= camera.near
    d[5] += camera.far
    return np.column_stack([rows, d])


def test_the_culler_planes_are_the_cameras_pushed_out_bit_for_bit():
    rng = np.random.default_rng(7)
    pushed = 0
    for i, camera in enumerate(random_cameras(rng, 300, offset=(0.0, 3e4)[rng.integers(2)])):
        planes = camera.frustum_planes()
        old = old_planes(camera)
        assert np.allclose(planes[:, :3], old[:, :3], rtol=0, atol=1e-15)
        bound = 4 * np.spacing(np.abs(camera.eye).sum() + np.abs(old[:, 3]))
        assert (np.abs(planes[:, 3] - old[:, 3]) <= bound).all()
        for mode in ("float64", "float32", "fixed16.16"):
            scale = max(10.0 ** (i % 6), *map(abs, camera.position))
            mine = culling_planes(camera, mode, scale)
            assert np.array_equal(mine, conservative_planes(camera.frustum_planes(), mode, scale))
            pushed += (mine[:, 3] == 1.0).sum()  # fixed16.16 cannot hold the offset: inside
        wide = ConservativeCamera(**{k: getattr(camera, k) for k in (
            "position", "yaw", "pitch", "fov", "aspect", "near", "far")}, margin=0.5)
        assert np.array_equal(culling_planes(wide, "float32", 1.0),
                              conservative_planes(wide.frustum_planes(), "float32", 1.0))
    assert pushed > 0  # the always-inside replacement was exercised


def test_the_compiled_view_is_the_stages_bit_for_bit(kit):
    part = kit.structure("w1", "octree")
    rng = np.random.default_rng(11)
    for mode, options in (("float32", {"screen": (240, 320)}),
                          ("fixed16.16", {}),
                          ("float64", {"screen": (240, 320), "samples": True})):
        culler = Culler(part, "vfc,occlusion,tbfc", mode, occlusion=options)
        stage, tbfc = culler._chained
        tables = chain_tables(stage, tbfc)[0]
        unordered = 0
        for camera in random_cameras(rng, 60, offset=(0.0, 1e5)[rng.integers(2)]):
            tx, ty = half_tangents(camera.fov, camera.aspect)
            eye, rot, move, clip, scale, order = chain_view(
                tables, *camera.position, float(camera.yaw), float(camera.pitch),
                float(camera.near), tx, ty)
            view = stage._view(camera)
            assert np.array_equal(eye, view[0]) and np.array_equal(rot, view[1])
            assert (tx, ty) == view[2:4]
            assert (move, clip, scale) == view[4:7], mode
            assert order == view[7] or (order == np.inf and view[7] == np.inf)
            unordered += order == np.inf
        assert mode != "float32" or unordered  # near 1e-4 at 1e5 in float32: no order


def test_the_cache_hints_take_any_ids_and_change_no_send(kit):
    # warm_caches only prefetches: ids out of range (a caller may reuse its result's arrays)
    # must be skipped or harmless, and a frame sends the same with and without the hints.
    part = kit.structure("w2", "octree")
    culler = Culler(part, "vfc,occlusion,tbfc", "float32", occlusion={"screen": (240, 320)})
    stage, tbfc = culler._chained
    tables = chain_tables(stage, tbfc)[0]
    wild = np.array([-7, 0, part.node_count - 1, part.node_count, 10 ** 12], dtype=np.int64)
    warm_caches(tables, wild, wild, np.array([-3, 0, part.world.triangle_count, 10 ** 12],
                                            dtype=np.int64))
    cold = Culler(part, "vfc,occlusion,tbfc", "float32", occlusion={"screen": (240, 320)})
    empty = (np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64))
    lo, hi = part.world.extent
    used = 0
    for k in range(8):
        camera = Camera(position=tuple(lo + (hi - lo) * (0.2 + 0.08 * k)), yaw=40.0 * k)
        cold.stages[1]._warm = empty
        one, two = culler.cull(camera), cold.cull(camera)
        assert np.array_equal(one.triangles, two.triangles) and one.stats == two.stats
        used += stage._warm[0] is one.nodes  # the chained frame ran and keeps its hints
    assert used >= 2

"""ROAM (seed 003): crack-free bintree meshes, the pixel bound, coherence, budget, geomorph."""
import numpy as np
import pytest

from vismobile.study.terrain import vertex_errors
from vismobile.terrain.heightmap import Heightmap
from vismobile.terrain.raster import triangle_heights
from vismobile.terrain.roam import Roam, full_mesh, wedgies

from .conftest import overview_cameras

RESOLUTION = (240, 320)


def _check_mesh(triangles, n):
    """A closed, crack-free cover of the square: CCW from +y, area (n-1)^2, every interior
    edge used once each way, and no vertex strictly inside another triangle's edge."""
    rc = np.stack(np.divmod(triangles, n), -1).astype(np.int64)
    cross = (rc[:, 1, 0] - rc[:, 0, 0]) * (rc[:, 2, 1] - rc[:, 0, 1]) - \
        (rc[:, 1, 1] - rc[:, 0, 1]) * (rc[:, 2, 0] - rc[:, 0, 0])
    assert (cross > 0).all()
    assert cross.sum() == 2 * (n - 1) ** 2
    edges = np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [2, 0]]])
    keys, counts = np.unique(edges, axis=0, return_counts=True)
    assert (counts == 1).all()
    present = set(map(tuple, keys.tolist()))
    for a, b in keys.tolist():
        ra, ca = divmod(a, n)
        rb, cb = divmod(b, n)
        border = (ra == rb and ra in (0, n - 1)) or (ca == cb and ca in (0, n - 1))
        assert border or (b, a) in present, (a, b)
    # T-junctions: lattice points strictly inside an edge are not mesh vertices.
    used = np.zeros(n * n, bool)
    used[triangles.ravel()] = True
    a, b = np.divmod(keys[:, 0], n), np.divmod(keys[:, 1], n)
    dr, dc = b[0] - a[0], b[1] - a[1]
    steps = np.gcd(np.abs(dr), np.abs(dc))
    for k in range(1, int(steps.max())):
        inner = steps > k
        r = a[0][inner] + dr[inner] // steps[inner] * k
        c = a[1][inner] + dc[inner] // steps[inner] * k
        assert not used[r * n + c].any()


def test_wedgies_are_nested_and_zero_on_a_plane():
    i, j = np.mgrid[0:33, 0:33]
    assert (wedgies(Heightmap((3 * i + 5 * j).astype(np.uint16)).heights.astype(float), 5)
            == 0).all()
    bump = np.zeros((33, 33), np.uint16)
    bump[9, 14] = 100
    e = wedgies(Heightmap(bump).heights.astype(float), 5).reshape(33, 33)
    assert e[16, 16] == 100  # the root diamond's wedgie holds the bump
    assert e[9, 14] == 100 and e[1::2, 1::2].max() <= 100


def test_full_mesh_is_the_four_eight_surface(fractal129):
    t = full_mesh(fractal129)
    _check_mesh(t, fractal129.size)
    drawn = triangle_heights(fractal129.heights.astype(float), t)
    assert np.allclose(drawn, fractal129.heights)
    r = Roam(fractal129)
    frame = r.update(overview_cameras(fractal129)[0], RESOLUTION, 1e-9, cull=False)
    # Only diamonds of zero error stay unsplit: the surface is the full one.
    assert 0.99 * len(t) < len(frame.triangles) <= len(t)
    assert np.allclose(triangle_heights(fractal129.heights.astype(float), frame.triangles),
                       fractal129.heights)


@pytest.mark.parametrize("tau", [0.5, 2.0, 8.0])
def test_meshes_are_crack_free_along_a_path(fractal129, tau):
    """Every frame of a coherent run (splits, forced splits and merges) is a closed cover
    without T-junctions, and level transitions do occur."""
    r = Roam(fractal129)
    forced = merges = 0
    for camera in overview_cameras(fractal129) * 2:
        frame = r.update(camera, RESOLUTION, tau, cull=False)
        _check_mesh(frame.triangles, fractal129.size)
        assert frame.leaves == len(frame.triangles)
        forced += frame.forced
        merges += frame.merges
    assert forced > 0 and merges > 0


@pytest.mark.parametrize("tau", [0.5, 1.0, 2.0, 6.0])
@pytest.mark.parametrize("view", range(4))
def test_screen_error_never_exceeds_the_knob(pyramid257, tau, view):
    """The exact projected vertical gap at every full-resolution sample in the frustum stays
    within tau pixels (and within the frame's reported bound), with frustum culling on."""
    hm = pyramid257.heightmap
    r = Roam(hm)
    cameras = overview_cameras(hm)
    r.update(cameras[(view + 1) % 4], RESOLUTION, tau)  # arrive from another view
    camera = cameras[view]
    frame = r.update(camera, RESOLUTION, tau)
    drawn = triangle_heights(hm.heights.astype(np.float64), frame.triangles)
    errors = vertex_errors(hm, drawn, camera, RESOLUTION)
    assert len(errors) > 1000
    assert errors.max() <= tau
    assert frame.bound_px <= tau


def test_coherent_frames_match_a_fresh_refinement_and_are_deterministic(fractal257):
    """Two coherent runs agree frame by frame, and (on these views; priorities are not
    monotone, so it is not guaranteed) with a fresh refinement from the two roots."""
    cameras = overview_cameras(fractal257)
    a, b = Roam(fractal257), Roam(fractal257)
    for camera in cameras + cameras[::-1]:
        fa, fb = a.update(camera, RESOLUTION, 1.0), b.update(camera, RESOLUTION, 1.0)
        assert np.array_equal(fa.triangles, fb.triangles)
        fresh = Roam(fractal257).update(camera, RESOLUTION, 1.0)
        assert np.array_equal(np.unique(np.sort(fa.triangles, 1), axis=0),
                              np.unique(np.sort(fresh.triangles, 1), axis=0))
    counts = [len(Roam(fractal257).update(cameras[0], RESOLUTION, tau).triangles)
              for tau in (0.5, 2.0, 8.0)]
    assert counts[0] > counts[1] > counts[2] > 0


def test_merges_happen_when_the_camera_moves_away(fractal257):
    r = Roam(fractal257)
    near = overview_cameras(fractal257)[0]
    first = r.update(near, RESOLUTION, 1.0)
    away = near.with_(position=np.add(near.position, (0.0, 3.0 * fractal257.extent,
                                                      2.0 * fractal257.extent)))
    moved = r.update(away, RESOLUTION, 1.0)
    assert moved.merges > 0 and moved.leaves < first.leaves
    assert moved.splits < moved.merges


@pytest.mark.parametrize("budget", [300, 2000, 6000])
def test_budget_mode_respects_the_budget(fractal257, budget):
    r = Roam(fractal257)
    free = Roam(fractal257)
    for camera in overview_cameras(fractal257):
        frame = r.update(camera, RESOLUTION, 0.05, budget=budget)
        assert frame.leaves <= budget and len(frame.triangles) <= budget
        unlimited = free.update(camera, RESOLUTION, 0.05)
        if unlimited.leaves > budget:
            assert frame.budget_hit and frame.leaves > 0.8 * budget
            assert frame.bound_px >= unlimited.bound_px


def test_geomorph_moves_new_vertices_over_frames(fractal257):
    r = Roam(fractal257, geomorph=4)
    camera = overview_cameras(fractal257)[0]
    first = r.update(camera, RESOLUTION, 1.0)
    ids, heights = first.morph
    assert len(ids) == first.splits > 0
    truth = fractal257.heights.ravel()[ids]
    assert not np.allclose(heights, truth)
    for _ in range(4):
        later = r.update(camera, RESOLUTION, 1.0)
    assert len(later.morph[0]) == 0  # arrived
    assert np.array_equal(later.triangles, first.triangles)


def test_measured_against_its_full_render_with_and_without_geomorph(fractal257):
    """Through the study's measure: 0.5 px keeps PSNR >= 40 dB and the pixel-height error
    near the knob; a geomorphing run draws its morphed heights (its first frame differs from
    the popping run's image, and the exact error may exceed tau while vertices rise)."""
    from vismobile.device.profile import get_profile
    from vismobile.study.terrain import RoamMethod, measure

    profile = get_profile("ipaq-hx2490b")
    camera = overview_cameras(fractal257)[0].with_(aspect=profile.aspect)
    low, high = measure([RoamMethod(Roam(fractal257))], fractal257, [camera], [0.5, 8.0],
                        profile, exact_vertices=True)
    assert low["psnr"] >= 40 and low["pixel_height_max"] <= 0.5 + 0.25
    assert low["vertex_error_max"] <= 0.5 and high["vertex_error_max"] <= 8.0
    assert high["triangles"] < low["triangles"] <= low["full_triangles"]
    morphing = measure([RoamMethod(Roam(fractal257, geomorph=8))], fractal257, [camera], [0.5],
                       profile, exact_vertices=True)[0]
    assert morphing["triangles"] == low["triangles"]
    assert morphing["psnr"] < low["psnr"] and morphing["vertex_error_max"] > 0.5


def test_culled_mesh_covers_the_frustum(pyramid257):
    """Frustum culling (IN / OUT / PARTIAL diamonds) drops only triangles outside the view:
    every sample inside the frustum is drawn, and fewer triangles go out than with culling
    off."""
    from vismobile.geometry.planes import points_inside

    hm = pyramid257.heightmap
    i, j = np.mgrid[0:hm.size, 0:hm.size]
    points = np.stack([j * hm.spacing, hm.heights, i * hm.spacing], -1).reshape(-1, 3)
    for camera in overview_cameras(hm):
        r, everything = Roam(hm), Roam(hm)
        frame = r.update(camera, RESOLUTION, 2.0)
        drawn = np.isfinite(triangle_heights(hm.heights.astype(float), frame.triangles))
        inside = points_inside(points, camera.frustum_planes()).reshape(i.shape)
        assert drawn[inside].all()
        uncut = everything.update(camera, RESOLUTION, 2.0, cull=False)
        assert len(frame.triangles) < len(uncut.triangles)


def test_deferred_priorities_change_nothing_but_the_work(fractal257):
    """Along consecutive frames of a slow path, candidates the eye's travel cannot have
    brought above tau are not re-scored; the meshes are the ones full re-scoring gives, and
    every frame keeps the exact error within tau."""
    from vismobile.terrain.paths import path_cameras

    lazy = Roam(fractal257, incremental=False)  # the walking ROAM's deferral
    eager = Roam(fractal257, incremental=False, defer=False)
    deferred = 0
    for camera in path_cameras(fractal257, "circle", "slow", frames=12, every=3):
        a, b = lazy.update(camera, RESOLUTION, 1.0), eager.update(camera, RESOLUTION, 1.0)
        assert np.array_equal(a.triangles, b.triangles) and b.deferred == 0
        deferred += a.deferred
        drawn = triangle_heights(fractal257.heights.astype(np.float64), a.triangles)
        assert vertex_errors(fractal257, drawn, camera, RESOLUTION).max() <= 1.0
        assert a.bound_px <= 1.0
    assert deferred > 1000


def test_merges_morph_down_within_tau_before_they_happen(fractal257):
    """With geomorphing, a diamond due to merge first lowers its vertex to its hypotenuse
    midpoint over the morph frames (monotonically), and merges after; while only such
    descents are in flight every sample in the frustum stays within tau (rising vertices of
    splits may exceed it, as before). Without geomorphing the same move merges at once (with
    it, only the diamonds outside the frustum do)."""
    from vismobile.study.terrain import RoamMethod

    near = overview_cameras(fractal257)[0]
    away = near.with_(position=np.add(near.position, (0.0, 0.3 * fractal257.extent, 0.0)))
    popping = Roam(fractal257)
    popping.update(near, RESOLUTION, 1.0)
    at_once = popping.update(away, RESOLUTION, 1.0).merges
    assert at_once > 0
    roam = Roam(fractal257, geomorph=3)
    method = RoamMethod(roam)
    for _ in range(4):  # let the split morphs end
        roam.update(near, RESOLUTION, 1.0)
    heights, merged, checked = {}, 0, 0
    for step in range(8):
        frame = roam.update(away, RESOLUTION, 1.0)
        merged += frame.merges
        if step == 0:
            # only diamonds out of view merge at once (nobody sees them pop)
            assert frame.merges < at_once / 2 and len(frame.morph[0]) > frame.splits
        descending = np.setdiff1d(frame.morph[0], roam.morph_ids)
        truth = fractal257.heights.ravel()
        for v, h in zip(*frame.morph):
            if v in heights and v in descending:  # moving away from its height, step by step
                assert abs(h - truth[v]) >= abs(heights[v] - truth[v]) - 1e-9
            heights[v] = h
        if len(descending) and not len(roam.morph_ids):
            errors = vertex_errors(fractal257, method.heights(frame), away, RESOLUTION)
            assert errors.max() <= 1.0
            checked += 1
    assert merged > 0 and checked >= 2

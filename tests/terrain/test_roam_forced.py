"""Samec's forced merge in ROAM (seed 003, Fig. 22): a diamond merges although its children
are split, its split descendants first; the mesh stays crack-free and within tau, and with
geomorphing the whole set moves from the fine to the coarse surface before it merges."""
import numpy as np

from vismobile.study.terrain import RoamMethod, vertex_errors
from vismobile.study.terrain_check import rasterise, reference, screen_errors
from vismobile.terrain.paths import path_cameras
from vismobile.terrain.raster import triangle_heights
from vismobile.terrain.roam import Roam

from .conftest import overview_cameras
from .test_roam import RESOLUTION, _check_mesh


def _receding(hm, frames):
    """Low over the map, then rising and backing away, so that much of the mesh merges."""
    near = overview_cameras(hm)[0]
    return [near.with_(position=np.add(near.position, (0.0, 0.06 * k * hm.extent,
                                                         0.04 * k * hm.extent)))
            for k in range(frames)]


def test_forced_merges_keep_the_mesh_within_tau_and_crack_free(fractal257):
    """Along a receding camera and a fast circle, the default ROAM and the incremental one that
    never walks (forced merges happen in incremental frames) force-merge sets of diamonds; every frame is within tau on the dense lattice (4x finer than
    the samples), and the whole mesh (cull off) is a crack-free cover after each frame."""
    truth = reference(fractal257, 4, alternating=True)
    cameras = _receding(fractal257, 6) + path_cameras(fractal257, "circle", "fast", frames=4,
                                                      every=30)
    for kwargs in ({}, {"walk_above": np.inf}):
        roam, whole = Roam(fractal257, **kwargs), Roam(fractal257, **kwargs)
        ops = merged = 0
        for camera in cameras:
            frame = roam.update(camera, RESOLUTION, 1.0)
            errors = screen_errors(fractal257, rasterise(fractal257, frame.triangles, 4), truth,
                                   camera, RESOLUTION, 4)
            assert len(errors) > 1000 and errors.max() <= 1.0 and frame.bound_px <= 1.0
            uncut = whole.update(camera, RESOLUTION, 1.0, cull=False)
            _check_mesh(uncut.triangles, fractal257.size)
            ops += frame.forced_merges + uncut.forced_merges
            merged += frame.forced_merged + uncut.forced_merged
            assert frame.forced_merged <= frame.merges
        assert ops > 10 and merged > 2 * ops  # sets of several diamonds, not lone merges


def test_a_jump_away_coarsens_in_forced_merges_to_a_fresh_refinement(fractal257):
    """After a close view, one frame from far away merges the region, partly in forced merges
    (a set holds the diamond and at least one split child), and ends with the mesh a fresh
    refinement of the far view gives."""
    near, far = _receding(fractal257, 12)[0], _receding(fractal257, 12)[-1]
    roam = Roam(fractal257, walk_above=np.inf)
    for _ in range(2):
        before = roam.update(near, RESOLUTION, 0.5, cull=False)
    frame = roam.update(far, RESOLUTION, 0.5, cull=False)
    fresh = Roam(fractal257, incremental=False).update(far, RESOLUTION, 0.5, cull=False)
    assert frame.forced_merges > 0 and frame.forced_merged >= 2 * frame.forced_merges
    assert len(before.triangles) > 1.5 * len(frame.triangles)
    assert np.array_equal(np.sort(np.sort(frame.triangles, 1), 0),
                          np.sort(np.sort(fresh.triangles, 1), 0))


def test_forced_merges_morph_from_the_fine_to_the_coarse_surface(fractal257):
    """With geomorphing (3 frames), every vertex due to merge, alone or in a forced merge's
    set, is drawn at h + t (s - h) with t = 1/4, 2/4, 3/4 on consecutive frames, s the height
    of the coarse surface at that sample once it has merged: its position moves continuously
    from the fine surface to the coarse one. While only such descents are in flight, every
    sample in the frustum stays within tau."""
    k = 3
    cameras = _receding(fractal257, 6)
    roam = Roam(fractal257, geomorph=k, walk_above=np.inf)
    method = RoamMethod(roam)
    for _ in range(k + 1):  # let the split morphs end
        roam.update(cameras[0], RESOLUTION, 1.0, cull=False)
    truth = fractal257.heights.ravel().astype(np.float64)
    drawn = {}  # vertex -> heights drawn on consecutive frames while descending
    checked_vertices = checked_views = forced = 0
    for camera in cameras[1:]:
        for _ in range(k + 2):
            frame = roam.update(camera, RESOLUTION, 1.0, cull=False)
            forced += frame.forced_merged - frame.forced_merges
            descending = set(np.setdiff1d(frame.morph[0], roam.morph_ids).tolist())
            surface = triangle_heights(fractal257.heights.astype(np.float64),
                                       frame.triangles).ravel()
            for v in list(drawn):
                if v in descending:
                    continue
                heights = drawn.pop(v)
                if roam.split[v]:
                    continue  # stopped descending (its priority rose, or a child split)
                s, h = surface[v], truth[v]
                assert len(heights) == k, (v, heights)
                expected = h + np.arange(1, k + 1) / (k + 1) * (s - h)
                assert np.allclose(heights, expected, atol=1e-9), (v, heights, expected)
                checked_vertices += 1
            for v, z in zip(*frame.morph):
                if v in descending:
                    drawn.setdefault(v, []).append(z)
            if descending and not len(roam.morph_ids):
                errors = vertex_errors(fractal257, method.heights(frame), camera, RESOLUTION)
                assert errors.max() <= 1.0
                checked_views += 1
    assert forced > 0  # forced merges of several diamonds morphed too
    assert checked_vertices > 50 and checked_views >= 2


def test_a_forced_merge_waits_while_a_descendant_is_above_tau(fractal129):
    """Jumping between random views, some forced merges are refused because a split
    descendant still scores above tau (its box reaches into its other parent's half, so it
    can outrank this parent); refused, they leave the mesh as it is: a second frame from the
    same camera splits and merges nothing (a forced merge that ignored the descendant would
    merge it and the split phase would split it again, every frame), and each frame stays
    within tau."""
    from vismobile.world.camera import Camera

    rng = np.random.default_rng(4)
    w = fractal129.extent
    top = float(fractal129.heights.max())
    roam = Roam(fractal129, walk_above=np.inf)
    refused = views = 0
    for _ in range(40):
        x, z = rng.uniform(-0.2, 1.2, 2) * w
        camera = Camera((x, top * rng.uniform(0, 1.5) + rng.uniform(0.1, 5), z),
                        yaw=float(rng.uniform(0, 360)), pitch=float(rng.uniform(-60, 10)),
                        fov=60, near=0.05, far=4 * w)
        tau = float(rng.choice([0.5, 1.0, 2.0]))
        first = roam.update(camera, RESOLUTION, tau)
        again = roam.update(camera, RESOLUTION, tau)
        refused += first.forced_refused
        assert again.splits == 0 and again.merges == 0
        assert again.bound_px <= tau
        drawn = triangle_heights(fractal129.heights.astype(np.float64), again.triangles)
        errors = vertex_errors(fractal129, drawn, camera, RESOLUTION)
        assert errors.size == 0 or errors.max() <= tau  # (some views miss the map)
        views += errors.size > 0
    assert refused > 0 and views > 20


def test_descents_of_forced_merges_stay_within_tau_between_random_views(fractal129):
    """With geomorphing, a view held for a few frames after a jump lets forced merges' sets
    descend; on every frame where only descents are in flight (no vertex rising), every sample
    in the frustum is within tau: a set with a member above tau never starts descending."""
    from vismobile.world.camera import Camera

    rng = np.random.default_rng(7)
    w = fractal129.extent
    top = float(fractal129.heights.max())
    roam = Roam(fractal129, geomorph=2, walk_above=np.inf)
    method = RoamMethod(roam)
    checked = forced = 0
    for _ in range(25):
        x, z = rng.uniform(0.0, 1.0, 2) * w
        camera = Camera((x, top * rng.uniform(0.2, 1.2) + 1.0, z),
                        yaw=float(rng.uniform(0, 360)), pitch=float(rng.uniform(-50, 0)),
                        fov=60, near=0.05, far=4 * w)
        for _ in range(5):
            frame = roam.update(camera, RESOLUTION, 1.0)
            forced += frame.forced_merged
            descending = np.setdiff1d(frame.morph[0], roam.morph_ids)
            if len(descending) and not len(roam.morph_ids):
                errors = vertex_errors(fractal129, method.heights(frame), camera, RESOLUTION)
                assert errors.size == 0 or errors.max() <= 1.0
                checked += errors.size > 0
    assert forced > 0 and checked >= 5

"""The independent dense check (issue 30): its rasteriser and projection, on cases with known
answers."""
import numpy as np

from vismobile.world.camera import Camera
from vismobile.study.terrain_check import (rasterise, reference, screen_errors, screen_points,
                                            takagi)
from vismobile.terrain.heightmap import Heightmap


def test_a_plane_drawn_by_two_triangles_is_exact_between_samples():
    i, j = np.mgrid[0:9, 0:9]
    hm = Heightmap((10 * i + 3 * j).astype(np.uint16))
    n = hm.size
    two = np.array([[0, 8 * n + 8, 8], [0, 8 * n, 8 * n + 8]])  # the whole square, two triangles
    drawn = rasterise(hm, two, fine=4)
    assert np.isfinite(drawn).all()
    assert np.allclose(drawn, reference(hm, 4))


def test_a_bump_skipped_by_a_coarse_triangle_is_found_between_samples():
    """One raised sample under a coarse triangle: the gap is the bump at the sample and a
    linear ramp between, exactly as the reference has it."""
    h = np.zeros((5, 5), np.uint16)
    h[2, 2] = 8
    hm = Heightmap(h)
    n = hm.size
    coarse = np.array([[0, 4 * n + 4, 4], [0, 4 * n, 4 * n + 4]])
    gap = np.abs(rasterise(hm, coarse, fine=4) - reference(hm, 4))
    assert gap.max() == 8 and gap[8, 8] == 8
    assert np.isclose(gap[8, 6], 4) and np.isclose(gap[6, 8], 4)  # halfway to a zero sample


def test_projection_puts_the_axis_at_the_centre_and_a_known_gap_in_pixels():
    camera = Camera((0.0, 0.0, 0.0), yaw=0, pitch=0, fov=90, aspect=1.0, near=0.1, far=100)
    p, depth = screen_points(np.array([[0.0, 0.0, -10.0], [0.0, 1.0, -10.0]]), camera, (200, 200))
    assert np.allclose(p[0], (100, 100)) and np.allclose(depth, 10)
    assert np.isclose(p[0, 1] - p[1, 1], 10.0)  # 1 unit at 10 units, 100 px per unit at 1


def test_points_behind_the_near_plane_or_off_screen_do_not_count():
    h = np.zeros((5, 5), np.uint16)
    hm = Heightmap(h)
    drawn = reference(hm, 1) + 1.0
    ahead = Camera((2.0, 1.0, 10.0), yaw=0, pitch=-20, fov=60, near=0.1, far=100)
    assert len(screen_errors(hm, drawn, reference(hm, 1), ahead, (240, 320), fine=1))
    away = ahead.with_(yaw=180)
    assert not len(screen_errors(hm, drawn, reference(hm, 1), away, (240, 320), fine=1))


def test_takagi_map_adds_every_octave():
    hm = takagi(65)
    assert hm.size == 65 and np.ptp(hm.heights) > 0
    row = hm.heights[0].astype(np.float64)
    # Self-similar: the one-level change at the quarter points equals half the one at the
    # half point, octave after octave (within the 16-bit quantization).
    mid = row[32] - (row[0] + row[64]) / 2
    quarter = row[16] - (row[0] + row[32]) / 2
    assert np.isclose(quarter, mid / 2, rtol=0.02)

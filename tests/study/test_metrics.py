"""False negatives, false-negative pixels, tightness and the Pareto front."""
import numpy as np

from vismobile.render import item_buffer
from vismobile.study.metrics import (SENTINEL, VisibleSet, buffer_difference, frame_errors,
                                     pareto_front)


def test_visible_set_counts_pixels_and_skips_background():
    buffer = np.array([[3, 3, SENTINEL], [1, SENTINEL, 3]], dtype=np.uint32)
    seen = VisibleSet.from_buffer(buffer)
    assert seen.ids.tolist() == [1, 3]
    assert seen.pixels.tolist() == [1, 3]
    assert seen.total == 6


def test_frame_errors_literal():
    seen = VisibleSet(np.array([1, 3, 5]), np.array([10, 20, 30]), 100)
    errors = frame_errors(seen, np.array([0, 1, 5, 9]))
    assert errors == {"false_negatives": 1, "fn_pixels": 20, "visible": 3, "tightness": 4 / 3}


def test_frame_errors_empty_view():
    seen = VisibleSet(np.zeros(0, np.int64), np.zeros(0, np.int64), 100)
    assert frame_errors(seen, np.zeros(0, np.int64))["tightness"] == 0.0
    assert frame_errors(seen, np.array([2]))["tightness"] == float("inf")


def test_fn_pixels_equal_a_real_culled_render(world, trajectory, profile):
    """The no-second-render shortcut matches rendering the culled set and diffing buffers."""
    rng = np.random.default_rng(3)
    for frame in (1, 4, 6):
        camera = trajectory.camera(frame, profile.aspect)
        full = item_buffer(world, None, camera, profile)
        seen = VisibleSet.from_buffer(full)
        sent = np.sort(rng.choice(world.triangle_count, world.triangle_count // 2, replace=False))
        culled = item_buffer(world, sent, camera, profile)
        errors = frame_errors(seen, sent)
        assert errors["fn_pixels"] == buffer_difference(full, culled)
        assert errors["false_negatives"] > 0


def test_pareto_front_literal():
    cost = np.array([1.0, 2.0, 3.0, 2.5, 1.0])
    error = np.array([5.0, 0.0, 0.0, 3.0, 5.0])
    assert pareto_front(cost, error).tolist() == [True, True, False, False, True]


def test_pareto_front_empty():
    assert pareto_front(np.zeros(0), np.zeros(0)).tolist() == []

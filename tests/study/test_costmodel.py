"""Non-negative least squares, the fitted cost model and the device model."""
import numpy as np
import pytest

from vismobile.world.camera import Camera
from vismobile.culling import Culler
from vismobile.partition import partition
from vismobile.device.profile import get_profile
from vismobile.study.costmodel import (CALIBRATION_ROWS, CostModel, DeviceModel, best_device_fit,
                                       cull_cycles, device_counters, fit_device, nnls)
from vismobile.study.thesis import DEVICE_POINTS


def test_nnls_recovers_non_negative_coefficients():
    rng = np.random.default_rng(0)
    a = rng.uniform(0, 1, (50, 3))
    x = np.array([2.0, 0.0, 0.5])
    assert np.allclose(nnls(a, a @ x), x, atol=1e-9)


def test_nnls_clips_a_negative_truth_to_zero():
    a = np.column_stack([np.ones(20), np.arange(20.0)])
    solution = nnls(a, 5.0 - 0.1 * np.arange(20.0))
    assert solution[1] == 0.0 and solution[0] > 0


def test_nnls_all_zero_target():
    assert np.array_equal(nnls(np.eye(3), np.zeros(3)), np.zeros(3))


def test_cost_model_fits_render_per_triangle_and_back_face_apart():
    rows = [{"triangles_sent": n, "draw_batches": 1, "cull_back": back}
            for n in (0, 1000, 5000, 20000) for back in (False, True)]
    ms = [0.5 + (2e-4 if not r["cull_back"] else 1e-4) * r["triangles_sent"] for r in rows]
    cull_rows = [{"nodes_visited": n, "plane_tests": 2 * n, "triangles_tested": 0}
                 for n in (10, 100, 1000)]
    model = CostModel.fit(cull_rows, [0.1 + 1e-3 * r["nodes_visited"] for r in cull_rows],
                          rows, ms)
    assert np.isclose(model.render_ms({"triangles_sent": 10000, "draw_batches": 1}), 2.5)
    assert np.isclose(model.render_ms({"triangles_sent": 10000, "draw_batches": 1}, True), 1.5)
    assert np.isclose(model.render_saving_ms(1000), 0.2)
    assert np.isclose(model.cull_ms({"nodes_visited": 500, "plane_tests": 1000}), 0.6)


# ---- the device model ---------------------------------------------------------------------


def test_cull_cycles_price_float_operations_at_the_device_rate():
    # One plane test: 7 float operations and 10 integer cycles.
    assert cull_cycles({"plane_tests": 1}, 50.0) == 360.0
    assert cull_cycles({"plane_tests": 1}, 4.0) == 38.0
    assert cull_cycles({}, 50.0) == 0.0
    assert cull_cycles({"nodes_visited": 10, "unknown": 5}, 50.0) == 600.0


def test_device_model_prices_counters_on_the_ipaq():
    model = DeviceModel(get_profile("ipaq-hx2490b"))
    c = model.cost
    stats = {"triangles_sent": 1000, "nodes_drawn": 10, "plane_tests": 520}
    expected_render = c.render_base_ms + c.render_triangle_us + 10 * c.render_call_us * 1e-3
    assert np.isclose(model.render_ms(stats), expected_render)
    assert model.render_ms(stats, True) == model.render_ms(stats)  # GL_CULL_FACE neutral
    assert np.isclose(model.cull_ms(stats), 520 * 360 / 520e3)
    assert np.isclose(model.render_saving_ms(1000, 10), expected_render - c.render_base_ms)
    assert "us per triangle" in model.describe() and model.to_dict()["clock_mhz"] == 520.0


def test_the_desktop_has_no_device_model():
    with pytest.raises(ValueError, match="desktop"):
        DeviceModel(get_profile("desktop"))


def test_fit_device_recovers_render_figures_and_takes_off_cull_time():
    rng = np.random.default_rng(3)
    rows = [{"triangles_sent": t, "nodes_drawn": n, "plane_tests": p}
            for t, n, p in zip(rng.uniform(500, 12000, 8), rng.uniform(1, 900, 8),
                               rng.uniform(0, 3000, 8))]
    cull = np.array([cull_cycles(r, 50.0) for r in rows]) / 520e3
    target = [90 + 0.02 * r["triangles_sent"] + 0.15 * r["nodes_drawn"] + ms
              for r, ms in zip(rows, cull)]
    fit = fit_device(rows, target, 50.0, 520.0, "nodes_drawn")
    assert np.isclose(fit["base_ms"], 90) and np.isclose(fit["triangle_us"], 20)
    assert np.isclose(fit["call_us"], 150) and fit["loo_error"] < 1e-9
    chosen, fits = best_device_fit(rows, target, 50.0, 520.0)
    assert chosen["call_counter"] == "nodes_drawn" and len(fits) == 4
    alone = fit_device(rows, target, 50.0, 520.0)
    assert alone["call_us"] == 0.0 and alone["loo_error"] > 0.01


@pytest.mark.parametrize("name", ["ipaq-hx2490b", "nokia-n82"])
def test_profile_figures_are_the_fit_of_the_calibration_rows(name):
    cost = get_profile(name).cost
    points = DEVICE_POINTS[name]
    rows = CALIBRATION_ROWS[:len(points)]
    counter = cost.call_counter if cost.render_call_us else None
    fit = fit_device(rows, [p[3] for p in points], cost.float_op_cycles, cost.clock_mhz, counter)
    assert np.isclose(fit["base_ms"], cost.render_base_ms, rtol=2e-3)
    assert np.isclose(fit["triangle_us"], cost.render_triangle_us, rtol=2e-3)
    assert np.isclose(fit["call_us"], cost.render_call_us, rtol=2e-3, atol=1e-9)
    chosen, _ = best_device_fit(rows, [p[3] for p in points], cost.float_op_cycles,
                                cost.clock_mhz)
    assert chosen["call_counter"] == counter  # the kept term is the one held-out error picked


def test_device_counters_of_a_whole_world_draw_gather_nothing(world):
    tree_partition = partition(world, "octree", depth=2)
    whole = device_counters(Culler(tree_partition, "none").cull(_camera()),
                            Culler(tree_partition, "none").tree)
    assert whole["refs_gathered"] == 0 and whole["leaves_drawn"] == 1
    culler = Culler(tree_partition, "vfc")
    result = culler.cull(_camera())
    some = device_counters(result, culler.tree)
    held = culler.tree.ref_end[result.nodes] - culler.tree.ref_start[result.nodes]
    assert some["refs_gathered"] == held.sum() >= some["triangles_sent"]
    assert 0 < some["leaves_drawn"]


def _camera():
    return Camera((-8, 1.6, 3), yaw=-60, pitch=0)

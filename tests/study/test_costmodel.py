"""Non-negative least squares and the fitted cost model."""
import numpy as np

from vismobile.study.costmodel import CostModel, nnls


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

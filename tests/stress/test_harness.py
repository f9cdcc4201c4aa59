"""The stress harness on a sample of cases: real partitions, the Culler and the item buffer.

Proof obligation of issue 7: no crash, no NaN, no false negative once the frustum is inflated
(against the rounded and the float64 truth), and the device's own plane test in each mode never
calls a visible triangle's box outside; or a clear ProfileError where the mode cannot hold it.
"""
import importlib.util
import sys
from pathlib import Path

import pytest

from vismobile.scenes.stress import stress_cases

SPEC = importlib.util.spec_from_file_location(
    "stress_tool", Path(__file__).resolve().parents[2] / "tools" / "stress.py")
stress = importlib.util.module_from_spec(SPEC)
sys.modules["stress_tool"] = stress  # dataclasses look their module up there
SPEC.loader.exec_module(stress)

CASES = {case.name: case for case in stress_cases()}
SAMPLE = ("translate_1e7", "scale_1e4", "zero_area", "single_triangle", "huge_triangle",
          "empty_cell")


@pytest.mark.parametrize("name", SAMPLE)
@pytest.mark.parametrize("mode", ("float64", "float32", "fixed16.16"))
def test_stress_case_is_safe_or_refused(name, mode):
    case = CASES[name]
    case.cameras = [c for c in case.cameras if c[0] in ("room_a", "fov_170", "pitch_-90",
                                                         "far_near_1e7")]
    cell = stress.Cell()
    stress.run_case(case, mode, cell, ["octree", "bsp"], ["vfc", "vfc,cbfc"], repeats=1)
    assert not cell.crashes and not cell.nans
    if cell.runs == 0:
        assert cell.refused  # nothing ran: there must be a clear reason
        return
    assert cell.fn_inflated == 0, cell.fn_examples
    assert cell.fn_device == 0
    assert cell.max_ratio <= 1.0  # the measured plane-test error stays inside the bound


def test_modes_refuse_what_they_cannot_represent():
    expect = {("translate_1e7", "float32"): "cannot resolve",
              ("translate_1e5", "fixed16.16"): "range",
              ("scale_1e4", "fixed16.16"): "range",
              ("scale_1e-4", "fixed16.16"): "cannot resolve"}
    for (name, mode), message in expect.items():
        cell = stress.Cell()
        stress.run_case(CASES[name], mode, cell, ["octree"], ["vfc"], repeats=1)
        assert cell.runs == 0 and message in cell.refused and "ProfileError" not in cell.refused

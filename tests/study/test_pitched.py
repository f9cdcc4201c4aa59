"""The pitched paths in the study: `compare --trajectory pitched` runs the thesis worlds along
the paths that look up and down (and down the ramp), and the report gives what cbfc_thesis
loses of the visible pixels there."""
import json

import numpy as np
import pytest

from vismobile.app.cli import main
from vismobile.study.thesis import TRAJECTORY_VARIANTS, trajectory_for


def test_trajectory_for_names_the_variants():
    assert trajectory_for("w2", "pitched").endswith("indoor_pitched.csv")
    assert trajectory_for("w6", "pitched").endswith("outdoor_pitched.csv")
    assert trajectory_for("w1").endswith("indoor.csv")
    with pytest.raises(ValueError, match="pitched"):
        trajectory_for("w1", "sideways")
    assert set(TRAJECTORY_VARIANTS) == {"pitched"}


def test_compare_pitched_reports_cbfc_thesis_losses(tmp_path):
    out = tmp_path / "out"
    assert main(["compare", "--worlds", "w1", "--structures", "octree:2", "--cull",
                 "vfc+bfc+cbfc_thesis,vfc+bfc+cbfc", "--profiles", "ipaq-hx2490b", "--frames",
                 "stride:40", "--trajectory", "pitched", "-o", str(out), "--cache",
                 str(tmp_path / "cache"), "--jobs", "1", "--quiet", "--agreement", "0"]) == 0
    runs = [json.loads(p.read_text()) for p in (out / "runs").glob("*.json")]
    by_cull = {r["spec"]["cull"]: r for r in runs}
    assert all(r["spec"]["trajectory"].endswith("indoor_pitched.csv") for r in runs)
    lossy = by_cull["vfc+bfc+cbfc_thesis"]["summary"]
    frames = by_cull["vfc+bfc+cbfc_thesis"]["frames"]
    # looking down the ramp, the thesis's 2D rule drops the ramp: visible pixels lost
    assert lossy["fn_visible_fraction"] > 0.005 and lossy["fn_visible_fraction_max"] > 0.1
    assert lossy["fn_visible_fraction"] == pytest.approx(
        np.sum(frames["fn_pixels"]) / np.sum(frames["visible_pixels"]))
    assert by_cull["vfc+bfc+cbfc"]["summary"]["conservative"]
    report = (out / "report.html").read_text()
    assert "Lost visible pixels along indoor_pitched.csv" in report
    assert f"{lossy['fn_visible_fraction']:.1%}" in report

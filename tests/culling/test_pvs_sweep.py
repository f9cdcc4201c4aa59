"""tools/pvs_sweep.py's sampled subset (issue 29 target 1; the full sweep: 2,000 cameras per
world, every path frame): W5 baked on the portal structure (street cells) and on the BSP
tree's leaves, random cameras in its view cells and path frames in float64, float32 and
fixed16.16, 0 dropped."""
import importlib.util
import json
from pathlib import Path

TOOL = Path(__file__).resolve().parents[2] / "tools" / "pvs_sweep.py"


def test_the_sweep_drops_nothing_on_a_sample_of_w5(tmp_path):
    spec = importlib.util.spec_from_file_location("pvs_sweep", TOOL)
    sweep = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(sweep)
    out = tmp_path / "rows.jsonl"
    assert sweep.main(["--worlds", "w5", "--cameras", "16", "--path-stride", "250",
                       "--cache", str(tmp_path / "cache"), "--out", str(out), "--jobs", "2"]) == 0
    rows = [json.loads(line) for line in out.read_text().splitlines()]
    assert [r["structure"] for r in rows] == ["portal:2", "bsp"]
    for row in rows:
        assert row["random"]["checks"] == 3 * 16 and row["path"]["checks"] == 3 * 8
        assert row["random"]["dropped"] == row["path"]["dropped"] == 0
        # every camera inside a cell used its set, but on the street cells (partition/
        # pvs_street.py; both structures take them on W5) for near planes (0.01) nearer than
        # the bake assumed (NEAR_MIN), and on a cell's side facing a building's inside or the
        # world's edge (its near plane may leave the cells)
        others = row["random"]["fallbacks"] - row["random"]["near_fallbacks"]
        assert others <= row["random"]["checks"] // 8
        kinds = row["random"]["kinds"]  # [checks, fell back, dropped] per kind of camera
        assert sum(k[0] for k in kinds.values()) == 3 * 16
        assert {"inside", "face", "edge", "corner", "near face", "near edge",
                "near corner"} <= set(kinds)
        assert kinds["near face"][1] < kinds["near face"][0]  # next to a face, the set is used

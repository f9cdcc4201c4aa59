"""RegionalCuller (culling/regional.py): per portal cell, the cheapest conservative stage set."""
from pathlib import Path

import numpy as np
import pytest

from vismobile.culling import Culler
from vismobile.culling.regional import RegionalCuller
from vismobile.partition import portal
from vismobile.world.trajectory import Trajectory


@pytest.fixture(scope="module")
def w7_static(thesis_world):
    world = thesis_world("w7")
    movers = [i for i, n in enumerate(world.object_names)
              if n.startswith(("door_", "person_", "car_"))]
    return world.subset(np.flatnonzero(~np.isin(world.object_ids, movers)))


def test_each_region_decides_after_its_probes_and_sends_a_choices_result(w7_static):
    part = portal.build(w7_static, depth=2)
    regional = RegionalCuller(part, probes=2)
    fixed = [Culler(part, s) for s in regional.choices]
    path = Trajectory.load(Path(__file__).resolve().parents[2] / "trajectories" / "hybrid.csv")
    seen = {}
    for frame in range(0, len(path), 40):
        camera = path.camera(frame)
        result = regional.cull(camera)
        region = result.stats["regional.region"]
        seen[region] = seen.get(region, 0) + 1
        pick = regional.choices.index(result.stats["active_stages"])
        # each fixed Culler culls the frames its twin in `regional` culled (every choice on a
        # probe frame), so stages with a frame-to-frame state (occlusion's occluder choice)
        # have seen the same frames
        probing = "regional.probe_ms" in result.stats
        results = [c.cull(camera) if probing or k == pick else None
                   for k, c in enumerate(fixed)]
        assert np.array_equal(result.triangles, results[pick].triangles)
        if seen[region] > 2:  # decided: no probing, and the pick is the cheapest on average
            assert "regional.probe_ms" not in result.stats
            prices = np.mean(regional.prices[region], axis=0)
            assert pick == int(np.argmin(prices)) == regional.decisions[region]
    assert any(n > 2 for n in seen.values())
    assert len(set(regional.decisions.values())) == 2  # portals somewhere, occlusion elsewhere


def test_no_choice_is_refused(w7_static):
    part = portal.build(w7_static, depth=1)
    with pytest.raises(ValueError, match="at least one"):
        RegionalCuller(part, choices=())

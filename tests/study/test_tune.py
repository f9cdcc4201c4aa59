"""Automatic configuration on the tiny world."""
from vismobile.study.tune import candidate_culls, tune


def test_candidates_leave_out_loose_stages_and_misplaced_portals():
    culls = candidate_culls("octree:3")
    assert "none" in culls and "vfc+bfc+cbfc" in culls
    assert not any("thesis" in c or "portals" in c for c in culls)
    assert any("portals" in c for c in candidate_culls("portal:1"))


def test_tune_picks_the_cheapest_safe_candidate(world, trajectory, profile):
    result = tune(world, trajectory, profile, probe=4, structures="octree:1-3,bsp")
    assert result.choice.false_negatives == 0
    assert result.choice.frame_ms == min(c.frame_ms for c in result.candidates
                                         if c.false_negatives == 0)
    assert {c.structure for c in result.candidates} >= {"bsp", "octree:2"}
    text = result.report()
    assert "choice: --structure" in text and "cost model" in text
    assert len(result.explanations) >= 5
    assert result.to_dict()["choice"]["structure"] == result.choice.structure

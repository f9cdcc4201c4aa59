"""The selection grammar and the run matrix."""
from pathlib import Path

import pytest

from vismobile.culling import STAGES
from vismobile.study.matrix import (LOOSE_STAGES, OUR_CULLS, STAGE_ORDER, THESIS_CULLS, RunSpec,
                                    SelectionError, canonical_cull, expand, frame_indices,
                                    parse_culls, parse_structures)


def test_structures_expand_depth_ranges():
    assert parse_structures("grid,octree:3-6,portal:1-3,bsp") == [
        "grid", "octree:3", "octree:4", "octree:5", "octree:6",
        "portal:1", "portal:2", "portal:3", "bsp"]


def test_structures_all_is_the_thesis_set():
    assert parse_structures("all") == parse_structures("grid,octree:3-6,portal:1-3,bsp")
    assert parse_structures("bsp,kdtree") == ["bsp", "kdtree"]


@pytest.mark.parametrize("bad", ["octree:0", "portal:4", "octree:5-3", "grid:2", "kd", "bsp:1",
                                 "kdtree:3"])
def test_bad_structures_are_refused(bad):
    with pytest.raises(SelectionError):
        parse_structures(bad)


def test_thesis_has_eight_combinations_and_ours_are_canonical():
    assert len(THESIS_CULLS) == 8
    for cull in THESIS_CULLS + OUR_CULLS:
        assert canonical_cull(cull) == cull


def test_cull_order_does_not_matter():
    assert canonical_cull("cbfc+VFC+bfc") == "vfc+bfc+cbfc"
    assert canonical_cull("none") == "none"


def test_label_order_names_every_culling_stage_once():
    assert sorted(STAGE_ORDER) == sorted(STAGES) and set(LOOSE_STAGES) <= set(STAGES)


@pytest.mark.parametrize("bad", ["vfc+hzb", "vfc+vfc_thesis"])
def test_bad_culls_are_refused(bad):
    with pytest.raises(SelectionError):
        canonical_cull(bad)


def test_all_culls_is_thesis_plus_ours():
    assert parse_culls("all") == list(THESIS_CULLS) + list(OUR_CULLS)


def test_portals_stage_only_on_portal_structures():
    specs = expand("w1", "octree:5,portal:2", "vfc+portals", "ipaq-hx2490b")
    assert [s.structure for s in specs] == ["portal:2"]


def test_expand_counts_the_cross_product():
    specs = expand("w1,w5", "grid,octree:3-4", "thesis", "ipaq-hx2490b,nokia-n82")
    assert len(specs) == 2 * 3 * 8 * 2
    (path,) = {s.trajectory for s in specs if s.world == "w5"}
    assert path.endswith("vismobile/trajectories/outdoor.csv") and Path(path).is_file()


def test_keys_are_stable_and_distinct():
    a = RunSpec("w1", "t.csv", "octree:5", "vfc", "ipaq-hx2490b")
    b = RunSpec("w1", "t.csv", "octree:5", "vfc+bfc", "ipaq-hx2490b")
    assert a.key("salt") == RunSpec("w1", "t.csv", "octree:5", "vfc", "ipaq-hx2490b").key("salt")
    assert a.key("salt") != b.key("salt")
    assert a.key("salt") != a.key("other world bytes")


def test_ground_truth_back_faces_follow_backface_stages():
    assert RunSpec("w1", "t", "bsp", "vfc+cbfc", "desktop").truth_cull_back
    assert not RunSpec("w1", "t", "bsp", "vfc+cbfc", "desktop").cull_back
    assert not RunSpec("w1", "t", "bsp", "vfc", "desktop").truth_cull_back


def test_frame_selections_include_waypoints():
    assert frame_indices("stride:4", 10, {}) == [0, 4, 8]
    assert frame_indices("sample:3", 11, {"A": 7}) == [0, 5, 7, 10]
    assert frame_indices("all", 3, {}) == [0, 1, 2]


def test_empty_selection_is_refused():
    with pytest.raises(SelectionError):
        expand("w1", "octree:5", "vfc+portals", "ipaq-hx2490b")

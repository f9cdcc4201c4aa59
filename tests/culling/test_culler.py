"""The Culler's interface: stage names, ordering, result shape, flags and counters."""
import numpy as np
import pytest

from vismobile import Culler
from vismobile.world.camera import Camera
from vismobile.culling import STAGES, parse_stages


def test_stages_parse_from_a_comma_string_or_a_list_and_run_cheapest_first():
    assert parse_stages("cbfc,vfc,bfc") == ("vfc", "cbfc", "bfc")
    assert parse_stages(["occlusion", "vfc", "vfc"]) == ("vfc", "occlusion")
    assert parse_stages("none") == () and parse_stages("") == ()


def test_unknown_stage_is_a_value_error_listing_the_valid_ones():
    with pytest.raises(ValueError, match="valid: .*cbfc.*vfc"):
        parse_stages("vfc,frustum")


def test_unknown_stage_option_is_a_value_error(w1_octree):
    with pytest.raises(ValueError, match="unknown stage"):
        Culler(w1_octree, "vfc", vcf={"x": 1})


def test_result_is_sorted_unique_ids_with_counters(w1_octree):
    cam = Camera((20.0, 1.6, 16.0), yaw=30.0, aspect=0.75)
    result = Culler(w1_octree, "vfc,cbfc").cull(cam)
    ids = result.triangles
    assert ids.dtype.kind == "i" and np.all(np.diff(ids) > 0)
    for key in ("nodes_visited", "plane_tests", "triangles_tested", "triangles_sent",
                "draw_batches", "vfc.nodes_culled", "cbfc.regions_dropped"):
        assert key in result.stats
    assert result.stats["triangles_sent"] == len(ids)
    assert result.stats["draw_batches"] == 1 + np.count_nonzero(np.diff(ids) != 1)


def test_no_stages_sends_every_triangle(w1_octree):
    result = Culler(w1_octree, "none").cull(Camera((0.0, 0.0, 0.0)))
    assert np.array_equal(result.triangles, np.arange(w1_octree.world.triangle_count))
    assert result.stats["nodes_visited"] == 0 and not result.cull_back


def test_bfc_is_a_render_flag_and_sends_the_same_triangles(w1_octree):
    cam = Camera((20.0, 1.6, 16.0), yaw=200.0, pitch=-10.0, aspect=0.75)
    plain, flagged = Culler(w1_octree, "vfc").cull(cam), Culler(w1_octree, "vfc,bfc").cull(cam)
    assert flagged.cull_back and not plain.cull_back
    assert np.array_equal(plain.triangles, flagged.triangles)


def test_camera_looking_away_from_the_world_sends_nothing(w1_octree):
    low, high = w1_octree.world.extent
    cam = Camera((low[0] - 5.0, 1.0, 16.0), yaw=90.0, aspect=0.75)  # looks toward -x
    for stages in ("vfc", "vfc_thesis", "portals", "vfc,occlusion"):
        result = Culler(w1_octree, stages).cull(cam)
        assert len(result.triangles) == 0 and result.stats["draw_batches"] == 0


def test_every_stage_combines_with_every_other(w1_octree):
    cam = Camera((20.0, 1.6, 16.0), yaw=45.0, aspect=0.75)
    reference = set(Culler(w1_octree, "none").cull(cam).triangles)
    for name in STAGES:
        for other in STAGES:
            sent = Culler(w1_octree, [name, other]).cull(cam).triangles
            assert set(sent) <= reference


def test_unknown_arithmetic_mode_is_a_value_error(w1_octree):
    with pytest.raises(ValueError, match="valid: float64, float32, fixed16.16"):
        Culler(w1_octree, "vfc", arithmetic="float16")


def test_coarser_arithmetic_only_widens_the_frustum(w1_octree):
    cameras = [Camera((20.0, 1.6, 16.0), yaw=y, pitch=p, aspect=0.75)
               for y, p in ((0.0, 0.0), (37.5, 10.0), (-120.0, -30.0))]
    exact, fixed = Culler(w1_octree, "vfc"), Culler(w1_octree, "vfc", arithmetic="fixed16.16")
    for camera in cameras:
        kept = exact.cull(camera).triangles
        assert np.isin(kept, fixed.cull(camera).triangles).all()

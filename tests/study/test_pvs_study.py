"""The study with baked PVS configurations: structure labels with +pvs, the combinations they
run, the device model's price of the lookup and of the PVS's memory, and the report's
bake-or-cull table, on the tiny world."""
import numpy as np
import pytest

from vismobile.culling import Culler
from vismobile.device.costmodel import DeviceModel, device_counters
from vismobile.device.profile import PVS_DECODED, get_profile
from vismobile.study import engine
from vismobile.study.candidates import candidate_culls
from vismobile.study.matrix import (SelectionError, expand, parse_structures, pvs_of,
                                    structure_params)
from vismobile.study.pvs_report import verdict
from vismobile.study.tune import stage_subsets


def test_structure_labels_take_a_pvs():
    assert parse_structures("portal:1-2+pvs,bsp+pvs=conservative,grid+pvs=sampled:8,bsp") == \
        ["portal:1+pvs", "portal:2+pvs", "bsp+pvs", "grid+pvs=sampled:8", "bsp"]
    assert structure_params("portal:2+pvs") == {"depth": 2, "pvs": "conservative"}
    assert structure_params("grid+pvs=sampled:8") == {"auto": True, "pvs": "sampled:8"}
    assert pvs_of("octree:3") is None
    for bad in ("bsp+pvs=aggressive", "bsp+pvs=sampled:0", "bsp+pv", "grid+pvs=sampled:99999",
                "octree:9+pvs"):
        with pytest.raises(SelectionError):
            parse_structures(bad)


def test_a_baked_structure_runs_every_combination_with_pvs(world_file, trajectory_file):
    specs = expand(str(world_file), "portal:1,portal:1+pvs", "vfc+tbfc;pvs+vfc;none",
                   trajectories={str(world_file): trajectory_file})
    runs = {(s.structure, s.cull) for s in specs}
    assert runs == {("portal:1", "vfc+tbfc"), ("portal:1", "none"),
                    ("portal:1+pvs", "vfc+tbfc+pvs"), ("portal:1+pvs", "vfc+pvs"),
                    ("portal:1+pvs", "pvs")}
    assert all("pvs" in c.split("+") for c in candidate_culls("bsp+pvs"))
    assert not any("pvs" in c.split("+") for c in candidate_culls("bsp"))
    assert all("pvs" in c.split("+") for c in stage_subsets("bsp+pvs"))


@pytest.fixture(scope="module")
def baked(world, tmp_path_factory):
    cache = tmp_path_factory.mktemp("cache")
    part, seconds = engine.load_structure(world, "portal:1+pvs", cache)
    return part, cache


def test_the_bake_is_cached_with_its_statistics(world, baked):
    part, cache = baked
    assert part.params["pvs"] == "conservative" and "pvs_pack" in part.extras
    base, _ = engine.load_structure(world, "portal:1", cache)
    assert "pvs_pack" not in base.extras  # the base structure is not touched
    engine._BAKES.clear()
    engine._PARTITIONS.clear()
    again, seconds = engine.load_structure(world, "portal:1+pvs", cache)
    assert seconds == 0.0 and np.array_equal(again.extras["pvs_pack"], part.extras["pvs_pack"])
    stats = engine.bake_stats(world, "portal:1+pvs", cache)  # read back from beside the file
    assert stats["cells"] == len(part.extras["pvs_cells"]) and stats["bytes"] > 0
    assert stats["seconds"] > 0 and 0 < stats["mean_set"] <= 1


def test_the_study_bakes_at_the_default_budget_and_not_from_older_exact_files(world, baked):
    # a +pvs candidate is the default bake (budget 0.25, recorded); a cached file without a
    # budget in its params was baked exact before the default, and is baked again
    from vismobile.partition import load_partition, save_partition

    part, cache = baked
    assert part.params["budget"] == 0.25
    path = engine._structure_path(world, "portal:1+pvs", cache)
    old = engine.load_structure(world, "portal:1", cache)[0]
    old.extras = {**old.extras, "pvs_unread": np.zeros(1)}  # a mark the bake would not make
    old.params = {**old.params, "pvs": "conservative"}
    save_partition(old, path)
    assert "budget" not in load_partition(path).params  # it loads: stale, not unreadable
    engine._PARTITIONS.clear()
    again, seconds = engine.load_structure(world, "portal:1+pvs", cache)
    assert seconds > 0 and again.params["budget"] == 0.25 and "pvs_unread" not in again.extras


def test_the_device_model_prices_the_lookup_and_the_memory(world, baked, trajectory, profile):
    part, _ = baked
    camera = trajectory.camera(3, profile.aspect)
    result = Culler(part, "pvs+vfc").cull(camera)
    stats = device_counters(result)
    # the boxes in the x-z buckets around the eye (culling/pvs_lookup.py), at most every cell
    assert 0 < stats["pvs.cells_tested"] <= len(part.extras["pvs_cells"])
    model = DeviceModel(profile)
    without = {k: v for k, v in stats.items() if not k.startswith("pvs.")}
    assert model.cull_ms(stats) > model.cull_ms(without)
    from vismobile.culling.pvs import KEEP

    assert PVS_DECODED == KEEP
    memory = get_profile("ipaq-hx2490b").estimate_memory(world, part)
    cells = len(part.extras["pvs_cells"])
    assert memory["pvs"] >= min(KEEP, cells) * world.triangle_count
    plain = get_profile("ipaq-hx2490b").estimate_memory(world, engine.load_structure(
        world, "portal:1", baked[1])[0])
    assert "pvs" not in plain and memory["partition"] == plain["partition"]


def _record(structure, ms, conservative=True):
    return {"spec": {"structure": structure},
            "summary": {"conservative": conservative,
                        "model": {"ipaq-hx2490b": {"frame_ms": {"mean": ms}}}}}


def test_the_verdict_needs_more_than_one_percent():
    runtime = _record("portal:2", 100.0)
    assert verdict(_record("portal:2+pvs", 90.0), runtime, "ipaq-hx2490b") == "bake"
    assert verdict(_record("portal:2+pvs", 99.5), runtime, "ipaq-hx2490b") == "either"
    assert verdict(_record("portal:2+pvs", 120.0), runtime, "ipaq-hx2490b") == \
        "cull at run time"
    assert verdict(None, runtime, "ipaq-hx2490b") == "cull at run time"


def test_compare_runs_a_bake_and_the_report_answers_bake_or_cull(tmp_path, world_file,
                                                                 trajectory_file):
    from vismobile.study.report import write_report
    from vismobile.study.runner import Context, run_matrix

    context = Context("/", tmp_path / "out", tmp_path / "worlds", tmp_path / "cache")
    specs = expand(str(world_file), "portal:1,portal:1+pvs", "vfc+tbfc", frames="sample:3",
                   trajectories={str(world_file): trajectory_file})
    records = run_matrix(specs, context, processes=2, progress=False)  # the bake spread
    baked = [r for r in records if r["spec"]["structure"] == "portal:1+pvs"]
    assert len(baked) == 1 and baked[0]["summary"]["pvs"]["bytes"] > 0
    assert baked[0]["summary"]["conservative"]
    page = write_report(records, tmp_path / "r.html").read_text()
    assert "Bake or cull at run time?" in page and "Bake a PVS or cull at run time?" in page
    assert page.count("class='verdict'") == 2  # one per device model


def test_partition_bakes_over_dask_as_it_bakes_alone(tmp_path, world_file, world, capsys):
    pytest.importorskip("dask.distributed")
    from vismobile.app.cli import main as cli
    from vismobile.partition import load_partition, partition

    out = tmp_path / "p.vmp"
    rc = cli(["partition", str(world_file), "--structure", "portal:1,pvs=conservative",
              "--scheduler", "dask", "--jobs", "2", "--repair", "none", "-o", str(out)])
    assert rc == 0 and "pvs         conservative" in capsys.readouterr().out
    alone = partition(world, "portal", depth=1, pvs="conservative")
    spread = load_partition(out)
    for name in ("pvs_cells", "pvs_shape", "pvs_pack"):
        assert np.array_equal(spread.extras[name], alone.extras[name]), name


@pytest.mark.parametrize("args", [["--structure", "portal:1,pvs=conservative", "--scheduler",
                                   "tcp://nowhere:99999"],
                                  ["--structure", "portal:1,pvs=conservative", "--scheduler",
                                   "dask; rm"],
                                  ["--structure", "portal:1", "--scheduler", "dask"]])
def test_partition_refuses_a_bad_scheduler_in_one_line(tmp_path, world_file, capsys, args):
    from vismobile.app.cli import main as cli

    out = tmp_path / "p.vmp"
    assert cli(["partition", str(world_file), *args, "-o", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--scheduler" in err[0] and not out.exists()


def test_compare_on_dask_bakes_on_the_cluster(tmp_path, world_file, trajectory_file):
    pytest.importorskip("dask.distributed")
    from vismobile.study.runner import Context, run_matrix

    specs = expand(str(world_file), "portal:1+pvs", "vfc", frames="sample:2",
                   trajectories={str(world_file): trajectory_file})
    context = Context("/", tmp_path / "out", tmp_path / "worlds", tmp_path / "cache")
    records = run_matrix(specs, context, processes=2, progress=False, scheduler="dask")
    assert all("error" not in r for r in records), [r.get("error") for r in records]
    assert records[0]["summary"]["pvs"]["cells"] > 0
    assert records[0]["summary"]["conservative"]

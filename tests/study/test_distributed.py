"""The comparison on a Dask LocalCluster: a worker killed mid-sweep changes nothing."""
import json
import os
import signal

import pytest

from vismobile.study import distributed
from vismobile.study.matrix import RunSpec
from vismobile.study.runner import Context, run_matrix

# Per-frame columns that do not depend on timing: equal between any two runs of a spec.
EXACT = ("frame", "triangles_sent", "draw_batches", "nodes_visited", "plane_tests",
         "triangles_tested", "visible", "false_negatives", "fn_pixels", "tightness")


def _specs(world_file, trajectory_file):
    return [RunSpec(str(world_file), str(trajectory_file), structure, cull, "ipaq-hx2490b",
                    "sample:2")
            for structure, cull in (("octree:2", "none"), ("octree:2", "vfc"), ("bsp", "vfc"),
                                    ("octree:2", "vfc+bfc+cbfc"), ("bsp", "vfc+occlusion"))]


def _exact(records):
    return {r["key"]: {c: r["frames"][c] for c in EXACT} for r in records}


def test_a_worker_killed_mid_sweep_changes_nothing(tmp_path, world_file, trajectory_file):
    dask_distributed = pytest.importorskip("dask.distributed")
    specs = _specs(world_file, trajectory_file)
    cache = tmp_path / "cache"
    plain = run_matrix(specs, Context("/", tmp_path / "plain", tmp_path / "w", cache),
                       processes=1, progress=False)
    killed = []

    def kill_a_busy_worker(client, key, record):
        if killed:
            return
        busy = [address for address, keys in client.processing().items() if keys]
        pids = client.run(os.getpid)
        victim = busy[0] if busy else sorted(pids)[0]
        os.kill(pids[victim], signal.SIGKILL)
        killed.append(victim)

    context = Context("/", tmp_path / "dask", tmp_path / "w", cache)
    with dask_distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                       dashboard_address=None,
                                       env=distributed._worker_env()) as cluster, \
            dask_distributed.Client(cluster) as client:
        records = run_matrix(specs, context, progress=False, scheduler=client,
                             on_record=kill_a_busy_worker)
    assert killed
    assert all("error" not in r for r in records), [r.get("error") for r in records]
    assert _exact(records) == _exact(plain)
    # One result file and one table row per run: nothing duplicated by the re-executed task.
    assert len(list((context.out / "runs").glob("*.json"))) == len(specs)
    rows = json.loads((context.out / "runs.json").read_text())
    assert sorted(r["key"] for r in rows) == sorted(r["key"] for r in plain)


def test_a_finished_result_file_is_read_back_not_rerun(tmp_path, world_file, trajectory_file):
    spec = _specs(world_file, trajectory_file)[1]
    context = Context("/", tmp_path / "out", tmp_path / "w", tmp_path / "cache")
    path = tmp_path / "out" / "runs" / "k.json"
    path.parent.mkdir(parents=True)
    path.write_text(json.dumps({"key": "k", "spec": spec.to_dict(), "marker": 1}))
    key, record = distributed._resume_or_execute((spec, "k", context.as_tuple()))
    assert key == "k" and record["marker"] == 1


def test_an_unreachable_scheduler_is_one_clear_error():
    pytest.importorskip("dask.distributed")
    with pytest.raises(distributed.SchedulerError, match="127.0.0.1:9"):
        distributed.open_client("tcp://127.0.0.1:9", None, timeout="1s")


def test_local_cluster_workers_render_on_one_thread_and_keep_glibcs_trim(monkeypatch):
    pytest.importorskip("dask.distributed")
    import dask

    monkeypatch.delenv("MALLOC_TRIM_THRESHOLD_", raising=False)
    client, cluster = distributed.open_client("dask", 1)
    try:
        seen = client.run(lambda: (os.environ.get("LP_NUM_THREADS"),
                                   os.environ.get("MALLOC_TRIM_THRESHOLD_"),
                                   dask.config.get("distributed.worker.profile.enabled")))
    finally:
        client.close()
        cluster.close()
    assert list(seen.values()) == [("1", None, False)]


def test_dask_tracebacks_are_one_line(capsys):
    # a killed worker makes Dask log CommClosedError tracebacks on stderr: one line each
    import io
    import logging

    stream = io.StringIO()
    handler = logging.StreamHandler(stream)
    logger = logging.getLogger("distributed")
    logger.addHandler(handler)
    try:
        distributed.quiet_dask_logs()
        try:
            raise OSError("in <TCP (closed) ConnectionPool.gather local=tcp://127.0.0.1:1>")
        except OSError:
            logging.getLogger("distributed.worker").error("Worker stream died", exc_info=True)
        logging.getLogger("distributed.nanny").warning("Traceback (most recent call last):\n"
                                                       "  File x\nCommClosedError: gone")
    finally:
        logger.removeHandler(handler)
    lines = stream.getvalue().splitlines()
    assert lines == ["Worker stream died (OSError: in <TCP (closed) ConnectionPool.gather "
                     "local=tcp://127.0.0.1:1>)",
                     "Traceback (most recent call last): (CommClosedError: gone)"]

"""The comparison's runs as Dask tasks: on a LocalCluster of worker processes ("dask") or on an
existing dask.distributed cluster (its scheduler's address).

Resumable exactly like the local pool: every run task writes `runs/<key>.json` atomically and
first reads that file back when it exists, so a task re-executed after its worker died (Dask
reschedules it) neither runs twice to completion nor leaves a duplicate; the caller merges
records by key into the same runs.csv. Run tasks depend on the prepare tasks (partition and
ground truth cached on disk) they need, and carry their position in the matrix as priority,
so workers go through the runs in matrix order and their per-process caches of worlds and
partitions keep hitting. Workers on other machines must see the same paths (a shared disk).
"""
from __future__ import annotations

import hashlib
import json
import logging
import os
import re
from pathlib import Path

from ..errors import VisMobileError

# A run whose worker dies this many times is reported as failed instead of retried forever.
ALLOWED_FAILURES = 3


class SchedulerError(VisMobileError):
    """A Dask scheduler that cannot be reached or started."""


class OneLine(logging.Filter):
    """Dask's log records as one line each: a worker killed mid-sweep is expected (its runs
    are redone, nothing is lost), so the tracebacks Dask logs about it (CommClosedError from
    the scheduler, the nanny and the other workers) are reduced to their exception's name and
    message."""

    def filter(self, record) -> bool:
        text = record.getMessage().strip().splitlines()
        line = text[0] if text else ""
        if record.exc_info and record.exc_info[1] is not None:
            error = record.exc_info[1]
            line += f" ({type(error).__name__}: {str(error).splitlines()[0] if str(error) else ''})"
        elif len(text) > 1:  # a traceback formatted into the message itself
            line += f" ({text[-1].strip()})"
        record.msg, record.args = line, ()
        record.exc_info, record.exc_text, record.stack_info = None, None, None
        return True


def quiet_dask_logs() -> None:
    """OneLine on every handler of the "distributed" logger (Dask's own stderr handler), in
    this process; workers call it too (their tasks start with it)."""
    handlers = logging.getLogger("distributed").handlers or logging.getLogger().handlers
    for handler in handlers:
        if not any(isinstance(f, OneLine) for f in handler.filters):
            handler.addFilter(OneLine())


def _worker_env() -> dict:
    """Environment of each LocalCluster worker: one llvmpipe thread, one BLAS thread."""
    return {"LP_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"}


ADDRESS = re.compile(r"(?:tcp://)?[A-Za-z0-9](?:[A-Za-z0-9.-]{0,252})?:([0-9]{1,5})")


def scheduler_address(text: str) -> str:
    """A --scheduler value checked before anything connects: "dask" or a scheduler address
    (tcp://host:port or host:port, port 1..65535); SchedulerError naming it otherwise."""
    text = str(text).strip()
    match = ADDRESS.fullmatch(text)
    if text == "dask" or (match and 1 <= int(match[1]) <= 65535):
        return text
    raise SchedulerError(f"--scheduler {text[:60]!r}: expected dask or a Dask scheduler's "
                         "address, tcp://host:port")


def open_client(scheduler: str, workers: int | None, timeout: str = "15s"):
    """(client, cluster or None) for "dask" (a LocalCluster of `workers` processes, one thread
    each) or a scheduler address ("tcp://host:8786" or "host:8786"), waited for `timeout`."""
    import dask
    from dask.distributed import Client, LocalCluster

    dask.config.set({"distributed.scheduler.allowed-failures": ALLOWED_FAILURES,
                     # Dask's 64 KiB makes glibc hand freed memory back at once, so numpy's
                     # per-frame temporaries fault their pages in again (docs/scale.md).
                     "distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": None,
                     # The statistical profiler samples every 10 ms for a dashboard not shown.
                     "distributed.worker.profile.enabled": False})
    try:
        if scheduler == "dask":
            cluster = LocalCluster(n_workers=max(1, workers or os.cpu_count() or 1),
                                   threads_per_worker=1, processes=True,
                                   dashboard_address=None, env=_worker_env())
            return Client(cluster), cluster
        return Client(scheduler, timeout=timeout), None
    except (OSError, TimeoutError, ValueError) as error:
        raise SchedulerError(f"cannot reach Dask scheduler {scheduler!r}: {error}") from None


def _resume_or_execute(task, *ready) -> tuple:
    """Run task: the finished result file when one exists (an earlier attempt wrote it before
    its worker died), else execute the run. `ready` are the prepare results it waited for."""
    from .tasks import Context, _execute_task, _worker_init, result_path

    _worker_init()
    quiet_dask_logs()
    spec, key, context_tuple = task
    path = result_path(Context.from_tuple(context_tuple), key)
    if path.is_file():
        try:
            return key, json.loads(path.read_text())
        except (OSError, ValueError):
            pass  # a damaged file is run again
    return _execute_task(task)


def _prepare(task) -> str:
    from .tasks import _worker_init, prepare

    _worker_init()
    quiet_dask_logs()
    return prepare(task)


def run_tasks(prep, tasks, scheduler, workers=None, on_record=None, step=None,
              progress=True) -> dict:
    """Execute prepare tasks and run tasks (runner's tuples) on Dask; {key: record}.

    scheduler : "dask", an address, or a dask.distributed Client to use as it is
    on_record : called with (client, key, record) as each run finishes (tests kill workers here)
    step      : called once per finished task (the progress bar)
    progress  : a progress line while a PVS bakes (False: none)
    """
    from dask.distributed import as_completed

    from .tasks import bake_first, prep_key

    quiet_dask_logs()  # a killed worker's tracebacks: one line each
    if hasattr(scheduler, "submit"):
        client, cluster, own = scheduler, None, False
    else:
        (client, cluster), own = open_client(scheduler, workers), True
    records = {}
    try:
        ready = {}
        for task in prep:
            name = hashlib.sha1(repr(prep_key(task)).encode()).hexdigest()[:16]
            ready[prep_key(task)] = client.submit(_prepare, task, key=f"prepare-{name}",
                                                  priority=len(tasks) + 1)
        # Conservative PVS bakes: from here, their source cells as tasks of this cluster (the
        # prepare tasks of their structures then find them cached). Not from inside a task: a
        # task that secedes to wait leaves the worker a second thread, and a GL context is
        # the thread's that made it.
        bake_first(prep, client, progress)
        futures = {}
        for index, task in enumerate(tasks):
            spec = task[0]
            needs = [ready[k] for k in (prep_key(("structure", spec, None)),
                                        prep_key(("truth", spec, None))) if k in ready]
            futures[client.submit(_resume_or_execute, task, *needs, key=f"run-{task[1]}",
                                  priority=-index)] = task
        for future in as_completed(list(ready.values())):
            if step:
                step()
        for future in as_completed(futures):
            try:
                key, record = future.result()
            except Exception as error:  # the worker died ALLOWED_FAILURES times on this run
                task = futures[future]
                key, record = task[1], {"spec": task[0].to_dict(),
                                        "error": f"{type(error).__name__}: {error}"}
            records[key] = record
            if on_record:
                on_record(client, key, record)
            if step:
                step()
    finally:
        if own:
            client.close()
            if cluster is not None:
                cluster.close()
    return records


def absolute(context):
    """The context with absolute paths, so workers in other directories find the same files."""
    from .tasks import Context

    *paths, repair = context.as_tuple()
    return Context(*(Path(p).resolve() for p in paths), repair)

"""A bake's fan-out over processes or a Dask cluster (pvs.py's source cells, pvs_street.py's
street cells): the same task over parts of the items, the parts' results in order."""
from __future__ import annotations

import numpy as np

# Parts per process of a process pool. The items' costs follow where they are (W2: a source
# cell's walk from 0.1 s to several seconds), so each part takes every PARTS-th item (strided,
# not contiguous runs) and the parts cost about the same; the last part to finish then leaves
# the other process idle for about 1 / (PARTS x jobs) of the bake.
PARTS = 8

_SHARED = None  # a pool worker's (task, shared), set once by _keep


def _keep(task, shared):
    """A pool worker's initializer: the task and its shared arguments, passed once per process
    (not pickled with every part)."""
    global _SHARED
    _SHARED = (task, shared)


def _run(part, rest):
    """task(*shared, part, *rest) in a pool worker (_keep)."""
    task, shared = _SHARED
    return task(*shared, part, *rest)


def strided_parts(count, parts) -> list:
    """(n,) int64 item ids of each of `parts` parts: part k takes items k, k + parts, ... ."""
    parts = max(1, min(count, parts))
    return [np.arange(k, count, parts) for k in range(parts)]


def _take(items, ids):
    return items[ids] if isinstance(items, np.ndarray) else [items[i] for i in ids]


def fan_out(task, shared, items, rest=(), jobs=1, executor=None, chunks=32,
            progress=None) -> list:
    """task(*shared, part, *rest) (a list, one result per item of part) over parts of items,
    returned in items' order.

    Serially one item a part; with jobs > 1 over a process pool of jobs (PARTS strided parts
    a process, strided_parts; `shared` handed to each process once); with executor
    (submit(fn, *args) -> future with result(); a Dask Client scatters `shared` to its
    workers once) over `chunks` contiguous parts. progress(done, total) after each part.
    """
    count = len(items)
    if executor is not None:
        split = np.array_split(np.arange(count), max(1, min(count, chunks)))
        if hasattr(executor, "scatter"):
            shared = executor.scatter(list(shared), broadcast=True)
        out = []
        futures = [executor.submit(task, *shared, items[p[0]:p[-1] + 1], *rest)
                   for p in split if len(p)]
        for f in futures:
            out.extend(f.result())
            if progress is not None:
                progress(len(out), count)
        return out
    if jobs > 1 and count > 1:
        from concurrent.futures import ProcessPoolExecutor, as_completed

        out = [None] * count
        done = 0
        with ProcessPoolExecutor(jobs, initializer=_keep, initargs=(task, shared)) as pool:
            futures = {pool.submit(_run, _take(items, ids), rest): ids
                       for ids in strided_parts(count, PARTS * jobs)}
            for f in as_completed(futures):
                ids = futures[f]
                results = f.result()
                if len(results) != len(ids):
                    raise RuntimeError("a bake task returned a result count unlike its items'")
                for i, r in zip(ids, results):
                    out[i] = r
                done += len(ids)
                if progress is not None:
                    progress(done, count)
        return out
    out = []
    for i in range(count):
        out.extend(task(*shared, items[i:i + 1], *rest))
        if progress is not None:
            progress(len(out), count)
    return out

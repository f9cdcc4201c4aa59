"""A bake's fan-out over processes or a Dask cluster (pvs.py's source cells, pvs_street.py's
street cells): the same task over parts of the items, the parts' results in order."""
from __future__ import annotations

import numpy as np


def fan_out(task, shared, items, rest=(), jobs=1, executor=None, chunks=32,
            progress=None) -> list:
    """task(*shared, part, *rest) (a list) over parts of items, concatenated in items' order.

    Serially one item a part; with jobs > 1 over a process pool of jobs (4 parts a process);
    with executor (submit(fn, *args) -> future with result(); a Dask Client scatters `shared`
    to its workers once) over `chunks` parts. progress(done, total) after each part.
    """
    count = len(items)
    out = []
    if executor is not None or (jobs > 1 and count > 1):
        from concurrent.futures import ProcessPoolExecutor

        parts = 4 * max(jobs, 1) if executor is None else chunks
        split = np.array_split(np.arange(count), max(1, min(count, parts)))
        pool = executor or ProcessPoolExecutor(jobs)
        if hasattr(pool, "scatter"):
            shared = pool.scatter(list(shared), broadcast=True)
        try:
            futures = [pool.submit(task, *shared, items[p[0]:p[-1] + 1], *rest)
                       for p in split if len(p)]
            for f in futures:
                out.extend(f.result())
                if progress is not None:
                    progress(len(out), count)
        finally:
            if executor is None:
                pool.shutdown()
        return out
    for i in range(count):
        out.extend(task(*shared, items[i:i + 1], *rest))
        if progress is not None:
            progress(len(out), count)
    return out

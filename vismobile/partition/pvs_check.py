"""The PVS extras' invariants (pvs.py's layout), checked on every load (base.Partition.check)."""
from __future__ import annotations

import numpy as np


def check_pvs(x, triangles) -> None:
    """Raise ValueError when the PVS extras are inconsistent (loaded files are checked)."""
    names = ("pvs_cells", "pvs_start", "pvs_runs", "pvs_grow")
    present = [n for n in names if n in x]
    if not present:
        return
    if len(present) != len(names):
        raise ValueError(f"pvs extras missing: {', '.join(n for n in names if n not in x)}")
    cells, start, runs, grow = (np.asarray(x[n]) for n in names)
    if "pvs_back" in x:
        back = np.asarray(x["pvs_back"])
        if back.shape != (1,) or not np.isfinite(back).all() or back[0] < 0:
            raise ValueError("pvs_back must be one finite non-negative value")
    if cells.ndim != 3 or cells.shape[1:] != (2, 3) or not np.isfinite(cells).all() \
            or np.any(cells[:, 0] > cells[:, 1]):
        raise ValueError("pvs_cells must be (V, 2, 3) finite boxes")
    if grow.shape != (1,) or not np.isfinite(grow).all() or grow[0] < 0:
        raise ValueError("pvs_grow must be one finite non-negative value")
    start = start.astype(np.int64)
    if (start.shape != (len(cells) + 1,) or start[0] != 0 or start[-1] != len(runs)
            or np.any(np.diff(start) < 0) or np.any(start % 2)):
        raise ValueError("pvs_start must be even ascending offsets from 0 to len(pvs_runs)")
    runs = runs.astype(np.int64)
    if runs.ndim != 1 or (len(runs) and (runs.min() < 0 or runs.max() > triangles)):
        raise ValueError("pvs_runs must be triangle ids")
    # within each cell: first < end, and each run after the previous one
    step = np.diff(runs)
    inner = np.ones(len(step), dtype=bool)
    cut = start[1:-1]
    inner[cut[(cut > 0) & (cut < len(runs))] - 1] = False  # no order across a cell boundary
    if len(step) and np.any(step[inner] <= 0):
        raise ValueError("pvs_runs must be ascending, non-touching runs within each cell")

"""The PVS extras' invariants (pvs.py's layout), checked on every load (base.Partition.check)."""
from __future__ import annotations

import numpy as np

from .pvs_codec import decode

NAMES = ("pvs_cells", "pvs_shape", "pvs_pack", "pvs_grow")


def check_pvs(x, triangles) -> None:
    """Raise ValueError when the PVS extras are inconsistent (loaded files are checked; the
    sets are inflated once to check them, within their declared size)."""
    present = [n for n in NAMES if n in x]
    if not present:
        if "pvs_runs" in x or "pvs_start" in x:
            raise ValueError("the PVS is stored as runs (an older layout): bake it again")
        return
    if len(present) != len(NAMES):
        raise ValueError(f"pvs extras missing: {', '.join(n for n in NAMES if n not in x)}")
    cells, grow = np.asarray(x["pvs_cells"]), np.asarray(x["pvs_grow"])
    if "pvs_back" in x:
        back = np.asarray(x["pvs_back"])
        if back.shape != (1,) or not np.isfinite(back).all() or back[0] < 0:
            raise ValueError("pvs_back must be one finite non-negative value")
    if cells.ndim != 3 or cells.shape[1:] != (2, 3) or not np.isfinite(cells).all() \
            or np.any(cells[:, 0] > cells[:, 1]):
        raise ValueError("pvs_cells must be (V, 2, 3) finite boxes")
    if grow.shape != (1,) or not np.isfinite(grow).all() or grow[0] < 0:
        raise ValueError("pvs_grow must be one finite non-negative value")
    decode(x, len(cells), int(triangles))

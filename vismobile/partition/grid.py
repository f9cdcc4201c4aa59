"""Irregular grid: per-axis slabs with given shares of the extent (thesis §2.3), or slab
boundaries placed at quantiles of the triangle centroids (auto); cells reference every
triangle they overlap (exact SAT)."""
from __future__ import annotations

import numpy as np

from ..geometry.triangle_box import triangles_overlap_boxes
from .layout import check_references, make_partition

AXES = "xyz"
# Cells of a grid (boxes are built for every cell, empty or not).
MAX_CELLS = 1 << 20


def slab_edges(low, high, slabs) -> np.ndarray:
    """(n + 1,) float64 slab boundaries on one axis from a count or a list of shares.

    slabs : int n (n equal slabs) or sequence of positive shares (normalised to sum 1)
    """
    if isinstance(slabs, (int, np.integer)) and not isinstance(slabs, bool):
        if not 1 <= slabs <= MAX_CELLS:
            raise ValueError(f"slab count must be from 1 to {MAX_CELLS:,}, got {slabs}")
        shares = np.full(int(slabs), 1.0 / int(slabs))
    else:
        if hasattr(slabs, "__len__") and len(slabs) > MAX_CELLS:
            raise ValueError(f"more than {MAX_CELLS:,} slab shares")
        shares = np.asarray(slabs, dtype=np.float64).ravel()
        if len(shares) == 0 or not np.all(np.isfinite(shares)) or np.any(shares <= 0):
            raise ValueError(f"slab shares must be positive numbers, got {list(slabs)!r}")
        shares = shares / shares.sum()
    edges = low + np.concatenate([[0.0], np.cumsum(shares)]) * (high - low)
    edges[0], edges[-1] = low, high
    return edges


def auto_counts(world, cells) -> np.ndarray:
    """(3,) int slab counts with product near `cells`, proportional to the world's extent."""
    size = np.ptp(world.extent, axis=0)
    live = size > 1e-9 * max(size.max(), 1e-300)
    counts = np.ones(3, dtype=np.int64)
    if live.any():
        step = (np.prod(size[live]) / cells) ** (1.0 / live.sum())
        counts[live] = np.maximum(1, np.round(size[live] / step)).astype(np.int64)
    return counts


def auto_edges(world, counts) -> list:
    """Per-axis boundaries at the quantiles of triangle centroids, so cells hold similar counts."""
    low, high = world.extent
    edges = []
    for axis in range(3):
        inner = np.quantile(world.centroids[:, axis], np.linspace(0, 1, counts[axis] + 1)[1:-1])
        e = np.unique(np.concatenate([[low[axis]], inner, [high[axis]]]))
        # Drop slivers thinner than 1e-6 of the extent: they only add empty cells.
        gap = 1e-6 * max(high[axis] - low[axis], 1e-300)
        e = e[np.concatenate([[True], np.diff(e) > gap])]
        e[-1] = high[axis]
        edges.append(e if len(e) > 1 else np.array([low[axis], high[axis]]))
    return edges


def default_cell_count(world) -> int:
    """Cells for automatic grids: about 64 triangles per cell, 8 to 4096 cells."""
    return int(np.clip(world.triangle_count // 64, 8, 4096))


def cell_pairs(world, edges, triangles=None, slack: float = 0.0):
    """(cell, triangle) references of a grid, exact: SAT for triangles spanning several cells.

    Errs toward keeping by `slack` (distance): a triangle within slack of a cell counts in it.
    edges   : three (n_a + 1,) float64 boundary arrays
    returns : cell (P,) int64 as (i * ny + j) * nz + k, tri (P,) int64, sorted by cell then tri
    """
    tris = np.arange(world.triangle_count) if triangles is None else np.asarray(triangles)
    tb = world.bounds[tris]
    if slack > 0.0:
        tb = tb + np.array([-slack, slack])[None, :, None]
    lo_idx, span = [], []
    for axis, e in enumerate(edges):
        n = len(e) - 1
        i0 = np.clip(np.searchsorted(e, tb[:, 0, axis], side="left") - 1, 0, n - 1)
        i1 = np.clip(np.searchsorted(e, tb[:, 1, axis], side="right") - 1, 0, n - 1)
        lo_idx.append(i0)
        span.append(i1 - i0 + 1)
    span = np.stack(span, axis=1)
    total = span.prod(axis=1)
    check_references(int(total.sum()), "the grid", candidates=True)
    owner = np.repeat(np.arange(len(tris)), total)
    local = np.arange(total.sum()) - np.repeat(np.cumsum(total) - total, total)
    ny, nz = len(edges[1]) - 1, len(edges[2]) - 1
    k = lo_idx[2][owner] + local % span[owner, 2]
    j = lo_idx[1][owner] + (local // span[owner, 2]) % span[owner, 1]
    i = lo_idx[0][owner] + local // (span[owner, 2] * span[owner, 1])
    keep = np.ones(len(owner), dtype=bool)
    multi = np.flatnonzero(total[owner] > 1)
    if len(multi):
        lo = np.stack([edges[0][i[multi]], edges[1][j[multi]], edges[2][k[multi]]], axis=1)
        hi = np.stack([edges[0][i[multi] + 1], edges[1][j[multi] + 1], edges[2][k[multi] + 1]],
                      axis=1)
        corners = world.vertices[world.triangles[tris[owner[multi]]]]
        keep[multi] = triangles_overlap_boxes(corners, lo - slack, hi + slack)
    cell = ((i * ny + j) * nz + k)[keep]
    tri = tris[owner[keep]]
    order = np.lexsort((tri, cell))
    return cell[order].astype(np.int64), tri[order].astype(np.int64)


def cell_boxes(edges) -> np.ndarray:
    """(C, 2, 3) float64 boxes of every cell, in (i * ny + j) * nz + k order."""
    i, j, k = np.meshgrid(*[np.arange(len(e) - 1) for e in edges], indexing="ij")
    i, j, k = i.ravel(), j.ravel(), k.ravel()
    lo = np.stack([edges[0][i], edges[1][j], edges[2][k]], axis=1)
    hi = np.stack([edges[0][i + 1], edges[1][j + 1], edges[2][k + 1]], axis=1)
    return np.stack([lo, hi], axis=1)


def resolve_edges(world, slabs=None, auto=False, cells=None):
    """Three boundary arrays from explicit slabs (per axis a count or shares) or auto mode."""
    if slabs is not None and auto:
        raise ValueError("give either slabs or auto=True, not both")
    if slabs is None:
        if not auto and cells is None:
            auto = True
        check_cells(default_cell_count(world) if cells is None else cells)
        counts = auto_counts(world, default_cell_count(world) if cells is None else int(cells))
        return auto_edges(world, counts)
    if isinstance(slabs, (int, np.integer)) and not isinstance(slabs, bool):
        slabs = (slabs,) * 3  # grid:8 -> 8 slabs on every axis
    if isinstance(slabs, (str, bytes)) or not hasattr(slabs, "__len__"):
        raise ValueError(f"slabs must be a count or one entry per axis, got {slabs!r}")
    if len(slabs) != 3:
        raise ValueError(f"slabs needs one entry per axis (x, y, z), got {len(slabs)}")
    counts = [s if isinstance(s, (int, np.integer)) else len(s) if hasattr(s, "__len__") else 1
              for s in slabs]
    check_cells(int(np.prod([max(int(c), 1) for c in counts], dtype=object)))
    low, high = world.extent
    return [slab_edges(low[a], high[a], slabs[a]) for a in range(3)]


def check_cells(cells, limit=MAX_CELLS, what="grid") -> int:
    """cells as an int in [1, limit], else ValueError (checked before any cell is built)."""
    if isinstance(cells, bool) or not isinstance(cells, (int, np.integer)) or not 1 <= cells <= limit:
        raise ValueError(f"{what} cell count must be an integer from 1 to {limit:,}, got {cells!r}")
    return int(cells)


def build(world, slabs=None, auto=False, cells=None, progress=None):
    """Irregular grid: root -> one level of non-empty cells (leaves).

    slabs : per axis a count or a sequence of shares, e.g. ((0.2, 0.2, 0.3, 0.3), 1, (0.5, 0.5)),
            or one count for every axis
    auto  : place boundaries at centroid quantiles; `cells` sets the target cell count
    returns : Partition; extras grid_x, grid_y, grid_z (n_a + 1,) float64 boundaries and
              cell_index (leaves, 3) int32 slab indices of each leaf in node order (root -1)
    """
    edges = resolve_edges(world, slabs, auto, cells)
    cell, tri = cell_pairs(world, edges)
    used, node = np.unique(cell, return_inverse=True)
    boxes = cell_boxes(edges)[used]
    parent = np.concatenate([[-1], np.zeros(len(used), dtype=np.int64)])
    shape = [len(e) - 1 for e in edges]
    ijk = np.concatenate([[[-1, -1, -1]], np.stack(np.unravel_index(used, shape), axis=1)])
    params = {"auto": slabs is None, "slabs": [len(e) - 1 for e in edges]}
    if progress is not None:
        progress(1, 1)
    result, _ = make_partition(
        "grid", params, world, parent, node + 1, tri,
        np.concatenate([world.extent[None], boxes]),
        node_extras={"cell_index": ijk.astype(np.int32)},
        extras={f"grid_{AXES[a]}": np.asarray(edges[a], dtype=np.float64) for a in range(3)})
    return result

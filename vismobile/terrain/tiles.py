"""Tile quadtree with a screen-space error in pixels (seed 002, Rodrigues 2016), ES 1.1 form.

Instead of tessellating patches on the GPU, each quadtree tile is drawn from pre-built LODs: a
tile at level l covers P * 2^(L-l) cells with a (P+1)^2 vertex grid at stride 2^(L-l); P is the
patch size. A tile is refined while rho = lambda_b * E / d > tau (pixels), with E the tile's
nested vertical error, d the distance from the eye to the tile's box and lambda_b the seed's
lambda = w / (2 tan(theta/2)) times the off-axis factor 1 + tan^2(hx) + tan^2(hy), so that the
bound holds at the screen corners too (the seed's plain lambda is exact only on the axis).

Crack-free edges: neighbouring leaves differ by at most one level (a fine-to-coarse balancing
pass), and a leaf next to a coarser one drops every other vertex of that edge by snapping it
onto the even vertex before it (16 pre-built index templates, one per set of reduced sides),
so both tiles draw exactly the coarse edge: the seed's n_outer = n_max / 2^delta with
delta <= 1. E covers every template (it is measured on the union of their triangles against
every full-resolution sample) and is nested (a parent's E is at least its children's), so
balancing, which only refines, never breaks the bound.
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from ..geometry.planes import classify_boxes
from . import quadtree
from .heightmap import Heightmap
from .mesh import grid_triangles
from .raster import lod_heights, tile_statistics

# Side bits of a template: which edges are reduced to every other vertex.
ROW0, COLP, ROWP, COL0 = 1, 2, 4, 8


def pixel_scale(camera, resolution) -> tuple:
    """(lambda, lambda_bound): pixels per unit at unit distance, and the strict off-axis bound.

    lambda = h / (2 tan(fov_y / 2)) (= w / (2 tan(fov_x / 2)) for square pixels). A segment of
    length E anywhere in the frustum at distance >= d from the eye projects to at most
    lambda_bound * E / d pixels (errs high by up to the off-axis factor on the axis).
    """
    ty = np.tan(np.radians(camera.fov) / 2.0)
    tx = ty * camera.aspect
    lam = resolution[1] / (2.0 * ty)
    return lam, lam * (1.0 + tx * tx + ty * ty)


def horizontal_error(valid, patch: int, stride: int, spacing: float) -> np.ndarray:
    """(m, m) float64 seed 002's horizontal error of each tile at one stride (Rodrigues's
    Table 4.1): over the stride's grid edges A-B (rows, columns and the cells' diagonals) with
    midpoint C, where no-data samples make the cut's silhouette (midway between a valid and a
    null vertex) move: hsize = |AC| when A and B agree and C differs, hsize / 2 when A and B
    differ, 0 otherwise; diagonals sqrt(2) times that. 0 at stride 1 (no midpoint). The
    pyramid nests it like the vertical error, as the seed does; a hole narrower than a
    midpoint's spacing between samples checked at no level is missed (the seed's rule, not a
    strict bound)."""
    n = valid.shape[0]
    m = (n - 1) // (patch * stride)
    if stride < 2:
        return np.zeros((m, m))
    half = stride // 2
    # the midpoints' grid: even entries are the stride's samples
    return horizontal_from_grid(valid[::half, ::half], patch, half * spacing)


def horizontal_from_grid(g, patch: int, hsize: float) -> np.ndarray:
    """horizontal_error over g, the validity at half the stride ((2 m_r P + 1, 2 m_c P + 1)
    bool: a whole map or one row of tiles), hsize = half the stride in world units: the
    (m_r, m_c) tiles' errors."""
    m_rows, m_cols = (g.shape[0] - 1) // (2 * patch), (g.shape[1] - 1) // (2 * patch)

    def value(a, c, b, scale):
        return np.where(a != b, 0.5 * scale, np.where(a != c, scale, 0.0))

    rows = value(g[::2, :-2:2], g[::2, 1::2], g[::2, 2::2], hsize)  # (G+1, G)
    cols = value(g[:-2:2, ::2], g[1::2, ::2], g[2::2, ::2], hsize)  # (G, G+1)
    diag = value(g[:-2:2, :-2:2], g[1::2, 1::2], g[2::2, 2::2], np.sqrt(2.0) * hsize)

    def pool(a, rows_extra, cols_extra):
        view = np.lib.stride_tricks.sliding_window_view(a, (patch + rows_extra,
                                                            patch + cols_extra))
        return view[::patch, ::patch].max(axis=(-1, -2))[:m_rows, :m_cols]

    return np.maximum(np.maximum(pool(rows, 1, 0), pool(cols, 0, 1)), pool(diag, 0, 0))


def template(patch: int, sides: int) -> np.ndarray:
    """(T, 3) int32 triangles over a (patch+1)^2 local grid with the `sides` edges halved.

    Vertices on a reduced side snap to the even vertex at or before them; triangles that
    collapse are dropped. Counter-clockwise from +y, no overlaps, and the union covers the
    tile (checked in the tests).
    """
    n = patch + 1
    a, b = np.divmod(np.arange(n * n), n)  # row, column of each local vertex
    sa, sb = a.copy(), b.copy()
    if sides & ROW0:
        sb = np.where(a == 0, sb - sb % 2, sb)
    if sides & ROWP:
        sb = np.where(a == patch, sb - sb % 2, sb)
    if sides & COL0:
        sa = np.where(b == 0, sa - sa % 2, sa)
    if sides & COLP:
        sa = np.where(b == patch, sa - sa % 2, sa)
    remap = sa * n + sb
    tris = remap[grid_triangles(patch)]
    keep = (tris[:, 0] != tris[:, 1]) & (tris[:, 1] != tris[:, 2]) & (tris[:, 0] != tris[:, 2])
    return tris[keep].astype(np.int32)


@dataclass
class TilePyramid:
    """Per-level tile statistics of one heightmap for one patch size.

    patch        : P, cells per tile side (power of two, <= N - 1)
    levels       : L, so the finest tiles (level L) have stride 1; level l has 2^l x 2^l tiles
    error[l]     : (2^l, 2^l) float64 nested vertical error E (world units)
    hmin, hmax   : per level (2^l, 2^l) float64 height range of each tile's footprint
    templates    : 16 (T_k, 3) int32 local triangle lists, indexed by side bits
    build_seconds: time to compute the statistics
    """

    heightmap: Heightmap
    patch: int
    levels: int
    error: list
    hmin: list
    hmax: list
    templates: list
    build_seconds: float

    def __post_init__(self):
        self.offsets = quadtree.level_offsets(self.levels)
        self.flat_error = np.concatenate([e.ravel() for e in self.error])
        self.flat_hmin = np.concatenate([e.ravel() for e in self.hmin])
        self.flat_hmax = np.concatenate([e.ravel() for e in self.hmax])
        self.template_counts = np.array([len(t) for t in self.templates])
        # Per-frame state of select_tiles (stamps: nothing is cleared between frames).
        self.stamp = np.zeros(self.offsets[-1], np.int64)
        self.lists = np.zeros(self.offsets[-1], np.int64)
        self.counts = np.zeros(self.levels + 1, np.int64)
        self.out = np.zeros((4 ** self.levels, 4), np.int64)
        self.frame = 0

    @classmethod
    def build(cls, heightmap: Heightmap, patch: int = 16) -> "TilePyramid":
        cells = heightmap.size - 1
        if patch < 2 or patch & (patch - 1) or patch > cells:
            raise ValueError(f"patch must be a power of two in [2, {cells}], got {patch}")
        levels = (cells // patch).bit_length() - 1
        start = time.perf_counter()
        templates = [template(patch, sides) for sides in range(16)]
        union = np.unique(np.sort(np.concatenate(templates), axis=1), axis=0)
        n = patch + 1
        local = np.stack(np.divmod(union, n), axis=-1).astype(np.int64)  # (K, 3, 2) row, col
        heights = heightmap.heights.astype(np.float64)
        error, hmin, hmax = [], [], []
        for level in range(levels + 1):
            stride = 1 << (levels - level)
            e, lo, hi = tile_statistics(heights, patch, stride, local)
            error.append(e)
            hmin.append(lo)
            hmax.append(hi)
        horizontal = None
        if heightmap.valid is not None:  # seed 002's holes: E = length(E_h, E_v)
            horizontal = [horizontal_error(heightmap.valid, patch, 1 << (levels - level),
                                           heightmap.spacing) for level in range(levels + 1)]
            error = [np.hypot(e, h) for e, h in zip(error, horizontal)]
        for level in range(levels - 1, -1, -1):  # nest: a parent bounds its children
            child = error[level + 1]
            k = child.shape[0] // 2
            error[level] = np.maximum(error[level], child.reshape(k, 2, k, 2).max(axis=(1, 3)))
        return cls(heightmap, patch, levels, error, hmin, hmax, templates,
                   time.perf_counter() - start)

    def tile_boxes(self, level: int, ti, tj) -> np.ndarray:
        """(K, 2, 3) float64 world boxes of tiles (level, ti, tj)."""
        size = self.patch * (1 << (self.levels - level)) * self.heightmap.spacing
        x0, z0 = np.asarray(tj) * size, np.asarray(ti) * size
        low = np.stack([x0, self.hmin[level][ti, tj], z0], axis=-1)
        high = np.stack([x0 + size, self.hmax[level][ti, tj], z0 + size], axis=-1)
        return np.stack([low, high], axis=1)


@dataclass
class TileSelection:
    """Drawn tiles of one frame.

    level, ti, tj : (K,) int64 tile ids (level, row, column)
    sides         : (K,) int64 template index (reduced-side bits)
    triangles     : int, triangles the tiles draw
    leaves        : int, leaves of the balanced quadtree (drawn or culled)
    tested        : int, tiles whose box was tested against the frustum
    """

    level: np.ndarray
    ti: np.ndarray
    tj: np.ndarray
    sides: np.ndarray
    triangles: int
    leaves: int
    tested: int


def select_tiles(pyramid: TilePyramid, camera, resolution, tau: float,
                 cull: bool = True) -> TileSelection:
    """Tiles to draw for camera at a pixel tolerance tau (seed 002's TRAVERSE, balanced).

    Contract: every point of the grid surface inside the frustum lies on a drawn tile whose
    surface is within tau pixels of it vertically (the bound errs high: it assumes the worst
    direction and the nearest point of the box). Finest tiles cannot refine: where one with a
    reduced side would be over tau, its coarser neighbour is subdivided instead
    (quadtree.unreduce_finest). cull=False draws tiles outside the frustum too.
    """
    _, lam = pixel_scale(camera, resolution)
    planes = camera.frustum_planes()
    pyramid.frame += 1
    cells = pyramid.heightmap.size - 1
    spacing = pyramid.heightmap.spacing
    tested = quadtree.refine(cells, spacing, pyramid.flat_hmin, pyramid.flat_error,
                             pyramid.flat_hmin, pyramid.flat_hmax, pyramid.offsets,
                             pyramid.levels, pyramid.stamp, pyramid.frame, camera.eye, planes,
                             quadtree.BOUND, lam, float(tau), cull, pyramid.lists, pyramid.counts)
    if pyramid.levels > 0 and quadtree.unreduce_finest(
            cells, spacing, pyramid.levels, pyramid.offsets, pyramid.stamp, pyramid.frame,
            pyramid.lists, pyramid.counts, pyramid.flat_error, pyramid.flat_hmin,
            pyramid.flat_hmax, camera.eye, planes, lam, float(tau), cull):
        quadtree.balance(pyramid.offsets, pyramid.levels, pyramid.stamp, pyramid.frame,
                         pyramid.lists, pyramid.counts)
    count, total = quadtree.leaves(cells, spacing, pyramid.flat_hmin, pyramid.flat_hmax,
                                   pyramid.offsets, pyramid.levels, pyramid.stamp, pyramid.frame,
                                   planes, cull, pyramid.out)
    rows = pyramid.out[:count]
    return TileSelection(rows[:, 0].copy(), rows[:, 1].copy(), rows[:, 2].copy(),
                         rows[:, 3].copy(), int(pyramid.template_counts[rows[:, 3]].sum()),
                         int(total), int(tested))


def full_selection(pyramid: TilePyramid, camera=None) -> TileSelection:
    """Every finest tile (the full-resolution mesh), frustum-culled when a camera is given."""
    m = 1 << pyramid.levels
    i, j = np.divmod(np.arange(m * m, dtype=np.int64), m)
    tested = 0
    if camera is not None:
        boxes = pyramid.tile_boxes(pyramid.levels, i, j)
        keep = ~classify_boxes(boxes, camera.frustum_planes())[0]
        tested = len(i)
        i, j = i[keep], j[keep]
    sides = np.zeros(len(i), dtype=np.int64)
    return TileSelection(np.full(len(i), pyramid.levels, dtype=np.int64), i, j, sides,
                         int(len(i) * len(pyramid.templates[0])), m * m, tested)


def selection_mesh(pyramid: TilePyramid, selection: TileSelection) -> tuple:
    """Grid coordinates and triangles of a selection.

    Returns (rows (K, V) int64, cols (K, V) int64 sample coordinates of each tile's
    V = (P+1)^2 local vertices, triangles list of K (T_k, 3) int32 local index arrays).
    """
    n = pyramid.patch + 1
    a, b = np.divmod(np.arange(n * n), n)
    stride = (1 << (pyramid.levels - selection.level))[:, None]
    origin_r = (selection.ti * pyramid.patch)[:, None] * stride
    origin_c = (selection.tj * pyramid.patch)[:, None] * stride
    rows = origin_r + a[None] * stride
    cols = origin_c + b[None] * stride
    return rows, cols, [pyramid.templates[s] for s in selection.sides]


def selection_heights(pyramid: TilePyramid, selection: TileSelection) -> np.ndarray:
    """(N, N) float64 height of the drawn surface at every sample (NaN where nothing is drawn)."""
    rows, cols, _ = selection_mesh(pyramid, selection)
    return lod_heights(pyramid.heightmap.heights.astype(np.float64), rows, cols,
                       selection.sides, pyramid.templates)


def drop_hidden(pyramid: TilePyramid, selection: TileSelection, horizon) -> TileSelection:
    """The selection without tiles whose box the horizon hides (seed 001 as a terrain occluder).

    Conservative for the drawn surface when the horizon was cast with lower >= the largest
    error of the selected tiles (the drawn ground may sink that far below the samples). A
    terrain with no-data samples keeps every tile: a horizon cast over its samples knows no
    holes (terrain/ground.py stops the bands at the drawn cuts; this one cannot).
    """
    if not len(selection.level) or pyramid.heightmap.valid is not None:
        return selection
    boxes = np.concatenate([pyramid.tile_boxes(int(l), selection.ti[selection.level == l],
                                               selection.tj[selection.level == l])
                            for l in np.unique(selection.level)])
    order = np.concatenate([np.flatnonzero(selection.level == l)
                            for l in np.unique(selection.level)])
    keep = np.ones(len(selection.level), dtype=bool)
    keep[order[horizon.hidden(boxes)]] = False
    sides = selection.sides[keep]
    return TileSelection(selection.level[keep], selection.ti[keep], selection.tj[keep], sides,
                         int(pyramid.template_counts[sides].sum()), selection.leaves,
                         selection.tested)


def selection_error(pyramid: TilePyramid, selection: TileSelection) -> float:
    """Largest vertical error E (world units) among the selected tiles (0 when empty)."""
    if not len(selection.level):
        return 0.0
    return float(pyramid.flat_error[pyramid.offsets[selection.level]
                                    + selection.ti * (1 << selection.level) + selection.tj].max())

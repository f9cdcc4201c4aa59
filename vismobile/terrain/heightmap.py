"""The heightmap: (2^n+1)^2 uint16 samples on a square grid, with their metric scale.

Grid convention (every terrain module uses it): sample (i, j) sits at world
x = j * spacing, z = i * spacing, y = z_offset + z_scale * samples[i, j]. Cell (i, j) is cut
along the diagonal (i, j)-(i+1, j+1) into (i, j)(i+1, j+1)(i, j+1) and (i, j)(i+1, j)(i+1, j+1),
both counter-clockwise seen from +y.
"""
from __future__ import annotations

import hashlib
from dataclasses import dataclass, field

import numpy as np

from ..errors import WorldError

MAX_LEVEL = 13  # 8193^2 samples; a 4097^2 map (n = 12) is the largest the issue asks for


def grid_exponent(size: int) -> int | None:
    """n when size == 2^n + 1 (n >= 1), else None."""
    n = int(size - 1).bit_length() - 1
    return n if size >= 3 and (1 << n) + 1 == size else None


@dataclass(eq=False)
class Heightmap:
    """A square terrain of (2^n+1)^2 samples.

    samples  : (N, N) uint16, N = 2^n + 1, row i = world z, column j = world x
    spacing  : world units between neighbouring samples (> 0)
    z_scale  : world units per sample step (> 0); z_offset: world height of sample 0
    name     : where it came from (shown by info and in reports)
    valid    : (N, N) bool, False where the source had no data (seed 002's holes), or None
               when every sample is valid; the samples there hold a fill (fill_holes) that no
               render shows (the renderers cut holes with an alpha test, render/terrain.py)
    """

    samples: np.ndarray
    spacing: float = 1.0
    z_scale: float = 1.0
    z_offset: float = 0.0
    name: str = "terrain"
    valid: np.ndarray | None = None
    _heights: np.ndarray | None = field(default=None, repr=False)

    def __post_init__(self):
        self.samples = np.ascontiguousarray(self.samples, dtype=np.uint16)
        size = self.samples.shape[0]
        if self.samples.ndim != 2 or self.samples.shape[1] != size or grid_exponent(size) is None:
            raise ValueError(f"heightmap must be (2^n+1)^2 samples, got {self.samples.shape}")
        if grid_exponent(size) > MAX_LEVEL:
            raise ValueError(f"heightmap of {size}^2 samples exceeds 2^{MAX_LEVEL}+1")
        for name in ("spacing", "z_scale"):
            value = float(getattr(self, name))
            if not (np.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be finite and positive, got {value}")
            setattr(self, name, value)
        self.z_offset = float(self.z_offset)
        if not np.isfinite(self.z_offset):
            raise ValueError("z_offset must be finite")
        if self.valid is not None:
            self.valid = np.ascontiguousarray(self.valid, dtype=bool)
            if self.valid.shape != self.samples.shape:
                raise ValueError(f"valid mask {self.valid.shape} does not match the samples "
                                 f"{self.samples.shape}")
            if self.valid.all():
                self.valid = None
            elif not self.valid.any():
                raise ValueError("no sample is valid")

    @property
    def holes(self) -> bool:
        """True when some samples have no data."""
        return self.valid is not None

    @property
    def size(self) -> int:
        """N, samples per side."""
        return self.samples.shape[0]

    @property
    def exponent(self) -> int:
        """n with N = 2^n + 1."""
        return grid_exponent(self.size)

    @property
    def heights(self) -> np.ndarray:
        """(N, N) float32 world heights (computed once; float32 is exact for 16-bit samples
        times a power-of-two scale and within 2^-24 relative otherwise)."""
        if self._heights is None:
            self._heights = (self.z_offset + self.z_scale * self.samples.astype(np.float64)
                             ).astype(np.float32)
        return self._heights

    @property
    def extent(self) -> float:
        """World width of the square, (N - 1) * spacing."""
        return (self.size - 1) * self.spacing

    def bounds(self) -> np.ndarray:
        """(2, 3) float64 world box of the whole terrain."""
        low = self.z_offset + self.z_scale * float(self.samples.min())
        high = self.z_offset + self.z_scale * float(self.samples.max())
        return np.array([[0.0, low, 0.0], [self.extent, high, self.extent]])

    def height_at(self, x, z, alternating: bool = False) -> np.ndarray:
        """Heights of the full-resolution mesh at world points (x, z) (arrays of one shape).

        Interpolates on the mesh's own triangles (diagonal (i, j)-(i+1, j+1)), so it is the
        exact surface the full render draws; points outside the square are clamped onto it.
        alternating: the 4-8 mesh of Röttger's finest fans instead (cells with i + j odd use
        the other diagonal, (i, j+1)-(i+1, j)).
        """
        h = self.heights
        u = np.clip(np.asarray(x, dtype=np.float64) / self.spacing, 0, self.size - 1)
        v = np.clip(np.asarray(z, dtype=np.float64) / self.spacing, 0, self.size - 1)
        j = np.minimum(np.floor(u).astype(np.int64), self.size - 2)
        i = np.minimum(np.floor(v).astype(np.int64), self.size - 2)
        fu, fv = u - j, v - i
        if alternating:
            # Mirror odd cells left-right: their diagonal becomes the grid's.
            odd = (i + j) % 2 == 1
            h00, h11 = np.where(odd, h[i, j + 1], h[i, j]), np.where(odd, h[i + 1, j], h[i + 1, j + 1])
            h01, h10 = np.where(odd, h[i, j], h[i, j + 1]), np.where(odd, h[i + 1, j + 1], h[i + 1, j])
            fu = np.where(odd, 1 - fu, fu)
            h00, h11 = h00.astype(np.float64), h11.astype(np.float64)
            upper = fu >= fv
            h_side = np.where(upper, h01, h10).astype(np.float64)
            a, b = np.where(upper, fu, fv), np.where(upper, fv, fu)
            return h00 + (a - b) * (h_side - h00) + b * (h11 - h00)
        h00, h11 = h[i, j].astype(np.float64), h[i + 1, j + 1].astype(np.float64)
        upper = fu >= fv  # triangle (i,j)(i+1,j+1)(i,j+1)
        h_side = np.where(upper, h[i, j + 1], h[i + 1, j]).astype(np.float64)
        a, b = np.where(upper, fu, fv), np.where(upper, fv, fu)
        return h00 + (a - b) * (h_side - h00) + b * (h11 - h00)

    def digest(self) -> bytes:
        """32-byte SHA-256 of samples and scale (files and caches refuse another terrain)."""
        h = hashlib.sha256()
        h.update(np.ascontiguousarray(self.samples, "<u2").tobytes())
        h.update(np.array([self.spacing, self.z_scale, self.z_offset], "<f8").tobytes())
        if self.valid is not None:
            h.update(np.packbits(self.valid).tobytes())
        return h.digest()


def sample_heights(samples, z_scale: float, z_offset: float) -> np.ndarray:
    """Heightmap.heights of some samples (a few rows of a grid not held whole): float32
    (z_offset + z_scale * sample), the same arithmetic."""
    return (z_offset + z_scale * samples.astype(np.float64)).astype(np.float32)


def fill_holes(heights, valid) -> np.ndarray:
    """(N, N) float64 heights with every invalid sample set to the nearer valid sample along
    its row (ties: the earlier), then along its column for rows without one; what is left
    (nothing, when any sample is valid) takes the lowest valid height. O(N^2), no iteration:
    the fill only keeps vertical errors near a hole's rim moderate, it is never drawn."""
    h = np.array(heights, dtype=np.float64)
    valid = np.asarray(valid, dtype=bool)
    filled = valid.copy()
    for axis in (1, 0):
        view_h = h if axis == 1 else h.T
        view_v = filled if axis == 1 else filled.T
        n = view_h.shape[1]
        index = np.arange(n)[None, :]
        last = np.maximum.accumulate(np.where(view_v, index, -1), axis=1)
        after = np.minimum.accumulate(np.where(view_v, index, n)[:, ::-1], axis=1)[:, ::-1]
        rows = np.arange(view_h.shape[0])[:, None]
        use_last = (last >= 0) & ((after >= n) | (index - last <= after - index))
        use_after = ~use_last & (after < n)
        pick = np.where(use_last, last, np.where(use_after, after, 0))
        value = view_h[rows, pick]
        fill = ~view_v & (use_last | use_after)
        view_h[fill] = value[fill]
        view_v |= fill
    if not filled.all():
        h[~filled] = h[valid].min()
    return h


def quantize(heights, spacing: float = 1.0, name: str = "terrain", path="<array>") -> Heightmap:
    """Heightmap of float heights (N, N), N = 2^n+1, stored as uint16 over their range.

    The quantisation step is (max - min) / 65535 (at most half a step of error, reported by
    Heightmap.heights being the stored values, not the input). NaN marks no data (seed 002's
    holes: Heightmap.valid, filled by fill_holes). Raises WorldError naming path on infinite
    input, input with no valid sample, or a shape that is not (2^n+1)^2.
    """
    heights = np.asarray(heights, dtype=np.float64)
    if heights.ndim != 2 or heights.shape[0] != heights.shape[1] or grid_exponent(heights.shape[0]) is None:
        raise WorldError(path, f"heights must be (2^n+1)^2 samples, got shape {heights.shape}")
    valid = ~np.isnan(heights)
    if np.isinf(heights).any():
        raise WorldError(path, "heights contain infinite values")
    if not valid.any():
        raise WorldError(path, "heights hold no valid sample (all no-data)")
    if not valid.all():
        heights = fill_holes(heights, valid)
    low, high = float(heights.min()), float(heights.max())
    scale = (high - low) / 65535.0 if high > low else 1.0
    samples = np.rint((heights - low) / scale).astype(np.uint16)
    return Heightmap(samples, spacing, scale, low, name, valid if not valid.all() else None)

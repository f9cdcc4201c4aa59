"""Where heightmaps come from: matplotlib's two DEMs, user files and diamond-square terrain.

Every source returns a Heightmap of (2^n+1)^2 samples; inputs of another size are resampled
bilinearly onto that grid over the same extent (the spacing grows or shrinks to match).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import WorldError
from .heightmap import MAX_LEVEL, Heightmap, grid_exponent, quantize

# matplotlib sample DEMs: file, array key, metres per sample (3 arc-seconds ~ 92.6 m north-south
# for jacksboro; topobathy is a 1 arc-minute grid, ~1852 m).
DEMS = {
    "jacksboro": ("jacksboro_fault_dem.npz", "elevation", 92.6),
    "topobathy": ("topobathy.npz", "topo", 1852.0),
}
SYNTHETIC = "fractal"
# A heightmap file's samples (a 4097^2 grid; float64 copies stay ~134 MB) and values.
MAX_FILE_SAMPLES = 4097 * 4097
MAX_HEIGHT = 1e12


def resample(heights, size: int) -> np.ndarray:
    """(size, size) float64 bilinear resampling of a 2-D array over the same extent.

    Corners map to corners, so a (2^n+1)^2 input of the requested size comes back unchanged.
    """
    heights = np.asarray(heights, dtype=np.float64)
    rows, cols = heights.shape
    if (rows, cols) == (size, size):
        return heights.copy()
    r = np.linspace(0.0, rows - 1, size)
    c = np.linspace(0.0, cols - 1, size)
    r0 = np.minimum(np.floor(r).astype(np.int64), max(rows - 2, 0))
    c0 = np.minimum(np.floor(c).astype(np.int64), max(cols - 2, 0))
    fr, fc = (r - r0)[:, None], (c - c0)[None, :]
    r1, c1 = np.minimum(r0 + 1, rows - 1), np.minimum(c0 + 1, cols - 1)
    top = heights[r0][:, c0] * (1 - fc) + heights[r0][:, c1] * fc
    bottom = heights[r1][:, c0] * (1 - fc) + heights[r1][:, c1] * fc
    return top * (1 - fr) + bottom * fr


FITS = ("pad", "resample")


def _to_grid(heights, size, spacing, name, path, fit="resample") -> Heightmap:
    """Heightmap of an arbitrary (R, C) array on a size^2 grid (default: the next 2^n+1).

    NaN marks no data (seed 002's holes, Heightmap.valid). fit "pad": the samples keep their
    spacing and every value (no detail resampled away) in the grid's first R rows and C
    columns, the rest is no data; "resample": bilinear onto the grid over the same extent
    (no-data samples filled first, the mask resampled and thresholded at one half).
    """
    heights = np.asarray(heights, dtype=np.float64)
    if heights.ndim != 2 or min(heights.shape) < 2:
        raise WorldError(path, f"a heightmap needs a 2-D array of at least 2x2, got {heights.shape}")
    if np.isinf(heights).any():
        raise WorldError(path, "heights contain infinite values")
    valid = ~np.isnan(heights)
    if not valid.any():
        raise WorldError(path, "heights hold no valid sample (all no-data)")
    if fit not in FITS:
        raise WorldError(path, f"fit must be one of {', '.join(FITS)}, got {fit!r}")
    longest = max(heights.shape)
    if size is None:
        size = (1 << int(np.ceil(np.log2(max(longest - 1, 2))))) + 1
    if grid_exponent(size) is None:
        raise WorldError(path, f"size must be 2^n+1, got {size}")
    if fit == "pad":
        if size < longest:
            raise WorldError(path, f"{heights.shape[0]:,}x{heights.shape[1]:,} samples do not "
                                   f"fit a {size}^2 grid unresampled; pass a larger --size or "
                                   "--fit resample")
        grid = np.full((size, size), np.nan)
        grid[:heights.shape[0], :heights.shape[1]] = heights
        return quantize(grid, spacing, name, path)
    # Keep the input's metric footprint: its longer side spans (longest - 1) * spacing.
    new_spacing = spacing * (longest - 1) / (size - 1)
    if valid.all():
        return quantize(resample(heights, size), new_spacing, name, path)
    from .heightmap import fill_holes

    grid = resample(fill_holes(heights, valid), size)
    grid[resample(valid.astype(np.float64), size) < 0.5] = np.nan
    return quantize(grid, new_spacing, name, path)


def dem(name: str, size: int | None = None) -> Heightmap:
    """One of matplotlib's sample DEMs ("jacksboro" or "topobathy"), resampled to size^2."""
    if name not in DEMS:
        raise WorldError(name, f"unknown DEM; known: {', '.join(DEMS)}")
    from matplotlib import cbook

    filename, key, metres = DEMS[name]
    with cbook.get_sample_data(filename) as data:
        heights = np.asarray(data[key], dtype=np.float64)
    return _to_grid(heights, size, metres, name, filename)


def diamond_square(size: int, seed: int = 0, roughness: float = 0.55,
                   relief: float = 0.25, spacing: float = 1.0) -> Heightmap:
    """Deterministic diamond-square (midpoint displacement) terrain of size^2 samples.

    roughness : amplitude ratio between successive octaves (0.5 = fractal dimension ~2.5)
    relief    : height range as a fraction of the map's width
    The same (size, seed, roughness, relief, spacing) always gives the same samples.
    """
    n = grid_exponent(size)
    if n is None:
        raise ValueError(f"size must be 2^n+1, got {size}")
    rng = np.random.default_rng(seed)
    h = np.zeros((size, size))
    h[::size - 1, ::size - 1] = rng.uniform(-1, 1, (2, 2))
    amplitude, step = 1.0, size - 1
    while step > 1:
        half = step // 2
        # Diamond step: centres of squares get the corner mean plus noise.
        corners = (h[0:-1:step, 0:-1:step] + h[0:-1:step, step::step]
                   + h[step::step, 0:-1:step] + h[step::step, step::step]) / 4
        h[half::step, half::step] = corners + amplitude * rng.uniform(-1, 1, corners.shape)
        # Square step: edge midpoints get the mean of their (up to) four neighbours.
        for r0, c0 in ((0, half), (half, 0)):
            rows, cols = np.arange(r0, size, step), np.arange(c0, size, step)
            rr, cc = np.meshgrid(rows, cols, indexing="ij")
            total, count = np.zeros(rr.shape), np.zeros(rr.shape)
            for dr, dc in ((-half, 0), (half, 0), (0, -half), (0, half)):
                r, c = rr + dr, cc + dc
                ok = (r >= 0) & (r < size) & (c >= 0) & (c < size)
                total[ok] += h[r[ok], c[ok]]
                count[ok] += 1
            h[rr, cc] = total / count + amplitude * rng.uniform(-1, 1, rr.shape)
        amplitude *= roughness
        step = half
    h = (h - h.min()) / max(np.ptp(h), 1e-12) * relief * (size - 1) * spacing
    return quantize(h, spacing, f"{SYNTHETIC}-{size}-s{seed}")


def load_file(path, size: int | None = None, spacing: float | None = 1.0,
              vertical: float = 1.0, fit: str = "pad", nodata: float | None = None) -> Heightmap:
    """A user heightmap: .npy (2-D numbers), 16-bit or 8-bit greyscale PNG, or TIFF (GeoTIFF:
    its GDAL_NODATA tag is the no-data value unless nodata is given, its pixel scale the
    spacing when spacing is None; read by geotiff.TiffRaster, so strips or tiles, deflate, LZW
    or packbits, predictors 2 and 3; PNG by Pillow).

    vertical scales sample values to world units; samples equal to nodata (or NaN) are no
    data, holes (Heightmap.valid); fit: "pad" (default: onto the next 2^n+1 grid, every sample
    kept, the padding no data) or "resample" (_to_grid). Raises WorldError naming the file when
    it is missing, unreadable or not a 2-D array of numbers.
    """
    path = Path(path)
    if not path.is_file():
        raise WorldError(path, "no such file (or not a regular file)")
    suffix = path.suffix.lower()
    try:
        if suffix == ".npy":
            heights = np.load(path, allow_pickle=False, mmap_mode="r")  # shape before data
            _check_shape(path, heights.shape, size)
            if heights.dtype.kind not in "uif":
                raise WorldError(path, f"heightmap values must be numbers, got dtype "
                                       f"{heights.dtype}")
            heights = np.array(heights)
        elif suffix in (".tif", ".tiff"):
            from .geotiff import TiffRaster

            with TiffRaster(path, 16 * MAX_FILE_SAMPLES) as raster:  # one strip of the largest
                _check_shape(path, raster.shape, size)
                nodata = raster.nodata if nodata is None else nodata
                spacing = raster.spacing if spacing is None else spacing
                heights = raster.rows(0, raster.shape[0])
        elif suffix == ".png":
            import warnings

            from PIL import Image

            with warnings.catch_warnings():
                warnings.simplefilter("ignore")  # PIL's bomb warning: the shape check decides
                with Image.open(path) as image:
                    _check_shape(path, image.size[::-1], size)
                    if image.mode not in ("I;16", "I;16B", "I;16L", "I", "L", "F"):
                        image = (image.convert("L") if image.mode in ("RGB", "RGBA", "P", "LA")
                                 else image)
                    heights = np.asarray(image)
        else:
            raise WorldError(path, "unknown heightmap format (use .npy, .png, .tif or .vmt)")
    except WorldError:
        raise
    except Exception as error:  # numpy and PIL raise many types for bad files
        raise WorldError(path, f"cannot read heightmap ({type(error).__name__}: {error})") from None
    if heights.dtype.kind not in "uif":
        raise WorldError(path, f"heightmap values must be numbers, got dtype {heights.dtype}")
    heights = np.array(heights, dtype=np.float64)
    spacing = 1.0 if spacing is None else float(spacing)
    if nodata is not None and np.isnan(nodata):
        nodata = None  # NaN is no data already
    if nodata is not None:
        heights[heights == float(nodata)] = np.nan
    with np.errstate(all="ignore"):
        heights *= float(vertical)
        beyond = not (np.abs(heights[~np.isnan(heights)]) <= MAX_HEIGHT).all()
    if beyond:
        raise WorldError(path, f"heights beyond +-{MAX_HEIGHT:g} world units or infinite "
                               "(after --vertical)")
    return _to_grid(heights, size, spacing, path.stem, path, fit)


def _check_shape(path, shape, size) -> None:
    """WorldError naming path, before its samples are read, when the file's shape cannot make a
    heightmap within MAX_FILE_SAMPLES and the grid's largest side (MAX_LEVEL)."""
    shape = tuple(int(n) for n in shape)
    if len(shape) != 2 or min(shape) < 2:
        raise WorldError(path, f"a heightmap needs a 2-D array of at least 2x2, got {shape}")
    rows, cols = shape
    if rows * cols > MAX_FILE_SAMPLES:
        raise WorldError(path, f"{rows:,}x{cols:,} samples, more than {MAX_FILE_SAMPLES:,}")
    largest = (1 << MAX_LEVEL) + 1
    if size is None and max(shape) > largest:
        raise WorldError(path, f"{rows:,}x{cols:,} samples: the longer side is beyond the "
                               f"largest grid ({largest:,}); pass --size")

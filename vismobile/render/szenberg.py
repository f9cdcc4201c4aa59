"""Szenberg's column ray caster (seed 001, 1997): terrain colour and depth per screen column,
with polygonal objects Z-buffered into the same image.

Camera (`LevelCamera`): the view direction is level; pitch is emulated by shifting the
projection plane vertically, `incl` pixel rows between the bottom row and the eye's row. So
every screen column is a vertical plane and the terrain is a 2D problem per column. The
frustum is glFrustum(-t, t, -2 t incl / W, 2 t (H - incl) / W, near, far) with t = tan(60/2)
by default, d_pk = W / (2 t) pixels from the eye to the plane.

Per column (Algorithm 1, floating horizon): march slices parallel to the screen at depths
z_i (the same for every column: the column's step is its ray direction scaled to advance one
slice along the view axis, so there is no fish-eye distortion); at each slice, take the ground
height h at the column's point; every row j not yet painted whose ray passes below the ground
there (eye_y + z_i m_j < h, m_j = (j + 1/2 - incl) / d_pk the row's slope) takes the ground's
colour at that point and the depth Prof[i], bottom to top, so each pixel is painted once,
near to far, and a column stops at the top row. Prof[i] = window depth of view depth z_i
under that frustum, (f - f n / z_i) / (f - n): one table for every column, eye and heading.

Ground: the same piecewise-linear surface the triangle renderer draws (cells cut along
(i, j)-(i+1, j+1); Szenberg's subvoxels interpolate bilinearly, which is not the triangle
render's surface), and the colour map is pre-lit (Szenberg's colours are): the renderer's
per-vertex lighting applied to each sample, interpolated on the same triangles, so a pixel's
colour is the one the Gouraud-shaded triangle render gives at the point its ray hits, up to
the slice spacing. Slices are geometric, z_{i+1} = z_i (1 + step), by default one pixel of
parallax for ground a unit away (step = 1 / d_pk); Szenberg's uniform 1-unit slices with a
step factor FATOR are `uniform=FATOR`.

Arithmetic: float64, or "fixed16.16" (fixed16.16 profiles; Szenberg ran in fixed point): the
ground, the positions and slopes in 16.16 raw int64 with products shifted right by 16 (the
device's multiply-high), no division in the loop (a row's ray height is eye_y + z_i m_j, and
the next row's slope is m_j + 1/d_pk, Szenberg's incremental form).

Objects are drawn by OpenGL into the item buffer with the same camera and composited by their
window depth against the terrain's depth image (GL's depth test "<", as when the terrain's
depth is loaded with glDrawPixels before the objects are drawn).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from .shaders import CLEAR_RGB, LIGHT_AMBIENT, LIGHT_DIFFUSE, LIGHT_DIRECTIONS, SCENE_AMBIENT


@dataclass(frozen=True)
class LevelCamera:
    """Szenberg's camera: level view, yaw in degrees (the engine's convention: 0 looks along
    -z), horizontal fov, resolution (W, H), incl rows from the bottom row to the eye's row."""

    position: tuple
    yaw: float
    resolution: tuple = (240, 320)
    incl: float = 160.0
    hfov: float = 60.0
    near: float = 0.1
    far: float = 1000.0

    @property
    def eye(self) -> np.ndarray:
        return np.array(self.position, dtype=np.float64)

    @property
    def d_pk(self) -> float:
        """Pixels from the eye to the projection plane (the seeds' lambda)."""
        return self.resolution[0] / (2 * math.tan(math.radians(self.hfov) / 2))

    def axes(self) -> tuple:
        """(forward, right) level unit vectors, (3,) float64."""
        yaw = math.radians(self.yaw)
        return (np.array([-math.sin(yaw), 0.0, -math.cos(yaw)]),
                np.array([math.cos(yaw), 0.0, -math.sin(yaw)]))

    def view_projection(self) -> np.ndarray:
        """(4, 4) float64 glFrustum(...) x look-at: the GL camera of the same image."""
        w, h = self.resolution
        n, f = self.near, self.far
        t = math.tan(math.radians(self.hfov) / 2)
        left, right = -n * t, n * t
        bottom, top = -n * 2 * t * self.incl / w, n * 2 * t * (h - self.incl) / w
        proj = np.array([[2 * n / (right - left), 0, (right + left) / (right - left), 0],
                         [0, 2 * n / (top - bottom), (top + bottom) / (top - bottom), 0],
                         [0, 0, -(f + n) / (f - n), -2 * f * n / (f - n)],
                         [0, 0, -1, 0]])
        fwd, rgt = self.axes()
        up = np.array([0.0, 1.0, 0.0])
        view = np.eye(4)
        view[0, :3], view[1, :3], view[2, :3] = rgt, up, -fwd
        view[:3, 3] = -view[:3, :3] @ self.eye
        return proj @ view

    def depths(self, step: float | None = None, uniform: float | None = None) -> np.ndarray:
        """(S,) float64 slice depths from near to far."""
        if uniform is not None:
            return np.arange(max(self.near, uniform), self.far, uniform)
        step = 1.0 / self.d_pk if step is None else step
        count = int(math.ceil(math.log(self.far / self.near) / math.log1p(step)))
        return self.near * (1 + step) ** np.arange(count + 1)

    def prof(self, depths) -> np.ndarray:
        """Szenberg's Prof table: window depth in [0, 1] of each slice depth."""
        n, f = self.near, self.far
        return (f - f * n / np.asarray(depths)) / (f - n)


def lit_colours(heightmap) -> np.ndarray:
    """(N, N, 3) float64 in [0, 1]: each sample's colour after the renderer's per-vertex
    lighting (render/shaders.py SHADED_VERTEX), Szenberg's pre-lit colour map."""
    from .terrain import terrain_vertices

    n = heightmap.size
    rows, cols = np.divmod(np.arange(n * n), n)
    records = terrain_vertices(heightmap, rows[None], cols[None])
    normal = records["normal"].astype(np.float64)
    colour = records["color"][:, :3].astype(np.float64) / 255.0
    light = np.full(len(normal), SCENE_AMBIENT)[:, None] * np.ones(3)
    for d, diffuse, ambient in zip(LIGHT_DIRECTIONS, LIGHT_DIFFUSE, LIGHT_AMBIENT):
        light = light + ambient + np.maximum(normal @ d, 0.0)[:, None] * diffuse
    return np.clip(colour * light, 0.0, 1.0).reshape(n, n, 3)


@njit(cache=True, inline="always")
def _ground(heights, lit, x, w, spacing, out_colour):
    """Height of the grid surface at world (x, w) and its interpolated colour (written to
    out_colour); NaN off the map."""
    n = heights.shape[0]
    c, r = x / spacing, w / spacing
    if not (0.0 <= c <= n - 1 and 0.0 <= r <= n - 1):
        return np.nan
    i = min(int(r), n - 2)
    j = min(int(c), n - 2)
    fr, fc = r - i, c - j
    if fc >= fr:  # triangle (i, j), (i, j+1), (i+1, j+1)
        a, b, d = 1.0 - fc, fc - fr, fr
        ia, ja, ib, jb = i, j, i, j + 1
    else:  # triangle (i, j), (i+1, j), (i+1, j+1)
        a, b, d = 1.0 - fr, fr - fc, fc
        ia, ja, ib, jb = i, j, i + 1, j
    for k in range(3):
        out_colour[k] = a * lit[ia, ja, k] + b * lit[ib, jb, k] + d * lit[i + 1, j + 1, k]
    return a * heights[ia, ja] + b * heights[ib, jb] + d * heights[i + 1, j + 1]


@njit(cache=True, inline="always")
def _next_crossing(origin, direction, z, spacing):
    """Smallest depth > z where origin + depth * direction crosses a multiple of spacing
    (inf when direction is 0)."""
    if direction == 0.0:
        return np.inf
    u = (origin + z * direction) / spacing
    k = np.floor(u) + 1.0 if direction > 0 else np.ceil(u) - 1.0
    return max((k * spacing - origin) / direction, z * (1 + 1e-15) + 1e-300)


@njit(cache=True)
def _cast(heights, lit, spacing, eye, forward, right, d_pk, incl, depths, prof, sky, colour,
          depth, slices_run, refine, near, far):
    """Fill colour (H, W, 3) float64 and depth (H, W) (row 0 = bottom) column by column.

    refine: the ground is also tested where the column's line crosses a row, a column or a
    cell diagonal (between two such points it is linear, so no ridge between slices is
    missed), and each painted pixel takes the colour and window depth of its ray's exact
    crossing, solved on the linear piece between the last point its ray passed above and the
    first it passed below (Szenberg's pixels take the slice's colour and Prof[i], up to one
    slice behind the ground, and a ridge crest between two slices is not seen)."""
    height, width = depth.shape
    sample = np.empty(3)
    before = np.empty(3)
    for k in range(width):
        xs = (k + 0.5 - width / 2) / d_pk
        dx = forward[0] + xs * right[0]
        dw = forward[2] + xs * right[2]
        j = 0
        z_prev, h_prev = 0.0, np.nan
        nx = _next_crossing(eye[0], dx, depths[0], spacing)
        nw = _next_crossing(eye[2], dw, depths[0], spacing)
        nd = _next_crossing(eye[0] - eye[2], dx - dw, depths[0], spacing)
        i = 0
        while i < depths.shape[0] and j < height:
            z = depths[i]
            at_slice = True
            if refine and i > 0:
                c = min(nx, nw, nd)
                if c < z:
                    z, at_slice = c, False
                    if c == nx:
                        nx = _next_crossing(eye[0], dx, c, spacing)
                    elif c == nw:
                        nw = _next_crossing(eye[2], dw, c, spacing)
                    else:
                        nd = _next_crossing(eye[0] - eye[2], dx - dw, c, spacing)
            h = _ground(heights, lit, eye[0] + z * dx, eye[2] + z * dw, spacing, sample)
            if not np.isnan(h):
                while j < height and eye[1] + z * (j + 0.5 - incl) / d_pk < h:
                    if refine and not np.isnan(h_prev):
                        slope = (j + 0.5 - incl) / d_pk
                        a = h_prev - (eye[1] + z_prev * slope)  # <= 0: the ray was above
                        b = h - (eye[1] + z * slope)            # > 0: now below
                        t = a / (a - b) if a < 0 else 0.0
                        hit = z_prev + t * (z - z_prev)
                        for c3 in range(3):
                            colour[j, k, c3] = before[c3] + t * (sample[c3] - before[c3])
                        depth[j, k] = (far - far * near / hit) / (far - near)
                    else:
                        for c3 in range(3):
                            colour[j, k, c3] = sample[c3]
                        depth[j, k] = prof[i]
                    j += 1
            z_prev, h_prev = z, h
            for c3 in range(3):
                before[c3] = sample[c3]
            if at_slice:
                i += 1
        slices_run[k] = i
        while j < height:
            for c3 in range(3):
                colour[j, k, c3] = sky[c3]
            depth[j, k] = 1.0
            j += 1


@njit(cache=True)
def _cast_fixed(heights, lit, spacing, eye, forward, right, inv_d, incl_slope, depths, prof,
                sky, colour, depth, slices_run):
    """_cast in 16.16 raw integers (heights, spacing, eye, axes, inv_d = 1/d_pk, the bottom
    row's slope incl_slope = (1/2 - incl)/d_pk, depths); colours stay float (a table)."""
    height, width = depth.shape
    n = heights.shape[0]
    limit = (n - 1) * spacing
    sample = np.empty(3)
    for k in range(width):
        xs = (2 * k + 1 - width) * inv_d // 2  # (k + 1/2 - W/2) / d_pk, raw
        dx = forward[0] + ((xs * right[0]) >> 16)
        dw = forward[2] + ((xs * right[2]) >> 16)
        j = 0
        m = incl_slope  # the current row's slope, raw
        for i in range(depths.shape[0]):
            z = depths[i]
            x = eye[0] + ((z * dx) >> 16)
            w = eye[2] + ((z * dw) >> 16)
            if x < 0 or w < 0 or x > limit or w > limit:
                continue
            c_raw, r_raw = (x << 16) // spacing, (w << 16) // spacing  # sample units, raw
            ci = min(c_raw >> 16, n - 2)
            ri = min(r_raw >> 16, n - 2)
            fc, fr = c_raw - (ci << 16), r_raw - (ri << 16)
            h00, h11 = heights[ri, ci], heights[ri + 1, ci + 1]
            if fc >= fr:
                hb = heights[ri, ci + 1]
                h = h00 + ((fc * (hb - h00)) >> 16) + ((fr * (h11 - hb)) >> 16)
                a, b, d = 65536 - fc, fc - fr, fr
                ib, jb = ri, ci + 1
            else:
                hb = heights[ri + 1, ci]
                h = h00 + ((fr * (hb - h00)) >> 16) + ((fc * (h11 - hb)) >> 16)
                a, b, d = 65536 - fr, fr - fc, fc
                ib, jb = ri + 1, ci
            for c in range(3):
                sample[c] = (a * lit[ri, ci, c] + b * lit[ib, jb, c]
                             + d * lit[ri + 1, ci + 1, c]) / 65536.0
            while j < height and eye[1] + ((z * m) >> 16) < h:
                for c in range(3):
                    colour[j, k, c] = sample[c]
                depth[j, k] = prof[i]
                j += 1
                m += inv_d
            if j >= height:
                slices_run[k] = i + 1
                break
        else:
            slices_run[k] = depths.shape[0]
        while j < height:
            for c in range(3):
                colour[j, k, c] = sky[c]
            depth[j, k] = 1.0
            j += 1


@dataclass
class ColumnImage:
    """One ray-cast frame: rgb (H, W, 3) uint8 and depth (H, W) float64 window depth in [0, 1]
    (1 = sky), row 0 = top as read from OpenGL; slices (W,) slices each column marched."""

    rgb: np.ndarray
    depth: np.ndarray
    slices: np.ndarray


class ColumnCaster:
    """Szenberg's renderer for one heightmap (pre-lit colour map built once).

    arithmetic: "float64" or "fixed16.16" (ColumnCaster.for_profile picks the profile's).
    """

    def __init__(self, heightmap, arithmetic: str = "float64"):
        if arithmetic not in ("float64", "fixed16.16"):
            raise ValueError(f"arithmetic must be float64 or fixed16.16, got {arithmetic!r}")
        self.heightmap = heightmap
        self.arithmetic = arithmetic
        self.heights = heightmap.heights.astype(np.float64)
        self.lit = lit_colours(heightmap)
        if arithmetic == "fixed16.16":
            from ..device.profile import to_fixed

            # In cell units (Szenberg's EscalaZB: the world scaled by 1 / spacing, which
            # leaves the image unchanged), so a map's size, not its extent, must fit 16.16.
            unit = self.heights / heightmap.spacing
            to_fixed(np.array([0.0, unit.min(), unit.max(), heightmap.size - 1.0]),
                     f"terrain {heightmap.name}")  # range check
            self.heights_raw = np.floor(unit * 65536).astype(np.int64)

    @classmethod
    def for_profile(cls, heightmap, profile):
        return cls(heightmap, "fixed16.16" if profile.fixed else "float64")

    def render(self, camera: LevelCamera, step: float | None = None,
               uniform: float | None = None, refine: bool = False) -> ColumnImage:
        """Colour and depth of the terrain alone (sky where no ground).

        refine (float64 only): also test the ground where the column crosses grid lines, and
        give each pixel its ray's exact crossing (colour and depth); see _cast."""
        w, h = camera.resolution
        depths = camera.depths(step, uniform)
        colour = np.empty((h, w, 3))
        depth = np.empty((h, w))
        slices = np.zeros(w, np.int64)
        forward, right = camera.axes()
        sky = np.array(CLEAR_RGB, dtype=np.float64)
        if self.arithmetic == "fixed16.16":
            from ..device.profile import to_fixed

            def raw(v):
                return np.asarray(to_fixed(np.asarray(v, np.float64), "szenberg"), np.int64)

            unit = self.heightmap.spacing
            depths = np.unique(raw(depths[depths / unit <= 32767] / unit))
            prof = camera.prof(depths / 65536.0 * unit)
            _cast_fixed(self.heights_raw, self.lit, 65536, raw(camera.eye / unit),
                        raw(forward), raw(right), int(raw(1 / camera.d_pk)),
                        int(raw((0.5 - camera.incl) / camera.d_pk)), depths, prof, sky,
                        colour, depth, slices)
        else:
            _cast(self.heights, self.lit, self.heightmap.spacing, camera.eye, forward, right,
                  camera.d_pk, float(camera.incl), depths, camera.prof(depths), sky, colour,
                  depth, slices, bool(refine), camera.near, camera.far)
        rgb = np.rint(colour[::-1] * 255).astype(np.uint8)
        return ColumnImage(rgb, depth[::-1].copy(), slices)


def composite_objects(image: ColumnImage, renderer, vertices, triangles, camera,
                      first_id: int = 0) -> np.ndarray:
    """(H, W) uint32 ids of the objects' triangles that show in the ray-cast image (SENTINEL
    elsewhere): the objects drawn by OpenGL (item buffer, same camera) where their window depth
    is below the terrain's (GL's "<" test against the loaded depth image)."""
    from .renderer import SENTINEL

    renderer.draw_samples(np.zeros((0, 3), np.int64), camera, kind="item")  # clear
    renderer.draw_mesh_items(vertices, triangles, camera, first_id)
    ids = renderer.read_ids()
    object_depth = renderer.read_depth("item")
    shows = (ids != SENTINEL) & (object_depth < image.depth)
    return np.where(shows, ids, SENTINEL)

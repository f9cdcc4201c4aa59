"""Camera paths for any world: a collision-free walk at eye height through an indoor world's free
space, or a fly-over of an outdoor one, with waypoints where the camera sees most and least.

Free space is a grid over the world's x-z extent (GRID cells along the longer side). A cell is
blocked when a triangle meets its body box: the cell's square from knee height (a quarter of
the eye height above the floor, so floors and low steps do not block) to just above the eye
(exact triangle-box test, geometry/triangle_box.py); blocked cells are grown by the clearance.
A cell is covered when a triangle lies above its centre at eye height. A world is indoor when
most of the free cells are covered; the walk then stays in the largest connected region of
free covered cells (free cells otherwise). Waypoint targets are spread over that region by
farthest-point sampling from a seeded start, joined by shortest grid paths (8-neighbour, no
corner cutting), straightened where a sampled line of sight stays in free cells, and resampled
to the frame count at constant speed; the camera looks along the way (yaw smoothed). Every
segment lies in free cells, so it passes through no triangle. An outdoor world gets an
elliptical fly-over above its highest point, looking down at the world's centre.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from ..world.camera import yaw_toward
from ..errors import WorldError

GRID = 128          # cells along the longer horizontal side of the world
EYE_HEIGHT = 1.7    # world units above the floor (capped at half the world's height)
CLEARANCE = 0.3     # world units kept from every triangle (capped at 1/20 of the shorter side)
TARGETS = 6         # places the walk visits
MAX_PAIRS = 1 << 24  # (triangle, cell) pairs tested at most; beyond, the grid is coarsened
SAMPLED_FRAMES = 48  # frames whose item buffers count the visible triangles


@dataclass(eq=False)
class FreeSpace:
    """The walkable grid: cell (i, k) is the square low + (i, k) * cell .. + cell in x-z."""

    low: np.ndarray      # (2,) x, z of the grid's corner
    cell: float
    eye: float           # eye y
    blocked: np.ndarray  # (nx, nz) bool, grown by the clearance
    covered: np.ndarray  # (nx, nz) bool

    def centre(self, cells) -> np.ndarray:
        """(K, 2) x, z of cell centres."""
        return self.low + (np.asarray(cells, float) + 0.5) * self.cell

    def index(self, xz) -> np.ndarray:
        """(K, 2) int cell of x-z points (clipped to the grid)."""
        cells = np.floor((np.asarray(xz, float) - self.low) / self.cell).astype(np.int64)
        return np.clip(cells, 0, np.array(self.blocked.shape) - 1)


def _cell_pairs(lo, hi):
    """(triangle index, i, k) of every cell in each triangle's inclusive cell range lo..hi."""
    span = hi - lo + 1
    counts = span[:, 0] * span[:, 1]
    tri = np.repeat(np.arange(len(lo)), counts)
    offset = np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)
    return tri, lo[tri, 0] + offset // span[tri, 1], lo[tri, 1] + offset % span[tri, 1]


def free_space(world, eye_height=None, clearance=None, grid=GRID) -> FreeSpace:
    """The blocked and covered cells of a world at eye height (see the module docstring)."""
    from ..geometry.triangle_box import triangles_overlap_boxes

    low3, high3 = world.extent
    size = high3 - low3
    floor = low3[1]
    eye = floor + (min(EYE_HEIGHT, 0.5 * size[1]) if eye_height is None else float(eye_height))
    horizontal = size[[0, 2]]
    clear = (min(CLEARANCE, 0.05 * horizontal.min()) if clearance is None else float(clearance))
    corners_xz = world.corners[:, :, [0, 2]]
    bounds = world.bounds
    band = (floor + 0.25 * (eye - floor), eye + 0.1 * (eye - floor))
    in_band = (bounds[:, 1, 1] >= band[0]) & (bounds[:, 0, 1] <= band[1])
    above = bounds[:, 1, 1] > eye
    while True:
        cell = max(float(horizontal.max()) / grid, 1e-12)
        shape = np.maximum(np.ceil(horizontal / cell).astype(np.int64), 1)
        low = low3[[0, 2]]
        lo = np.clip(np.floor((bounds[:, 0][:, [0, 2]] - low) / cell).astype(np.int64), 0,
                     shape - 1)
        hi = np.clip(np.floor((bounds[:, 1][:, [0, 2]] - low) / cell).astype(np.int64), 0,
                     shape - 1)
        spans = np.prod(hi - lo + 1, axis=1)
        if spans[in_band | above].sum() <= MAX_PAIRS or grid <= 16:
            break
        grid //= 2
    blocked = np.zeros(shape, bool)
    ids = np.flatnonzero(in_band)
    for chunk in np.array_split(ids, max(1, int(spans[ids].sum()) // (1 << 20) + 1)):
        tri, i, k = _cell_pairs(lo[chunk], hi[chunk])
        box_min = np.column_stack([low[0] + i * cell, np.full(len(i), band[0]), low[1] + k * cell])
        box_max = box_min + [cell, band[1] - band[0], cell]
        hit = triangles_overlap_boxes(world.corners[chunk[tri]], box_min, box_max)
        blocked[i[hit], k[hit]] = True
    covered = np.zeros(shape, bool)
    ids = np.flatnonzero(above)
    for chunk in np.array_split(ids, max(1, int(spans[ids].sum()) // (1 << 20) + 1)):
        tri, i, k = _cell_pairs(lo[chunk], hi[chunk])
        t = chunk[tri]
        point = np.column_stack([low[0] + (i + 0.5) * cell, low[1] + (k + 0.5) * cell])
        a, b, c = corners_xz[t, 0], corners_xz[t, 1], corners_xz[t, 2]
        det = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (c[:, 0] - a[:, 0]) * (b[:, 1] - a[:, 1])
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            u = ((point[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1])
                 - (c[:, 0] - a[:, 0]) * (point[:, 1] - a[:, 1])) / det
            v = ((b[:, 0] - a[:, 0]) * (point[:, 1] - a[:, 1])
                 - (point[:, 0] - a[:, 0]) * (b[:, 1] - a[:, 1])) / det
            y = world.corners[t, 0, 1] * (1 - u - v) + world.corners[t, 1, 1] * u \
                + world.corners[t, 2, 1] * v
            inside = (np.abs(det) > 0) & (u >= 0) & (v >= 0) & (u + v <= 1) & (y > eye)
        covered[i[inside], k[inside]] = True
    grow = int(np.ceil(clear / cell))
    grown = _dilate(_dilate(blocked, grow, 0), grow, 1)  # square dilation, axis by axis
    # The grid's border is the world's bounds: keep the clearance from it too.
    if grow:
        grown[:grow], grown[-grow:], grown[:, :grow], grown[:, -grow:] = True, True, True, True
    return FreeSpace(low, cell, float(eye), grown, covered)


def _dilate(mask, steps, axis) -> np.ndarray:
    """mask grown by `steps` cells both ways along one axis (no wrap-around)."""
    out = mask.copy()
    n = mask.shape[axis]
    for step in range(1, min(steps, n - 1) + 1):
        ahead = [slice(None)] * 2
        behind = [slice(None)] * 2
        ahead[axis], behind[axis] = slice(step, None), slice(None, -step)
        out[tuple(ahead)] |= mask[tuple(behind)]
        out[tuple(behind)] |= mask[tuple(ahead)]
    return out


@njit(cache=True)
def _bfs(free, start_i, start_k):
    """(nx, nz) int64 8-neighbour step distances from the start over free cells (-1:
    unreachable); a diagonal step needs both side cells free (no corner cutting)."""
    nx, nz = free.shape
    dist = np.full((nx, nz), -1, np.int64)
    queue = np.empty(nx * nz, np.int64)
    dist[start_i, start_k] = 0
    queue[0] = start_i * nz + start_k
    head, tail = 0, 1
    while head < tail:
        c = queue[head]
        head += 1
        i, k = c // nz, c % nz
        for di in range(-1, 2):
            for dk in range(-1, 2):
                if di == 0 and dk == 0:
                    continue
                a, b = i + di, k + dk
                if a < 0 or b < 0 or a >= nx or b >= nz or not free[a, b] or dist[a, b] >= 0:
                    continue
                if di != 0 and dk != 0 and not (free[i + di, k] and free[i, k + dk]):
                    continue
                dist[a, b] = dist[i, k] + 1
                queue[tail] = a * nz + b
                tail += 1
    return dist


def _descend(dist, goal):
    """Cells from the BFS start to goal, following decreasing distance (same moves as _bfs)."""
    path = [tuple(goal)]
    i, k = goal
    nx, nz = dist.shape
    while dist[i, k] > 0:
        for di, dk in ((-1, 0), (1, 0), (0, -1), (0, 1), (-1, -1), (-1, 1), (1, -1), (1, 1)):
            a, b = i + di, k + dk
            if 0 <= a < nx and 0 <= b < nz and dist[a, b] == dist[i, k] - 1 and (
                    di == 0 or dk == 0 or (dist[i + di, k] >= 0 and dist[i, k + dk] >= 0)):
                i, k = a, b
                break
        path.append((i, k))
    return path[::-1]


def _clear_line(space, free, a, b) -> bool:
    """True when points sampled at most a quarter cell apart from a to b (x-z) all lie in free
    cells. Errs toward clear by less than 0.09 cell: between two samples the line may cut a
    blocked cell's corner that deep (cell / (8 sqrt 2)); free_space grows the blocked cells by
    the clearance (at least one cell), which absorbs it."""
    steps = max(2, int(np.ceil(np.linalg.norm(b - a) / (space.cell / 4))) + 1)
    points = a + np.linspace(0, 1, steps)[:, None] * (b - a)
    cells = space.index(points)
    return bool(free[cells[:, 0], cells[:, 1]].all())


def _straighten(space, free, points) -> np.ndarray:
    """Greedy string pulling: from each kept point go on while the next point is in clear
    sight (about one sight test per point)."""
    kept, i = [points[0]], 0
    while i < len(points) - 1:
        j = i + 1
        while j + 1 < len(points) and _clear_line(space, free, points[i], points[j + 1]):
            j += 1
        kept.append(points[j])
        i = j
    return np.array(kept)


def _resample(points, frames) -> np.ndarray:
    """(frames, 2) points at constant spacing along a polyline."""
    lengths = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(points, axis=0), axis=1))]
    if lengths[-1] == 0:
        return np.repeat(points[:1], frames, axis=0)
    s = np.linspace(0, lengths[-1], frames)
    return np.column_stack([np.interp(s, lengths, points[:, d]) for d in range(2)])


def _smooth_yaw(xz, window) -> np.ndarray:
    """Yaw (degrees, 0 looks down -z, 90 down -x) along the path, smoothed over `window`."""
    ahead = np.gradient(xz, axis=0)
    still = np.linalg.norm(ahead, axis=1) == 0
    ahead[still] = [0.0, -1.0]
    yaw = np.unwrap(yaw_toward(ahead[:, 0], ahead[:, 1]), period=360.0)
    if window > 1 and len(yaw) > window:
        pad = np.r_[np.full(window, yaw[0]), yaw, np.full(window, yaw[-1])]
        yaw = np.convolve(pad, np.ones(window) / window, mode="same")[window:-window]
    return yaw


def walk(world, frames=600, seed=0, eye_height=None, clearance=None, targets=TARGETS):
    """(poses (frames, 5), kind "walk" or "fly-over", FreeSpace) for a world; WorldError when
    an indoor world has no free space at eye height."""
    space = free_space(world, eye_height, clearance)
    free = ~space.blocked
    indoor = free.any() and space.covered[free].mean() >= 0.5
    if not indoor:
        return _fly_over(world, frames, seed), "fly-over", space
    region = free & space.covered
    rng = np.random.default_rng(seed)
    cells = np.argwhere(region)
    start = cells[rng.integers(len(cells))]
    dist = _bfs(region, start[0], start[1])
    # The largest connected region: restart from a cell of the biggest component.
    remaining = region & (dist < 0)
    components = [(int((dist >= 0).sum()), start)]
    while remaining.any() and len(components) < 64:
        seed_cell = np.argwhere(remaining)[0]
        d = _bfs(region, seed_cell[0], seed_cell[1])
        components.append((int((d >= 0).sum()), seed_cell))
        remaining &= d < 0
    _, best = max(components, key=lambda c: c[0])
    if best is not start:
        dist = _bfs(region, best[0], best[1])
        reach = np.argwhere(dist >= 0)
        start = reach[rng.integers(len(reach))]
        dist = _bfs(region, start[0], start[1])
    reach = np.argwhere(dist >= 0)
    if len(reach) < 2:
        raise WorldError(world.name, "no free space at eye height to walk through (pass "
                         "--eye-height or --clearance)")
    # Farthest-point targets, visited in nearest-next order from the start.
    centres = space.centre(reach)
    chosen = [int(np.flatnonzero((reach == start).all(axis=1))[0])]
    nearest = np.linalg.norm(centres - centres[chosen[0]], axis=1)
    for _ in range(max(1, targets - 1)):
        chosen.append(int(np.argmax(nearest)))
        nearest = np.minimum(nearest, np.linalg.norm(centres - centres[chosen[-1]], axis=1))
    order, rest = [chosen[0]], chosen[1:]
    while rest:
        here = centres[order[-1]]
        nxt = min(rest, key=lambda c: np.linalg.norm(centres[c] - here))
        order.append(nxt)
        rest.remove(nxt)
    points = [space.centre([reach[order[0]]])]
    for a, b in zip(order[:-1], order[1:]):  # each leg a shortest path, straightened alone
        d = _bfs(region, reach[a][0], reach[a][1])
        points.append(_straighten(space, region, space.centre(_descend(d, reach[b])))[1:])
    points = np.concatenate(points)
    xz = _resample(points, frames)
    yaw = _smooth_yaw(xz, max(1, frames // 40))
    poses = np.column_stack([xz[:, 0], np.full(frames, space.eye), xz[:, 1], yaw,
                             np.zeros(frames)])
    return poses, "walk", space


def _fly_over(world, frames, seed) -> np.ndarray:
    """An ellipse over the world's x-z extent, above its top, looking at its centre."""
    low, high = world.extent
    centre = (low + high) / 2
    size = high - low
    rng = np.random.default_rng(seed)
    phase = rng.uniform(0, 2 * np.pi)
    turn = rng.choice([-1.0, 1.0])
    angle = phase + turn * np.linspace(0, 2 * np.pi, frames, endpoint=False)
    x = centre[0] + 0.4 * size[0] * np.cos(angle)
    z = centre[2] + 0.4 * size[2] * np.sin(angle)
    y = np.full(frames, high[1] + 0.15 * max(size[0], size[2], size[1], 1e-9))
    dx, dz = centre[0] - x, centre[2] - z
    yaw = np.unwrap(yaw_toward(dx, dz), period=360.0)
    pitch = -np.degrees(np.arctan2(y - centre[1], np.hypot(dx, dz)))
    return np.column_stack([x, y, z, yaw, pitch])


def counts(world, trajectory, profile, sampled=SAMPLED_FRAMES):
    """(in_frustum (F,) int64 triangles whose box meets the frustum, every frame;
    frames (S,) the sampled frames; visible (S,) int64 distinct ids in their item buffers)."""
    from ..render import item_buffer_renderer

    centre = world.bounds.mean(axis=1)
    half = (world.bounds[:, 1] - world.bounds[:, 0]) / 2
    in_frustum = np.empty(len(trajectory), np.int64)
    for f, camera in enumerate(trajectory.cameras(profile.aspect)):
        planes = camera.frustum_planes()  # a box is out when wholly behind one plane (exact
        inside = np.ones(len(centre), bool)  # up to rounding; errs inside)
        for n0, n1, n2, d in planes:  # elementwise: tiny BLAS products crawl on a busy machine
            inside &= (centre[:, 0] * n0 + centre[:, 1] * n1 + centre[:, 2] * n2 + d
                       + half[:, 0] * abs(n0) + half[:, 1] * abs(n1) + half[:, 2] * abs(n2)) >= 0
        in_frustum[f] = int(inside.sum())
    frames = np.unique(np.linspace(0, len(trajectory) - 1, min(sampled, len(trajectory)))
                       .round().astype(int))
    renderer = item_buffer_renderer(world, profile)
    ids = np.arange(world.triangle_count)
    from ..render import SENTINEL

    visible = np.array([len(np.unique(buffer[buffer != SENTINEL])) for buffer in
                        (renderer.render(ids, trajectory.camera(int(f), profile.aspect), False)
                         for f in frames)], np.int64)
    return in_frustum, frames, visible


def waypoints(in_frustum, frames, visible) -> dict:
    """{label: frame}: most_visible, least_visible (sampled frames), most_in_frustum,
    least_in_frustum (every frame), each on its own frame (the next extreme when taken)."""
    out, taken = {}, set()
    for label, values, where in (("most_visible", -visible, frames),
                                 ("least_visible", visible, frames),
                                 ("most_in_frustum", -in_frustum, np.arange(len(in_frustum))),
                                 ("least_in_frustum", in_frustum, np.arange(len(in_frustum)))):
        for i in np.argsort(values, kind="stable"):
            if int(where[i]) not in taken:
                out[label] = int(where[i])
                taken.add(int(where[i]))
                break
    return out


def generate_trajectory(world, frames=600, seed=0, profile="ipaq-hx2490b", eye_height=None,
                        clearance=None):
    """Trajectory of `frames` poses through a world (walk() then the waypoints from counts());
    what `vismobile trajectory generate` writes. profile: name or Profile whose screen counts
    the visible triangles."""
    from ..device.profile import Profile, get_profile
    from ..world.trajectory import Trajectory

    profile = profile if isinstance(profile, Profile) else get_profile(profile)
    poses, _, _ = walk(world, frames, seed, eye_height, clearance)
    trajectory = Trajectory(poses)
    trajectory.waypoints = waypoints(*counts(world, trajectory, profile))
    return trajectory

"""Ground truth: per-frame visible sets from the full world's item buffer, and a ray-cast check.

The truth of a frame is the set of triangle ids in the item buffer of the whole world rendered
at the profile's resolution (back faces culled when a back-face stage is active). On sampled
frames it is cross-checked against open3d's RaycastingScene, one ray through each pixel centre
(i + 0.5, j + 0.5), row 0 at the top, with the same camera model (Camera.basis, vertical fov,
near and far planes).
"""
from __future__ import annotations

import hashlib
import io
from pathlib import Path

import numpy as np

from ..open3d_import import raycast_primitive_ids
from ..world.world import World, atomic_write_bytes
from .metrics import SENTINEL, VisibleSet

# A ray re-cast past a back face moves on by this fraction of the hit distance (plus a floor).
_STEP_RELATIVE, _STEP_FLOOR = 1e-6, 1e-7
# Depths closer than this relative gap count as a tie between two triangles.
_TIE_RELATIVE = 1e-4


def camera_rays(camera, width: int, height: int) -> tuple:
    """Rays through the pixel centres of a width x height image, row 0 at the top.

    Returns origins (H*W, 3) float64 (all the eye) and directions (H*W, 3) float64 scaled so
    that direction . forward == 1: the ray parameter t is then the eye-space depth.
    """
    right, up, forward = camera.basis()
    tan_v = np.tan(np.radians(camera.fov) / 2.0)
    tan_h = tan_v * camera.aspect
    x = (2.0 * (np.arange(width) + 0.5) / width - 1.0) * tan_h
    y = (1.0 - 2.0 * (np.arange(height) + 0.5) / height) * tan_v
    xx, yy = np.meshgrid(x, y)                       # (H, W), row 0 top
    directions = (forward[None, :] + xx.reshape(-1, 1) * right[None, :]
                  + yy.reshape(-1, 1) * up[None, :])
    origins = np.broadcast_to(camera.eye, directions.shape).copy()
    return origins, directions


def plane_depths(world: World, ids: np.ndarray, origins: np.ndarray,
                 directions: np.ndarray) -> np.ndarray:
    """(R,) float64 ray parameter where each ray meets the plane of its triangle (nan if none).

    ids : (R,) int64 triangle ids, -1 allowed (gives nan).
    """
    ids = np.asarray(ids, dtype=np.int64)
    safe = np.where(ids >= 0, ids, 0)
    normals = world.normals[safe]
    anchor = world.vertices[world.triangles[safe, 0]]
    denominator = np.einsum("ij,ij->i", normals, directions)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.einsum("ij,ij->i", normals, anchor - origins) / denominator
    t[(ids < 0) | (denominator == 0)] = np.nan
    return t


def raycast_buffer(world: World, camera, width: int, height: int,
                   cull_back: bool = False, max_layers: int = 8) -> np.ndarray:
    """(H, W) uint32 ids of the first triangle hit by each pixel-centre ray; SENTINEL on a miss.

    Only hits at eye depth in [near, far] count, as with the raster's clip planes. With cull_back
    a ray that meets a back face (normal . direction >= 0) is re-cast just past it, up to
    max_layers times; rays still on a back face after that report SENTINEL.
    """
    origins, directions = camera_rays(camera, width, height)
    result = np.full(len(origins), -1, dtype=np.int64)
    # Start at the near plane: t counts eye depth because direction . forward == 1.
    start = np.full(len(origins), camera.near)
    active = np.arange(len(origins))
    for _ in range(max_layers):
        if len(active) == 0:
            break
        begin = origins[active] + start[active, None] * directions[active]
        ids = raycast_primitive_ids(world.vertices, world.triangles, begin, directions[active])
        depth = start[active] + plane_depths(world, ids, begin, directions[active])
        hit = (ids >= 0) & (depth <= camera.far)
        if cull_back:
            back = hit & (np.einsum("ij,ij->i", world.normals[np.maximum(ids, 0)],
                                    directions[active]) >= 0)
        else:
            back = np.zeros(len(active), dtype=bool)
        front = hit & ~back
        result[active[front]] = ids[front]
        # Move past the back face and cast again.
        step = np.maximum(np.abs(depth) * _STEP_RELATIVE, _STEP_FLOOR)
        start[active[back]] = depth[back] + step[back]
        active = active[back]
    buffer = np.where(result >= 0, result, np.int64(SENTINEL)).astype(np.uint32)
    return buffer.reshape(height, width)


def classify_disagreements(world: World, camera, raster: np.ndarray,
                           rays: np.ndarray) -> dict:
    """Why two (H, W) uint32 id buffers of the same view differ, pixel counts per cause.

    pixels      : total pixels
    agree       : pixels with the same id (background included)
    silhouette  : one buffer hits background, the other a triangle (pixel centre near an
                  outer edge: the raster's coverage rule against the exact ray)
    shared_edge : two triangles sharing a corner (the centre lies on or near their common edge,
                  where the raster's fill rule and the ray's edge test may pick either)
    coplanar    : two triangles in one plane sharing no corner, or exact duplicates
                  (overlapping faces: z-fighting)
    depth_tie   : two triangles met at depths within 1e-4 relative (depth-buffer precision)
    other       : anything else
    """
    height, width = raster.shape
    differ = np.flatnonzero(raster.ravel() != rays.ravel())
    counts = {"pixels": int(raster.size), "agree": int(raster.size - len(differ)),
              "silhouette": 0, "shared_edge": 0, "coplanar": 0, "depth_tie": 0, "other": 0}
    if len(differ) == 0:
        return counts
    a = raster.ravel()[differ].astype(np.int64)
    b = rays.ravel()[differ].astype(np.int64)
    background = (a == int(SENTINEL)) | (b == int(SENTINEL))
    counts["silhouette"] = int(background.sum())
    a, b, differ = a[~background], b[~background], differ[~background]
    if len(a) == 0:
        return counts
    corners_a, corners_b = world.corners[a], world.corners[b]            # (P, 3, 3)
    gap = np.linalg.norm(corners_a[:, :, None, :] - corners_b[:, None, :, :], axis=3)
    scale = np.linalg.norm(np.ptp(world.extent, axis=0)) + 1e-12
    corners_shared = (gap < 1e-9 * scale).any(axis=2).sum(axis=1)
    duplicate = corners_shared == 3
    shared = (corners_shared > 0) & ~duplicate
    n_a, n_b = world.normals[a], world.normals[b]
    parallel = np.abs(np.einsum("ij,ij->i", n_a, n_b)) > 1 - 1e-9
    offset = np.abs(np.einsum("ij,ij->i", n_a, corners_b[:, 0] - corners_a[:, 0]))
    coplanar = (parallel & (offset < 1e-7 * scale)) | duplicate
    origins, directions = camera_rays(camera, width, height)
    depth_a = plane_depths(world, a, origins[differ], directions[differ])
    depth_b = plane_depths(world, b, origins[differ], directions[differ])
    tie = np.abs(depth_a - depth_b) <= _TIE_RELATIVE * np.maximum(np.abs(depth_a), 1e-12)
    counts["shared_edge"] = int(shared.sum())
    counts["coplanar"] = int((coplanar & ~shared).sum())
    counts["depth_tie"] = int((tie & ~shared & ~coplanar).sum())
    counts["other"] = int((~tie & ~shared & ~coplanar).sum())
    return counts


def compare_truths(world: World, camera, raster: np.ndarray, cull_back: bool = False) -> dict:
    """Raster-against-ray-cast agreement for one view.

    Returns classify_disagreements' pixel counts plus: pixel_agreement (fraction), raster_ids and
    raycast_ids (visible set sizes), missed_by_raster and missed_by_rays (triangles one truth
    sees and the other does not) and missed_pixels_max (most pixels such a triangle covers).
    """
    height, width = raster.shape
    rays = raycast_buffer(world, camera, width, height, cull_back=cull_back)
    counts = classify_disagreements(world, camera, raster, rays)
    seen_raster = VisibleSet.from_buffer(raster)
    seen_rays = VisibleSet.from_buffer(rays)
    only_raster = ~np.isin(seen_raster.ids, seen_rays.ids)
    only_rays = ~np.isin(seen_rays.ids, seen_raster.ids)
    counts.update({
        "pixel_agreement": counts["agree"] / counts["pixels"],
        "raster_ids": int(len(seen_raster.ids)),
        "raycast_ids": int(len(seen_rays.ids)),
        "missed_by_rays": int(only_raster.sum()),
        "missed_by_raster": int(only_rays.sum()),
        "missed_pixels_max": int(max(seen_raster.pixels[only_raster].max(initial=0),
                                     seen_rays.pixels[only_rays].max(initial=0))),
    })
    return counts


# -- the per-trajectory truth, cached on disk --------------------------------------------------

def truth_key(world: World, poses: np.ndarray, frames, size, cull_back: bool) -> str:
    """16 hex digits naming a cached truth: world bytes, poses, frames, resolution, cull_back."""
    digest = hashlib.sha256(world.digest())
    digest.update(np.ascontiguousarray(poses, dtype=np.float64).tobytes())
    digest.update(np.asarray(frames, dtype=np.int64).tobytes())
    digest.update(f"{tuple(size)}:{bool(cull_back)}:v1".encode())
    return digest.hexdigest()[:16]


def save_truth(path, frames, sets) -> None:
    """Write a list of VisibleSets (one per frame) as one npz in CSR form, atomically."""
    offsets = np.concatenate([[0], np.cumsum([len(s.ids) for s in sets])]).astype(np.int64)
    buffer = io.BytesIO()
    np.savez_compressed(
        buffer, frames=np.asarray(frames, np.int64), offsets=offsets,
        ids=np.concatenate([s.ids for s in sets]) if sets else np.zeros(0, np.int64),
        pixels=np.concatenate([s.pixels for s in sets]) if sets else np.zeros(0, np.int64),
        totals=np.array([s.total for s in sets], np.int64))
    atomic_write_bytes(path, buffer.getvalue())


def load_truth(path) -> tuple:
    """(frames list, [VisibleSet]) from save_truth's file."""
    with np.load(path) as data:
        offsets = data["offsets"]
        sets = [VisibleSet(data["ids"][lo:hi], data["pixels"][lo:hi], int(total))
                for lo, hi, total in zip(offsets[:-1], offsets[1:], data["totals"])]
        return [int(f) for f in data["frames"]], sets


def trajectory_truth(world: World, cameras, frames, buffer_fn, size, poses,
                     cull_back: bool, cache_dir=None) -> list:
    """[VisibleSet] for the given frames, from buffer_fn(camera) -> (H, W) uint32 item buffer.

    cameras   : iterable of Camera, one per frame in `frames`
    cache_dir : optional folder; the truth is stored there under truth_key and reused.
    """
    path = None
    if cache_dir is not None:
        path = Path(cache_dir) / f"truth-{truth_key(world, poses, frames, size, cull_back)}.npz"
        if path.is_file():
            try:
                cached_frames, sets = load_truth(path)
                if cached_frames == list(frames):
                    return sets
            except (OSError, ValueError, KeyError):
                pass  # unreadable cache: recompute and overwrite
    sets = [VisibleSet.from_buffer(buffer_fn(camera)) for camera in cameras]
    if path is not None:
        save_truth(path, frames, sets)
    return sets

"""What a device in a given vertex format shows: the ground truth of the device proof obligation
(issue 17), shared by tests/culling/test_device_conservative.py and tools/conservative_sweep.py.

A triangle counts as shown when any of three item buffers shows it:
  device   the GPU drawing the world in the profile's vertex format (its float32 transform);
  rounded  the world and the eye rounded to that format, rendered relative to the eye (the
           rounding alone: float64 shift first, so the GPU's float32 adds no error of its own);
  exact    the float64 world rendered relative to the eye (the geometry alone).
"""
from __future__ import annotations

import numpy as np

from ..geometry import arithmetic
from .item_buffer import item_buffer
from .renderer import SENTINEL

KINDS = ("device", "rounded", "exact")


def eye_relative(world, camera, profile, cull_back: bool) -> np.ndarray:
    """(H, W) uint32 item buffer of `world` seen from `camera`, rendered relative to the eye
    (float64 shift first) in float32 vertices at the profile's resolution."""
    from ..device.profile import get_profile

    local = world.transformed(1.0, -camera.eye)
    at_origin = camera.with_(position=(0.0, 0.0, 0.0))
    return item_buffer(local, None, at_origin, get_profile(profile, "float32"),
                       cull_back=cull_back)


def device_buffers(world, camera, profile, cull_back: bool) -> dict:
    """{kind: (H, W) uint32 item buffer} for the KINDS above. Raises ProfileError when the
    profile's vertex format cannot hold or resolve the world or the eye."""
    fmt = profile.vertex_format
    eye = arithmetic.quantize(camera.eye, fmt, "camera position")
    return {"device": item_buffer(world, None, camera, profile, cull_back=cull_back),
            "rounded": eye_relative(world.quantized(fmt), camera.with_(position=eye),
                                    profile, cull_back),
            "exact": eye_relative(world, camera, profile, cull_back)}


def shown_ids(buffers: dict) -> np.ndarray:
    """(K,) int64 sorted ids any of the buffers shows."""
    ids = np.unique(np.concatenate([np.unique(b) for b in buffers.values()]))
    return ids[ids != SENTINEL].astype(np.int64)


def dropped_pixels(buffers: dict, dropped) -> int:
    """Pixels showing a dropped id, in the buffer where they are most (each buffer is one whole
    image, so their counts do not add)."""
    dropped = np.asarray(dropped, dtype=np.int64)
    if not len(dropped):
        return 0
    return max(int(np.isin(b, dropped).sum()) for b in buffers.values())

"""Regions of the direction sphere (yaw sectors x elevation bands) and caps that contain them.

Directions use the camera's convention: yaw 0 looks toward -z, yaw grows toward -x, elevation
is the angle above the xz plane, so forward(yaw, pitch) = (-sin y cos p, sin p, -cos y cos p).
"""
from __future__ import annotations

import numpy as np

from .angles import yaw_toward

# Boundary samples per region edge when bounding a region by a cap.
EDGE_SAMPLES = 129


def direction_regions(dirs, yaw_regions: int, pitch_bands: int) -> np.ndarray:
    """(N,) int32 region id = band * yaw_regions + sector of each direction; zero-length
    directions get id yaw_regions * pitch_bands (the "no region" id).

    dirs : (N, 3) float64, any length (only the direction matters)
    Sector k holds yaw in [k, k+1) * 360/yaw_regions degrees, band b elevation in
    [-90 + b, -90 + b + 1) * 180/pitch_bands degrees (the top band also holds +90).
    """
    dirs = np.asarray(dirs, dtype=np.float64)
    length = np.linalg.norm(dirs, axis=1)
    ok = length > 0
    unit = dirs / np.where(ok, length, 1.0)[:, None]
    yaw = yaw_toward(unit[:, 0], unit[:, 2]) % 360.0
    elev = np.degrees(np.arcsin(np.clip(unit[:, 1], -1.0, 1.0)))
    sector = np.minimum((yaw * yaw_regions / 360.0).astype(np.int64), yaw_regions - 1)
    band = np.clip(((elev + 90.0) * pitch_bands / 180.0).astype(np.int64), 0, pitch_bands - 1)
    ids = band * yaw_regions + sector
    return np.where(ok, ids, yaw_regions * pitch_bands).astype(np.int32)


def _directions(yaw_deg, elev_deg):
    y, e = np.radians(yaw_deg), np.radians(elev_deg)
    return np.stack([-np.sin(y) * np.cos(e), np.sin(e), -np.cos(y) * np.cos(e)], axis=-1)


def region_caps(yaw_regions: int, pitch_bands: int) -> tuple:
    """Spherical caps containing each region: (centers (R, 3) unit float64, radii (R,) radians).

    Errs large: the radius is the largest angle to a dense sample of the region's boundary
    plus the sample spacing plus 1e-9 rad, so every direction of the region is inside its cap.
    """
    wy, wb = 360.0 / yaw_regions, 180.0 / pitch_bands
    band, sector = np.divmod(np.arange(yaw_regions * pitch_bands), yaw_regions)
    y0, e0 = sector * wy, -90.0 + band * wb
    s = np.linspace(0.0, 1.0, EDGE_SAMPLES)
    ones, zeros = np.ones_like(s), np.zeros_like(s)
    # Four edges of each region: (R, 4 * S) yaw and elevation samples.
    yaw = np.concatenate([y0[:, None] + wy * s, y0[:, None] + wy * s,
                          y0[:, None] + zeros, y0[:, None] + wy * ones], axis=1)
    elev = np.concatenate([e0[:, None] + zeros, e0[:, None] + wb * ones,
                           e0[:, None] + wb * s, e0[:, None] + wb * s], axis=1)
    samples = _directions(yaw, elev)  # (R, 4S, 3)
    # The centre of the region itself (not of its boundary samples, which crowd at the poles).
    centers = _directions(y0 + wy / 2.0, e0 + wb / 2.0)
    cosines = np.clip(np.einsum("rsk,rk->rs", samples, centers), -1.0, 1.0)
    spacing = np.radians(max(wy, wb)) / (EDGE_SAMPLES - 1)
    radii = np.arccos(cosines.min(axis=1)) + spacing + 1e-9
    return centers, radii


def caps_within(centers, radii, rays) -> np.ndarray:
    """(R,) bool: every direction of each cap makes an angle <= 90 degrees with every ray
    (exact for caps; errs False by 1e-12).

    centers : (R, 3) unit float64;  radii : (R,) radians;  rays : (K, 3) float64, any length
    """
    rays = np.asarray(rays, dtype=np.float64)
    rays = rays / np.linalg.norm(rays, axis=1, keepdims=True)
    # angle(center, ray) + radius <= 90 deg  <=>  center . ray >= sin(radius), radius < 90 deg.
    need = np.where(radii < np.pi / 2, np.sin(np.minimum(radii, np.pi / 2)), np.inf)
    return ((centers @ rays.T) >= need[:, None] + 1e-12).all(axis=1)

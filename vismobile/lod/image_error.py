"""Image error of a frame against the full-detail frame with the same culling."""
from __future__ import annotations

import numpy as np


def image_error(reference, image) -> dict:
    """PSNR (dB, inf when equal), largest channel difference and fraction of pixels changed.

    reference, image : (H, W, 3) uint8 of the same shape
    Returns {"psnr_db": float, "max_diff": int (0..255), "changed": float (0..1)}.
    """
    a = np.asarray(reference, dtype=np.int16)
    b = np.asarray(image, dtype=np.int16)
    if a.shape != b.shape:
        raise ValueError(f"images differ in shape: {a.shape} and {b.shape}")
    diff = np.abs(a - b)
    mse = float(np.mean(diff.astype(np.float64) ** 2)) if diff.size else 0.0
    psnr = float("inf") if mse == 0 else 10.0 * np.log10(255.0 ** 2 / mse)
    changed = float(diff.reshape(-1, diff.shape[-1]).any(axis=1).mean()) if diff.size else 0.0
    return {"psnr_db": psnr, "max_diff": int(diff.max(initial=0)), "changed": changed}


def error_summary(psnr_db, max_diff, changed, tau) -> dict:
    """The level-of-detail block of a run's summary from its per-frame columns: lod_tau,
    psnr_db_min (the worst frame; None when every frame is identical), psnr_db_mean (PSNR of
    the mean squared error over the frames; None when all are identical), frames_identical,
    max_diff (largest over the frames) and changed_mean (mean fraction of pixels changed)."""
    psnr = np.asarray(psnr_db, dtype=np.float64)
    mse = np.where(np.isfinite(psnr), 255.0 ** 2 / 10.0 ** (psnr / 10.0), 0.0)
    mean_mse = float(mse.mean()) if len(mse) else 0.0
    finite = psnr[np.isfinite(psnr)]
    return {"lod_tau": float(tau),
            "psnr_db_min": float(finite.min()) if len(finite) else None,
            "psnr_db_mean": float(10.0 * np.log10(255.0 ** 2 / mean_mse)) if mean_mse > 0
            else None,
            "frames_identical": int(np.isinf(psnr).sum()),
            "max_diff": int(np.max(max_diff, initial=0)),
            "changed_mean": float(np.mean(changed)) if len(psnr) else 0.0}

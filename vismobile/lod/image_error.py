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

"""Scoring a disparity map against ground truth (Middlebury convention)."""
from __future__ import annotations

import numpy as np

from sim.model.validation import check_int, check_same_shape

__all__ = ["score_disparity"]


def score_disparity(disparity, ground_truth, gt_scale: float, *, max_error: float = 1.0,
                    exclude_left: int = 0) -> dict:
    """Percentages of good and invalid pixels.

    A pixel counts when its ground truth is known (``ground_truth > 0``). It
    is good when the disparity is valid (> 0) and within ``max_error`` pixels
    of ``ground_truth / gt_scale``; invalid pixels (0) count as wrong.

    Returns a dict with ``pct_good``, ``pct_invalid`` (both over the known
    pixels), ``known_pixels`` and, when ``exclude_left`` > 0,
    ``pct_good_excluding_left`` (the same score over columns >= exclude_left)
    and ``excluded_columns``.
    """
    disp = np.asarray(disparity)
    gt = np.asarray(ground_truth)
    check_same_shape(disparity=disp, ground_truth=gt)
    if disp.ndim != 2:
        raise ValueError(f"disparity must be a 2-D map, got shape {disp.shape}")
    if not (np.isfinite(gt_scale) and gt_scale > 0):
        raise ValueError(f"gt_scale must be a positive number, got {gt_scale}")
    exclude_left = check_int("exclude_left", exclude_left, 0, disp.shape[1] - 1)
    known = gt > 0
    if not known.any():
        raise ValueError("ground_truth has no known pixel (all 0)")
    truth = gt.astype(np.float64) / gt_scale
    valid = disp > 0
    good = known & valid & (np.abs(disp.astype(np.float64) - truth) <= max_error)
    n_known = int(known.sum())
    result = {
        "pct_good": round(100.0 * good.sum() / n_known, 3),
        "pct_invalid": round(100.0 * (known & ~valid).sum() / n_known, 3),
        "known_pixels": n_known,
    }
    if exclude_left:
        inner = known.copy()
        inner[:, :exclude_left] = False
        result["pct_good_excluding_left"] = round(
            100.0 * (good & inner).sum() / max(1, int(inner.sum())), 3)
        result["excluded_columns"] = exclude_left
    return result

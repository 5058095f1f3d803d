"""Scoring a disparity map against ground truth (Middlebury convention)."""
from __future__ import annotations

import numpy as np

from sim.model.validation import check_int, check_same_shape

__all__ = ["score_disparity", "misaligned_scores", "MISALIGNMENT", "remap_errors", "track_errors"]


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


#: The misalignment :func:`misaligned_scores` gives each camera by default:
#: roll (degrees) and image shift (pixels), as :func:`sim.model.rectify.misalignment`.
MISALIGNMENT = {"left": dict(roll=0.5, shift_x=0.3, shift_y=1.0),
                "right": dict(roll=-0.4, shift_x=-0.2, shift_y=-0.8)}


def misaligned_scores(left, right, ground_truth, gt_scale: float, *, matcher: dict,
                      misalignment: dict = MISALIGNMENT, grid_step: int = 8,
                      frac_bits: int = 5, interpolation: str = "bilinear") -> dict:
    """pct_good of a rectified pair (``left``, ``right``, grey) and of the same pair
    as a misaligned rig sees it (each camera warped by ``misalignment``, Lanczos,
    black outside), unrectified, rectified by the model's compressed maps and
    rectified by ``cv2.remap`` with the full float maps. ``matcher``: the
    :func:`sim.model.stereo.stereo_match` parameters, ``census_window`` and
    ``hamming_window`` among them.

    Every score counts the same pixels: known ground truth, and whose matching
    windows (radius Wc // 2 + Wh // 2) lie wholly in what both misaligned cameras
    saw (a pixel whose source lies outside either camera's picture is lost to
    any rectification, and so is the match of a window that reaches it)."""
    import cv2

    from sim.model.rectify import (compress_map, homography_maps, map_size, misalignment as
                                   camera_warp, rectify)
    from sim.model.stereo import stereo_match

    h, w = np.shape(left)
    ndisp = matcher["max_disparity"]

    cameras, model, oracle = [], [], []
    inside = np.ones((h, w), bool)
    for image, side in ((left, "left"), (right, "right")):
        hom = camera_warp(w, h, **misalignment[side])
        seen = cv2.warpPerspective(np.ascontiguousarray(image, np.uint8), hom, (w, h),
                                   flags=cv2.INTER_LANCZOS4, borderMode=cv2.BORDER_CONSTANT)
        # the camera pixel each rectified pixel comes from, and back: inside both ways
        sx, sy = homography_maps(hom, w, h)
        inside &= (sx >= 0) & (sx <= w - 1) & (sy >= 0) & (sy <= h - 1)
        back_x, back_y = homography_maps(np.linalg.inv(hom), w, h)
        inside &= (back_x >= 0) & (back_x <= w - 1) & (back_y >= 0) & (back_y <= h - 1)
        cameras.append(seen)
        grid = compress_map(*homography_maps(hom, *map_size(w, h, grid_step)), w, h,
                            grid_step=grid_step, frac_bits=frac_bits)
        model.append(rectify(seen, grid, interpolation))
        oracle.append(cv2.remap(seen, *homography_maps(hom, w, h), cv2.INTER_LINEAR,
                                borderMode=cv2.BORDER_CONSTANT))
    radius = matcher["census_window"] // 2 + matcher["hamming_window"] // 2
    inside = cv2.erode(inside.astype(np.uint8), np.ones((2 * radius + 1,) * 2, np.uint8),
                       borderValue=1).astype(bool)      # the frame's own edges stay
    truth = np.where(inside, ground_truth, 0)

    def score(a, b):
        disp = stereo_match(a, b, **matcher).disparity
        return score_disparity(disp, truth, gt_scale, exclude_left=ndisp)

    return {"original": score(left, right), "unrectified": score(*cameras),
            "rectified": score(*model), "rectified_cv2": score(*oracle),
            "seen_pixels_pct": round(100.0 * float(inside.mean()), 2)}


def remap_errors(image, homography, *, grid_step: int = 8, frac_bits: int = 5):
    """The rectification model against its oracle, ``cv2.remap`` with the full float
    maps of ``homography`` (bilinear, black outside): the absolute grey-level
    errors away from the border (4 px) and each pixel's distance (pixels) from
    the interpolated map's source position to the full map's."""
    import cv2

    from sim.model.rectify import (compress_map, homography_maps, map_size, rectify,
                                   source_positions)
    h, w = np.shape(image)
    grid = compress_map(*homography_maps(homography, *map_size(w, h, grid_step)), w, h,
                        grid_step=grid_step, frac_bits=frac_bits)
    full_x, full_y = homography_maps(homography, w, h)
    oracle = cv2.remap(np.ascontiguousarray(image, np.uint8), full_x, full_y, cv2.INTER_LINEAR,
                       borderMode=cv2.BORDER_CONSTANT, borderValue=0)
    grey = np.abs(rectify(image, grid).astype(int) - oracle.astype(int))[4:-4, 4:-4]
    sx, sy = source_positions(grid)
    one = 1 << frac_bits
    return grey, np.hypot(sx / one - full_x, sy / one - full_y)


def track_errors(truth_xy, trajectory) -> dict:
    """A clip's tracking against its rendered truth: the centroid error (pixels;
    mean and 95th percentile over the frames where both the truth and a hand
    exist, None without such frames), those frames' count and the number of
    flagged spans (0: the gesture was missed; 2 or more: split)."""
    truth = np.asarray(truth_xy, float)
    seen = (np.asarray(trajectory.area) > 0) & np.isfinite(truth[:, 0])
    error = np.hypot(*(np.asarray(trajectory.centroid)[seen] - truth[seen]).T)
    flag = np.asarray(trajectory.flag, bool)
    spans = int(np.sum(flag[1:] & ~flag[:-1]) + (1 if flag.size and flag[0] else 0))
    return {"centroid_error_mean": round(float(error.mean()), 2) if error.size else None,
            "centroid_error_p95": round(float(np.percentile(error, 95)), 2)
            if error.size else None,
            "hand_frames": int(seen.sum()), "flag_spans": spans}

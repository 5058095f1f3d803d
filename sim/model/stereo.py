"""The stereo matcher as one function: thesis §6.2 (Figs. 44-56) plus the
median of the disparity map (§6 introduction).

Stages, in stream order::

    [3x3 median of each input image]  (camera pipeline only, §6.1)
    sparse census (Wc)                 census.sparse_census
    Hamming distance + SHD (Wh, D)     matching.disparity_maps
    best-of selectors L2R and R2L      matching.disparity_maps
    left-right consistency (Th)        matching.lr_consistency
    3x3 median of the disparity map    median.median3x3
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from .validation import check_image, check_int, check_odd_window, check_same_shape
from .census import CENSUS_WINDOW_RANGE, census_bits, sparse_census
from .matching import (HAMMING_WINDOW_RANGE, default_no_match_cost, disparity_maps,
                       lr_consistency)
from .median import median3x3

__all__ = ["StereoResult", "stereo_match", "check_stereo_params"]


class StereoResult(NamedTuple):
    """Every map of the stereo matcher, all (H, W) uint8, for the left image
    except ``r2l`` (for the right image)."""
    disparity: np.ndarray   #: final map: LRCC then median; 0 = invalid
    l2r: np.ndarray         #: left-to-right winner-take-all map
    r2l: np.ndarray         #: right-to-left winner-take-all map
    checked: np.ndarray     #: after the consistency check, before the median


def check_stereo_params(width: int, height: int, census_window: int, hamming_window: int,
                        max_disparity: int, lrcc_threshold: int,
                        no_match_cost: int | None) -> int:
    """Validate the matcher's parameters for a ``width`` x ``height`` frame.

    Returns the resolved ``no_match_cost``. Raises ``ValueError`` naming the
    first parameter out of range.
    """
    check_odd_window("census_window", census_window, *CENSUS_WINDOW_RANGE)
    check_odd_window("hamming_window", hamming_window, *HAMMING_WINDOW_RANGE)
    if max_disparity is not None:
        check_int("max_disparity", max_disparity, 1, min(256, width))
    check_int("lrcc_threshold", lrcc_threshold, 1, max_disparity)
    bits = census_bits(census_window)
    if no_match_cost is None:
        return default_no_match_cost(bits)
    return check_int("no_match_cost", no_match_cost, 0, bits)


def stereo_match(left, right, *, census_window: int = 7, hamming_window: int = 29,
                 max_disparity: int = 48, lrcc_threshold: int = 8,
                 no_match_cost: int | None = None, prefilter_median: bool = False,
                 disparity_median: bool = True, threads: int | None = None
                 ) -> StereoResult:
    """Disparity map of the left image (thesis §6.2).

    Parameters
    ----------
    left, right : (H, W) 8-bit grey images of a rectified pair
        (left pixel x matches right pixel x - d).
    census_window : odd int in [3, 11]
        Wc, side of the 50 % sparse census window (thesis run time: 7).
    hamming_window : odd int in [1, 63]
        Wh, side of the SHD aggregation window (thesis run time: 29).
    max_disparity : int in [1, min(256, W)]
        D, the number of disparities searched, d = 0 .. D-1 (thesis: 48).
    lrcc_threshold : int in [1, D]
        Th of eq. 21: a pixel is kept when the L2R and R2L maps differ by
        less than Th (the thesis' hardware test bench ran with 8).
    no_match_cost : int in [0, census bits] or None
        Cost of a window position without a right partner; ``None`` = a third
        of the census bits (see :mod:`sim.model.matching`).
    prefilter_median : bool
        Apply the camera pipeline's 3x3 median (§6.1) to both inputs first.
    disparity_median : bool
        Apply the 3x3 median to the checked disparity map (§6 introduction).
    threads : int or None
        Worker threads for the cost stage (result does not depend on it).
    """
    left = check_image("left", left, max_value=255)
    right = check_image("right", right, max_value=255)
    check_same_shape(left=left, right=right)
    h, w = left.shape
    cost = check_stereo_params(w, h, census_window, hamming_window, max_disparity,
                               lrcc_threshold, no_match_cost)
    if prefilter_median:
        left, right = median3x3(left), median3x3(right)
    census_l = sparse_census(left, census_window)
    census_r = sparse_census(right, census_window)
    maps = disparity_maps(census_l, census_r, hamming_window, max_disparity,
                          census_bits(census_window), cost, threads)
    checked = lr_consistency(maps.l2r, maps.r2l, lrcc_threshold)
    disparity = median3x3(checked) if disparity_median else checked
    return StereoResult(disparity, maps.l2r, maps.r2l, checked)

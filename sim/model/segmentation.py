"""Hand segmentation: skin colour AND a disparity band (thesis §6.3, eq. 22, Fig. 58).

A pixel belongs to the hand when its chroma lies in a fixed skin box of the CbCr
plane and its disparity lies strictly between two thresholds (the hand is the
object nearest the cameras, inside a known depth range).
"""
from __future__ import annotations

import numpy as np

from .validation import (check_bool_image, check_byte_range, check_image, check_int,
                         check_same_shape)

__all__ = ["skin_mask", "disparity_band", "hand_mask", "check_band"]


def skin_mask(cb, cr, cb_range=(77, 127), cr_range=(133, 173)) -> np.ndarray:
    """Skin-colour classification in the CbCr plane (thesis §6.3, eq. 22).

    Parameters
    ----------
    cb, cr : (H, W) arrays of unsigned integers in [0, 255], same shape
        Chroma planes (4:4:4, e.g. from :func:`ycbcr422_to_444`).
    cb_range, cr_range : pair of int, each ``0 <= lo <= hi <= 255``
        Inclusive bounds; the thesis values are Cb in [77, 127], Cr in [133, 173].

    Returns
    -------
    (H, W) bool
        ``cb_lo <= cb <= cb_hi and cr_lo <= cr <= cr_hi`` per pixel; no neighbourhood,
        so no border effect.

    Raises
    ------
    ValueError
        On malformed planes, different shapes, or a bad range.
    """
    cb = check_image("cb", cb, dtype_kind="u", max_value=255)
    cr = check_image("cr", cr, dtype_kind="u", max_value=255)
    check_same_shape(cb=cb, cr=cr)
    cb_lo, cb_hi = check_byte_range("cb_range", cb_range)
    cr_lo, cr_hi = check_byte_range("cr_range", cr_range)
    return (cb >= cb_lo) & (cb <= cb_hi) & (cr >= cr_lo) & (cr <= cr_hi)


def check_band(low, high, max_disparity, names=("low", "high")) -> tuple[int, int, int]:
    """Validate the band thresholds of :func:`disparity_band` (``high=None``:
    ``max_disparity - 2``); returns ``(low, high, max_disparity)``. ``names``
    are the parameter names used in the error messages."""
    max_disparity = check_int("max_disparity", max_disparity, 2, 255)
    low = check_int(names[0], low, 0, max_disparity - 2)
    if high is None:
        high = max_disparity - 2
    high = check_int(names[1], high, low + 1, max_disparity - 1)
    return low, high, max_disparity


def disparity_band(disparity, low: int = 33, high: int | None = None,
                   max_disparity: int = 48) -> np.ndarray:
    """Pixels whose disparity lies strictly inside ``(low, high)`` (thesis §6.3, Fig. 58).

    Parameters
    ----------
    disparity : (H, W) array of non-negative integers, each ``<= max_disparity - 1``
        Disparity map (search range ``0 .. max_disparity - 1``).
    low : int, ``0 <= low <= max_disparity - 2``
        Exclusive lower threshold (thesis TL = 33).
    high : int or None, ``low < high <= max_disparity - 1``
        Exclusive upper threshold; ``None`` means ``max_disparity - 2`` (thesis TH = 46).
    max_disparity : int in [2, 255]
        Number of disparity levels D (thesis D = 48).

    Returns
    -------
    (H, W) bool
        ``low < disparity < high`` per pixel; no border effect.

    Raises
    ------
    ValueError
        On a bad parameter or a disparity value outside ``[0, max_disparity - 1]``.
    """
    low, high, max_disparity = check_band(low, high, max_disparity)
    disparity = check_image("disparity", disparity, dtype_kind="ui",
                            max_value=max_disparity - 1)
    return (disparity > low) & (disparity < high)


def hand_mask(skin, band) -> np.ndarray:
    """Hand pixels: skin colour AND inside the disparity band (thesis §6.3, Fig. 58).

    Parameters
    ----------
    skin, band : (H, W) bool (or 0/1 integer) masks of the same shape

    Returns
    -------
    (H, W) bool
        ``skin & band`` per pixel.

    Raises
    ------
    ValueError
        If a mask is malformed or the shapes differ.
    """
    skin = check_bool_image("skin", skin)
    band = check_bool_image("band", band)
    check_same_shape(skin=skin, band=band)
    return skin & band

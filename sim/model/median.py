"""3x3 median filter built as the hardware builds it (thesis §6.1, Figs. 36-37).

The hardware sorts the nine taps of the 3x3 window with an odd-even transposition
sorting network (nine layers of compare-and-swap cells) and outputs the middle one.
This model applies the same network to whole-image arrays: each compare-and-swap is
an ``np.minimum`` / ``np.maximum`` pair, so it is bit-exact by construction.
"""
from __future__ import annotations

import numpy as np

from .validation import check_image

__all__ = ["median3x3"]

_TAPS = 9


def _odd_even_transposition_sort(values: list[np.ndarray]) -> list[np.ndarray]:
    """Sort ``values`` element-wise in ascending order with ``len(values)`` layers."""
    values = list(values)
    count = len(values)
    for layer in range(count):
        for low in range(layer % 2, count - 1, 2):
            a, b = values[low], values[low + 1]
            values[low], values[low + 1] = np.minimum(a, b), np.maximum(a, b)
    return values


def median3x3(image) -> np.ndarray:
    """3x3 median of an unsigned-integer image (thesis §6.1, Figs. 36-37).

    Parameters
    ----------
    image : (H, W) array of unsigned integers
        Camera pixels (uint8) or a disparity map (uint8/uint16).

    Returns
    -------
    (H, W) array, same dtype as ``image``
        Interior pixel ``(y, x)`` (``1 <= y <= H-2``, ``1 <= x <= W-2``) is the 5th
        smallest (index 4 of 0..8) of the nine values ``image[y+dy, x+dx]``,
        ``dx, dy in {-1, 0, 1}``, found by a 9-layer odd-even transposition sorting
        network. Since the nine values are integers, this is exactly their median.

        Border policy: a pixel whose 3x3 window leaves the frame (first/last row or
        column) passes through unchanged -- the hardware forwards the centre tap there.
        Images smaller than 3x3 are returned unchanged (as a copy).

    Raises
    ------
    ValueError
        If ``image`` is not a 2-D unsigned-integer array.
    """
    image = check_image("image", image, dtype_kind="u")
    result = image.copy()
    height, width = image.shape
    if height < 3 or width < 3:
        return result
    taps = [image[1 + dy:height - 1 + dy, 1 + dx:width - 1 + dx]
            for dy in (-1, 0, 1) for dx in (-1, 0, 1)]
    result[1:-1, 1:-1] = _odd_even_transposition_sort(taps)[_TAPS // 2]
    return result

"""Hand centroid from the image moments of the binary mask (thesis §7.1, eq. 23-24, Fig. 72).

The hardware accumulates three moments while the mask streams past --
``M00`` (count of set pixels), ``M10`` (sum of their x) and ``M01`` (sum of their
y) -- and divides once per frame with an unsigned integer divider.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from .validation import check_bool_image, check_int

__all__ = ["Centroid", "MomentWidths", "centroid", "moment_widths"]


class Centroid(NamedTuple):
    """Integer centroid of a mask; ``area == 0`` means "no hand" (then x = y = 0)."""

    x: int
    y: int
    area: int


class MomentWidths(NamedTuple):
    """Unsigned bit widths that hold the largest possible M00, M10 and M01."""

    m00: int
    m10: int
    m01: int


def centroid(mask) -> Centroid:
    """Centroid of the set pixels of a mask (thesis §7.1, eq. 23-24, Fig. 72).

    Parameters
    ----------
    mask : (H, W) bool, or integer array of 0/1

    Returns
    -------
    Centroid(x, y, area) of Python ints
        ``area = M00`` = number of set pixels, ``M10 = sum of x`` and
        ``M01 = sum of y`` over set pixels (0-based column/row indices);
        ``x = M10 // M00`` and ``y = M01 // M00`` (floor, the quotient of the
        hardware's unsigned divider). An empty mask gives ``Centroid(0, 0, 0)``:
        ``area == 0`` tells "no hand". Moments are pointwise, so there is no border
        effect.

    Raises
    ------
    ValueError
        If ``mask`` is not a 2-D boolean (or 0/1) array.
    """
    mask = check_bool_image("mask", mask)
    height, width = mask.shape
    m00 = int(np.count_nonzero(mask))
    if m00 == 0:
        return Centroid(0, 0, 0)
    per_column = np.count_nonzero(mask, axis=0).astype(np.int64)
    per_row = np.count_nonzero(mask, axis=1).astype(np.int64)
    m10 = int(per_column @ np.arange(width, dtype=np.int64))
    m01 = int(per_row @ np.arange(height, dtype=np.int64))
    return Centroid(m10 // m00, m01 // m00, m00)


def moment_widths(width: int, height: int) -> MomentWidths:
    """Register widths for the moment accumulators of a ``width`` x ``height`` frame.

    Thesis §7.1, Fig. 72. The maxima occur for a full mask:
    ``M00 = W*H``, ``M10 = H * W*(W-1)/2``, ``M01 = W * H*(H-1)/2``; each width is
    the number of bits of that maximum as an unsigned integer (at least 1).

    Parameters
    ----------
    width, height : int in [1, 65535]
        Frame size in pixels.

    Returns
    -------
    MomentWidths(m00, m10, m01) of Python ints

    Raises
    ------
    ValueError
        If ``width`` or ``height`` is outside [1, 65535].
    """
    width = check_int("width", width, 1, 65535)
    height = check_int("height", height, 1, 65535)
    max_m00 = width * height
    max_m10 = height * width * (width - 1) // 2
    max_m01 = width * height * (height - 1) // 2
    return MomentWidths(*(max(1, value.bit_length()) for value in (max_m00, max_m10, max_m01)))

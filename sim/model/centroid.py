"""Hand centroid from the image moments of the binary mask (thesis §7.1, eq. 23-24, Fig. 72).

The hardware accumulates three moments while the mask streams past --
``M00`` (count of set pixels), ``M10`` (sum of their x) and ``M01`` (sum of their
y) -- and divides once per frame with an unsigned integer divider.

Hand tracking (not in the thesis; issue 18, both off by default): a bare forearm
inside the disparity band drags the centroid of the whole mask down the arm, and a
second skin-coloured thing at the hand's depth drags it across the picture.
``track_gate`` counts only the pixels within that many pixels (a square) of the
previous frame's centroid, and ``hand_rows`` only the first that many rows from
the top of what is left: the hand is the top of the arm. Both decide per pixel in
raster order, so the hardware still needs one pass and no frame memory.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from .validation import check_bool_image, check_int

__all__ = ["Centroid", "MomentWidths", "TRACK_GATE_RANGE", "HAND_ROWS_RANGE", "centroid",
           "counted_pixels", "moment_widths"]

#: Allowed ``track_gate`` (half-size of the gate square, px) and ``hand_rows``; 0 = off.
TRACK_GATE_RANGE = (0, 4095)
HAND_ROWS_RANGE = (0, 4096)


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


def counted_pixels(mask, *, previous=None, track_gate: int = 0, hand_rows: int = 0):
    """The pixels of ``mask`` the centroid counts (all of them unless hand tracking
    is on; module docstring).

    Parameters
    ----------
    mask : (H, W) bool, or integer array of 0/1
    previous : Centroid or tuple or None
        The previous frame's centroid (or its ``(x, y, area)``); None (the
        clip's first frame) or ``area == 0`` (no hand) opens the gate to the
        whole frame.
    track_gate : int in TRACK_GATE_RANGE
        0: no gate. Else only pixels with ``|x - previous.x| <= track_gate`` and
        ``|y - previous.y| <= track_gate`` count.
    hand_rows : int in HAND_ROWS_RANGE
        0: every row. Else only the rows ``top .. top + hand_rows - 1``, ``top``
        being the first row with a pixel inside the gate.

    Returns
    -------
    (H, W) bool
    """
    mask = check_bool_image("mask", mask)
    track_gate = check_int("track_gate", track_gate, *TRACK_GATE_RANGE)
    hand_rows = check_int("hand_rows", hand_rows, *HAND_ROWS_RANGE)
    if previous is not None:
        if len(tuple(previous)) != 3:
            raise ValueError(f"previous must be a centroid (x, y, area), got {previous!r}")
        px, py, parea = (check_int(f"previous.{name}", value, 0)
                         for name, value in zip(Centroid._fields, previous))
    if track_gate and previous is not None and parea > 0:
        gated = np.zeros_like(mask)
        rows = slice(max(py - track_gate, 0), py + track_gate + 1)
        cols = slice(max(px - track_gate, 0), px + track_gate + 1)
        gated[rows, cols] = mask[rows, cols]
        mask = gated
    if hand_rows:
        filled = np.flatnonzero(mask.any(axis=1))
        if filled.size:
            mask = mask.copy()
            mask[filled[0] + hand_rows:] = False
    return mask


def centroid(mask, *, previous=None, track_gate: int = 0, hand_rows: int = 0) -> Centroid:
    """Centroid of the set pixels of a mask (thesis §7.1, eq. 23-24, Fig. 72).

    Parameters
    ----------
    mask : (H, W) bool, or integer array of 0/1
    previous, track_gate, hand_rows
        Hand tracking (off by default: the thesis): only the pixels
        :func:`counted_pixels` keeps count.

    Returns
    -------
    Centroid
        ``(x, y, area)`` of Python ints: ``area = M00`` = number of set
        pixels, ``M10 = sum of x`` and ``M01 = sum of y`` over set pixels
        (0-based column/row indices);
        ``x = M10 // M00`` and ``y = M01 // M00`` (floor, the quotient of the
        hardware's unsigned divider). An empty mask gives ``Centroid(0, 0, 0)``:
        ``area == 0`` tells "no hand". Moments are pointwise, so there is no border
        effect.

    Raises
    ------
    ValueError
        If ``mask`` is not a 2-D boolean (or 0/1) array, or a tracking argument
        is out of range (the message names it).
    """
    mask = counted_pixels(mask, previous=previous, track_gate=track_gate,
                          hand_rows=hand_rows)
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

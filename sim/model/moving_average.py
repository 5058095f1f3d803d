"""Smoothing of the centroid trajectory (thesis §7.2, eq. 27, Fig. 75).

A small state machine clocked once per frame, so the model loops over frames in
Python; all arithmetic is integer and mirrors the hardware registers
(:class:`hdl.moving_average.MovingAverage`).
"""
from __future__ import annotations

import numpy as np

from .validation import check_flags, check_int, check_points

__all__ = ["moving_average"]


def moving_average(points, valid, window: int = 4, frac_bits: int = 8) -> np.ndarray:
    """Moving average of the centroid trajectory in fixed point (thesis §7.2, eq. 27, Fig. 75).

    The hardware keeps a shift register of the last ``window`` valid centroids and
    outputs their sum shifted left by ``frac_bits`` and right by ``log2(window)``.

    Parameters
    ----------
    points : (F, 2) integer array
        Centroid ``(x, y)`` per frame (value ignored on invalid frames).
    valid : (F,) bool
        ``False`` where no hand was found (centroid area 0).
    window : int, power of two in [1, 16]
        Number of samples averaged (thesis: 4).
    frac_bits : int in [0, 16]
        Fraction bits of the output (thesis 10.8 format: 8).

    Returns
    -------
    (F, 2) int64
        Per frame, with ``history`` the register contents after the frame's update:
        ``out = (sum(history) << frac_bits) >> log2(window)`` (arithmetic shift; exact
        whenever ``frac_bits >= log2(window)``). Update rule: a valid frame shifts
        its centroid in, dropping the oldest; the first valid centroid fills the whole
        register (no ramp up from 0); an invalid frame leaves the register unchanged.
        Frames before the first valid one output ``(0, 0)``.

    Raises
    ------
    ValueError
        On malformed arrays, a ``window`` that is not a power of two in [1, 16]
        (the hardware divides by shifting), or ``frac_bits`` outside [0, 16].
    """
    points = check_points("points", points)
    valid = check_flags("valid", valid, points.shape[0])
    window = check_int("window", window, 1, 16)
    if window & (window - 1):
        raise ValueError(f"window must be a power of two in [1, 16] "
                         f"(the hardware divides by shifting), got {window}")
    frac_bits = check_int("frac_bits", frac_bits, 0, 16)
    shift = window.bit_length() - 1

    out = np.zeros_like(points)
    history: np.ndarray | None = None
    for frame in range(points.shape[0]):
        if valid[frame]:
            if history is None:
                history = np.repeat(points[frame][None, :], window, axis=0)
            else:
                history = np.concatenate([history[1:], points[frame][None, :]])
        if history is not None:
            out[frame] = (history.sum(axis=0) << frac_bits) >> shift
    return out

"""Per-frame trajectory features: smoothing and gesture spotting (thesis §7.2-7.3, eq. 27,
Figs. 75, 78-79).

Both stages are small state machines clocked once per frame, so the model loops over
frames in Python; all arithmetic is integer and mirrors the hardware registers.
"""
from __future__ import annotations

import numpy as np

from ._check import check_int

__all__ = ["moving_average", "gesture_spotting"]


def _check_points(name: str, points) -> np.ndarray:
    arr = np.asarray(points)
    if arr.ndim != 2 or arr.shape[1] != 2:
        raise ValueError(f"{name} must have shape (F, 2) (x, y per frame), got {arr.shape}")
    if arr.dtype.kind not in "iu":
        raise ValueError(f"{name} must have an integer dtype, got {arr.dtype}")
    return arr.astype(np.int64)


def _check_flags(name: str, flags, frames: int) -> np.ndarray:
    arr = np.asarray(flags)
    if arr.shape != (frames,):
        raise ValueError(f"{name} must have shape ({frames},) (one flag per frame), "
                         f"got {arr.shape}")
    if arr.dtype != bool:
        if arr.dtype.kind not in "iu" or (arr.size and (arr.min() < 0 or arr.max() > 1)):
            raise ValueError(f"{name} must be boolean (values 0 or 1)")
        arr = arr.astype(bool)
    return arr


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
    points = _check_points("points", points)
    valid = _check_flags("valid", valid, points.shape[0])
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


def gesture_spotting(points, primed, window: int = 8, threshold: int = 30, hold: int = 16,
                     frac_bits: int = 8) -> np.ndarray:
    """Flag the frames that belong to a gesture (thesis §7.3, Figs. 78-79).

    Parameters
    ----------
    points : (F, 2) integer array
        Smoothed fixed-point positions from :func:`moving_average`.
    primed : (F,) bool
        ``True`` from the first valid centroid on (``np.logical_or.accumulate(valid)``);
        once ``True`` it must stay ``True``.
    window : int in [1, 64]
        Motion is measured over this many primed frames (thesis K = 8).
    threshold : int in [0, 1023]
        Motion threshold in whole pixels (thesis Tm = 30).
    hold : int in [1, 255]
        Consecutive still frames that end a gesture.
    frac_bits : int in [0, 16]
        Fraction bits of ``points``.

    Returns
    -------
    (F,) bool
        ``True`` where the state is GESTURE after the frame's update. On each primed
        frame ``n``, with ``p[n - window]`` the point ``window`` primed frames
        earlier (the register is filled with the first primed point, so there is
        no start spike)::

            motion[n] = max(|x[n] - x[n - window]|, |y[n] - y[n - window]|)
            moving[n] = motion[n] > (threshold << frac_bits)

        State machine, starting in REST: REST -> GESTURE when ``moving[n]``;
        in GESTURE a moving frame clears the still counter, a still frame increments
        it, and the state returns to REST (counter cleared) on the ``hold``-th
        consecutive still frame -- so the slow reversal of an up-and-back gesture
        does not split it. Unprimed frames output ``False`` and change nothing.

    Raises
    ------
    ValueError
        On malformed arrays, ``primed`` falling from ``True`` back to ``False``, or a
        parameter outside its range.
    """
    points = _check_points("points", points)
    primed = _check_flags("primed", primed, points.shape[0])
    if np.any(primed[:-1] & ~primed[1:]):
        raise ValueError("primed must stay True once set (np.logical_or.accumulate(valid))")
    window = check_int("window", window, 1, 64)
    threshold = check_int("threshold", threshold, 0, 1023)
    hold = check_int("hold", hold, 1, 255)
    frac_bits = check_int("frac_bits", frac_bits, 0, 16)
    limit = threshold << frac_bits

    flags = np.zeros(points.shape[0], dtype=bool)
    history: np.ndarray | None = None  # ring buffer of the last `window` primed points
    oldest = 0
    in_gesture = False
    still_frames = 0
    for frame in np.flatnonzero(primed):
        point = points[frame]
        if history is None:
            history = np.repeat(point[None, :], window, axis=0)
        motion = int(np.abs(point - history[oldest]).max())
        history[oldest] = point
        oldest = (oldest + 1) % window
        if motion > limit:
            in_gesture, still_frames = True, 0
        elif in_gesture:
            still_frames += 1
            if still_frames >= hold:
                in_gesture, still_frames = False, 0
        flags[frame] = in_gesture
    return flags

"""Gesture spotting: which frames belong to a gesture (thesis §7.3, Figs. 78-79).

A small state machine clocked once per frame, so the model loops over frames in
Python; all arithmetic is integer and mirrors the hardware registers
(:class:`hdl.gesture_spotting.GestureSpotting`).
"""
from __future__ import annotations

import numpy as np

from .validation import check_flags, check_int, check_points

__all__ = ["gesture_spotting"]


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
    points = check_points("points", points)
    primed = check_flags("primed", primed, points.shape[0])
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

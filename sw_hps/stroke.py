"""Whole-gesture features for the Gaussian gesture HMMs (the continuous
alternative to the thesis' 8 orientation symbols of §7.4).

Runs on the board's ARM: Python 3 and numpy only, nothing else from this
project. Training (:mod:`recognition`) and the board application compute the
features with these same functions, so they cannot drift apart.

A gesture is resampled to ``resample`` points equally spaced along its path
(cameras and pens sample unevenly in time and space), then every step ``t``
between consecutive resampled points gives one feature vector:

=========  ============================================================
name       value
=========  ============================================================
cos, sin   direction of the step (y up: image y grows downward)
x, y       position after the step relative to the first point, divided
           by the path length L (y up)
arc        arc-length fraction ``t / (T - 1)`` of the step, T = resample - 1
turn       change of direction from the previous step, radians in
           [-pi, pi) (0 for the first step)
=========  ============================================================

Position and arc need the whole gesture (its length and end), so the board
application buffers a gesture's points and scores it when it ends.
"""
from __future__ import annotations

import numpy as np

__all__ = ["FEATURE_NAMES", "RESAMPLE_RANGE", "resample_path", "stroke_features"]

#: Names of the feature columns, in order.
FEATURE_NAMES = ("cos", "sin", "x", "y", "arc", "turn")
#: Allowed number of resampled points.
RESAMPLE_RANGE = (3, 4096)


def _check_resample(num_points) -> int:
    lo, hi = RESAMPLE_RANGE
    if isinstance(num_points, bool) or not isinstance(num_points, (int, np.integer)) \
            or not lo <= num_points <= hi:
        raise ValueError(f"resample must be an integer in [{lo}, {hi}], got {num_points!r}")
    return int(num_points)


def resample_path(points, num_points: int) -> np.ndarray:
    """``num_points`` points equally spaced along the path (linear
    interpolation); a path of zero length gives its first point repeated.

    Parameters
    ----------
    points : (P, 2) array, P >= 1
        The path, any numeric scale.
    num_points : int
        In [2, 4096].
    """
    if isinstance(num_points, bool) or not isinstance(num_points, (int, np.integer)) \
            or not 2 <= num_points <= RESAMPLE_RANGE[1]:
        raise ValueError(f"resample must be an integer in [2, {RESAMPLE_RANGE[1]}], "
                         f"got {num_points!r}")
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    if len(pts) == 0:
        raise ValueError("trajectory must have at least one point")
    if not np.isfinite(pts).all():
        raise ValueError("trajectory must hold finite values")
    seg = np.hypot(*np.diff(pts, axis=0).T)
    along = np.concatenate([[0.0], np.cumsum(seg)])
    if along[-1] == 0:
        return np.repeat(pts[:1], num_points, axis=0)
    targets = np.linspace(0.0, along[-1], num_points)
    return np.column_stack([np.interp(targets, along, pts[:, 0]),
                            np.interp(targets, along, pts[:, 1])])


def stroke_features(points, resample: int) -> np.ndarray | None:
    """Feature vectors of one gesture (module docstring).

    Parameters
    ----------
    points : (P, 2) array
        The gesture's path in image orientation (y down), any scale.
    resample : int
        Points after resampling, in [3, 4096]; the result has ``resample - 1``
        rows.

    Returns
    -------
    (resample - 1, 6) float64 array, or None
        None when the path has zero length (no motion: nothing to score).
    """
    n = _check_resample(resample)
    path = resample_path(points, n)
    step = np.diff(path, axis=0)
    length = float(np.hypot(step[:, 0], step[:, 1]).sum())
    if not length > 0:
        return None
    angle = np.arctan2(-step[:, 1], step[:, 0])
    turn = np.diff(angle, prepend=angle[0])
    turn = (turn + np.pi) % (2 * np.pi) - np.pi
    rel = (path[1:] - path[0]) / length
    arc = np.arange(n - 1) / (n - 2)
    return np.column_stack([np.cos(angle), np.sin(angle), rel[:, 0], -rel[:, 1], arc, turn])

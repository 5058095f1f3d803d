"""Symbol sequences for the HMMs (thesis §7.2-7.4, Fig. 82).

Two front ends, both ending in the board's orientation quantiser
(:func:`sw_hps.orientation.orientation_symbols`):

* **camera** (default): a trajectory is the per-frame hand centroid in pixels,
  rest included. It goes through the FPGA's feature chain exactly as the
  golden model defines it (integer centroid, moving average, gesture
  spotting: :func:`sim.model.pipeline.track`), and the symbols of the longest
  flagged segment are kept: what the board application receives.
* **pen** (``resample=N``): pen and tablet devices sample unevenly in time and
  space, so the path is first resampled to N points equally spaced along its
  length; no spotting (the stroke is the gesture).

Steps without motion give no symbol and are dropped.
"""
from __future__ import annotations

import numpy as np

from recognition.datasets import TrajectorySet
from sim.model.pipeline import PipelineParams, track
from sw_hps.orientation import NO_SYMBOL, orientation_symbols

__all__ = ["camera_symbols", "resample_path", "pen_symbols", "sequences", "RESAMPLE_RANGE"]

RESAMPLE_RANGE = (2, 4096)
_PEN_SCALE = 256  # fixed-point scale before the integer quantiser


def camera_symbols(trajectory, params: PipelineParams = PipelineParams()) -> np.ndarray:
    """Symbols of the longest flagged gesture in a per-frame centroid track."""
    pts = np.asarray(trajectory, dtype=np.float64).reshape(-1, 2)
    if not np.isfinite(pts).all() or (pts < 0).any():
        raise ValueError("trajectory must hold finite, non-negative pixel positions")
    cents = np.floor(pts).astype(np.int64)
    traj = track(cents, np.ones(len(cents), np.int64), params)
    flag = traj.flag
    if not flag.any():
        return np.zeros(0, np.int8)
    # Longest run of flagged frames.
    edges = np.diff(np.concatenate([[0], flag.astype(np.int8), [0]]))
    starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    longest = int(np.argmax(ends - starts))
    segment = traj.symbol[starts[longest]:ends[longest]]
    return segment[segment != NO_SYMBOL].astype(np.int8)


def resample_path(trajectory, num_points: int) -> np.ndarray:
    """``num_points`` points equally spaced along the path's length (linear
    interpolation; a path of zero length gives its first point repeated)."""
    lo, hi = RESAMPLE_RANGE
    if isinstance(num_points, bool) or not isinstance(num_points, (int, np.integer)) \
            or not lo <= num_points <= hi:
        raise ValueError(f"resample must be an integer in [{lo}, {hi}], got {num_points!r}")
    pts = np.asarray(trajectory, dtype=np.float64).reshape(-1, 2)
    if len(pts) == 0:
        raise ValueError("trajectory must have at least one point")
    seg = np.hypot(*np.diff(pts, axis=0).T)
    along = np.concatenate([[0.0], np.cumsum(seg)])
    if along[-1] == 0:
        return np.repeat(pts[:1], num_points, axis=0)
    targets = np.linspace(0.0, along[-1], num_points)
    return np.column_stack([np.interp(targets, along, pts[:, 0]),
                            np.interp(targets, along, pts[:, 1])])


def pen_symbols(trajectory, resample: int) -> np.ndarray:
    """Symbols of a pen stroke after equidistant resampling to ``resample`` points."""
    path = resample_path(trajectory, resample)
    symbols = orientation_symbols(np.rint(path * _PEN_SCALE).astype(np.int64))
    return symbols[symbols != NO_SYMBOL].astype(np.int8)


def sequences(data: TrajectorySet, resample: int | None = None,
              params: PipelineParams = PipelineParams()) -> list[np.ndarray]:
    """Symbol sequence of every trajectory of ``data`` (camera or pen front end)."""
    if resample is None:
        return [camera_symbols(t, params) for t in data.trajectories()]
    return [pen_symbols(t, resample) for t in data.trajectories()]

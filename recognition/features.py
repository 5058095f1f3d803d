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

The Gaussian models (:mod:`sw_hps.gaussian_hmm`) take the same gestures as
points instead of symbols (:func:`camera_points`, :func:`feature_sets`): the
smoothed 10.8 positions of the longest flagged segment, which are exactly
the pairs the board application pops from the FIFO, or the raw pen path; the
features (:func:`sw_hps.stroke.stroke_features`) resample them.
"""
from __future__ import annotations

import numpy as np

from recognition.datasets import TrajectorySet
from sim.model.pipeline import PipelineParams, track
from sw_hps.orientation import NO_SYMBOL, orientation_symbols
from sw_hps.stroke import resample_path, stroke_features

__all__ = ["camera_symbols", "camera_points", "resample_path", "pen_symbols", "sequences",
           "feature_sets", "RESAMPLE_RANGE"]

#: Points of the pen front end (resample_path takes 2 and more).
RESAMPLE_RANGE = (2, 4096)
_PEN_SCALE = 256  # fixed-point scale before the integer quantiser


def _longest_flagged(trajectory, params: PipelineParams):
    """The golden model's track of a centroid trajectory and the frame range
    of its longest flagged run (None if nothing was flagged)."""
    pts = np.asarray(trajectory, dtype=np.float64).reshape(-1, 2)
    if not np.isfinite(pts).all() or (pts < 0).any():
        raise ValueError("trajectory must hold finite, non-negative pixel positions")
    cents = np.floor(pts).astype(np.int64)
    traj = track(cents, np.ones(len(cents), np.int64), params)
    flag = traj.flag
    if not flag.any():
        return traj, None
    edges = np.diff(np.concatenate([[0], flag.astype(np.int8), [0]]))
    starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    longest = int(np.argmax(ends - starts))
    return traj, slice(int(starts[longest]), int(ends[longest]))


def camera_symbols(trajectory, params: PipelineParams = PipelineParams()) -> np.ndarray:
    """Symbols of the longest flagged gesture in a per-frame centroid track."""
    traj, run = _longest_flagged(trajectory, params)
    if run is None:
        return np.zeros(0, np.int8)
    segment = traj.symbol[run]
    return segment[segment != NO_SYMBOL].astype(np.int8)


def camera_points(trajectory, params: PipelineParams = PipelineParams()) -> np.ndarray:
    """The (P, 2) smoothed 10.8 positions of the longest flagged gesture in a
    per-frame centroid track: the pairs the board pops from the FIFO."""
    traj, run = _longest_flagged(trajectory, params)
    if run is None:
        return np.zeros((0, 2), np.int64)
    return traj.smoothed[run]


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


def feature_sets(data: TrajectorySet, resample: int, camera: bool,
                 params: PipelineParams = PipelineParams()) -> list[np.ndarray | None]:
    """Feature vectors (:func:`sw_hps.stroke.stroke_features`, ``resample``
    points) of every trajectory: of its camera points (``camera``) or of the
    raw pen path; None where the gesture has no motion."""
    out = []
    for t in data.trajectories():
        points = camera_points(t, params) if camera else t
        out.append(stroke_features(points, resample) if len(points) else None)
    return out

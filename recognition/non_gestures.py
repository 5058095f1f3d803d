"""Trajectories that are not gestures, for measuring rejection.

* :func:`random_walks`: pen-like paths of Gaussian steps (no shape at all).
* :func:`scribbles`: smooth random curves, sums of a few random sinusoids
  per axis (shape-like, but no gesture's shape).
* :func:`wandering_hands`: per-frame hand centroid tracks at the camera's
  scale and frame rate, as :mod:`recognition.corpus` draws them (rest, then
  the hand wanders on a smooth random path for 40-80 frames, then rest,
  with jitter and tremor): what the camera front end sees when a person
  moves a hand without making a gesture.
* :func:`as_centroid_tracks`: pen paths turned into such tracks.

All are labelled ``"none"`` and seeded.
"""
from __future__ import annotations

import numpy as np

from recognition.datasets import TrajectorySet
from sim.model.validation import check_int

__all__ = ["NONE_LABEL", "random_walks", "scribbles", "wandering_hands", "as_centroid_tracks"]

NONE_LABEL = "none"


def _check(count, seed):
    check_int("count", count, 1)
    check_int("seed", seed, 0)


def _pen_paths(count: int, seed: int, points: tuple[int, int], draw) -> TrajectorySet:
    """``count`` paths of ``points`` (uniform in the range) points, ``draw(rng, n)``
    each, labelled "none"."""
    _check(count, seed)
    rng = np.random.default_rng(seed)
    paths = [draw(rng, int(rng.integers(points[0], points[1] + 1))) for _ in range(count)]
    return TrajectorySet.from_list(paths, [NONE_LABEL] * count)


def random_walks(count: int, seed: int = 0, points: tuple[int, int] = (30, 120)) -> TrajectorySet:
    """``count`` random walks of ``points`` (uniform in the range) Gaussian steps."""
    return _pen_paths(count, seed, points,
                      lambda rng, n: 200.0 + np.cumsum(rng.normal(0.0, 5.0, size=(n, 2)), axis=0))


def _smooth_curve(rng: np.random.Generator, n: int, amplitude: float) -> np.ndarray:
    s = np.linspace(0.0, 1.0, n)[:, None]
    curve = np.zeros((n, 2))
    for _ in range(int(rng.integers(2, 4))):
        freq = rng.uniform(0.5, 3.0, size=2)
        phase = rng.uniform(0.0, 2 * np.pi, size=2)
        curve += rng.uniform(0.3, 1.0, size=2) * np.sin(2 * np.pi * freq * s + phase)
    curve -= curve[0]
    span = np.abs(curve).max()
    return curve * (amplitude / span if span > 0 else 0.0)


def scribbles(count: int, seed: int = 0, points: tuple[int, int] = (30, 120)) -> TrajectorySet:
    """``count`` smooth random curves, 100 px across, with a little pen noise."""
    return _pen_paths(count, seed, points,
                      lambda rng, n: 200.0 + _smooth_curve(rng, n, 100.0)
                      + rng.normal(0.0, 0.5, size=(n, 2)))


def as_centroid_tracks(data: TrajectorySet, origin: tuple[float, float] = (150.0, 120.0),
                       rest_frames: int = 20, width: int = 640,
                       height: int = 480) -> TrajectorySet:
    """Pen paths as per-frame hand centroid tracks for the camera front end:
    moved so that their top-left corner is at ``origin``, with
    ``rest_frames`` still frames before and after (the spotting needs them),
    clipped to the frame."""
    tracks = []
    for path in data.trajectories():
        path = path - path.min(axis=0) + origin
        track = np.concatenate([np.repeat(path[:1], rest_frames, axis=0), path,
                                np.repeat(path[-1:], rest_frames, axis=0)])
        tracks.append(np.clip(track, 0, (width - 1, height - 1)))
    return TrajectorySet.from_list(tracks, data.label)


def wandering_hands(count: int, seed: int = 0, width: int = 640,
                    height: int = 480) -> TrajectorySet:
    """``count`` per-frame centroid tracks (integer pixels, 30 frames/s) of a
    hand that rests, wanders 40-80 frames over 40-120 px (scaled to the
    frame), and rests again."""
    _check(count, seed)
    rng = np.random.default_rng(seed)
    scale = width / 640.0
    tracks = []
    for _ in range(count):
        pre, motion, post = (int(rng.integers(15, 31)), int(rng.integers(40, 81)),
                             int(rng.integers(15, 31)))
        rest = np.array([width * rng.uniform(0.35, 0.65), height * rng.uniform(0.45, 0.7)])
        path = _smooth_curve(rng, motion, rng.uniform(40.0, 120.0) * scale)
        positions = np.concatenate([np.repeat(rest[None], pre, axis=0), rest + path,
                                    np.repeat((rest + path[-1])[None], post, axis=0)])
        t = np.arange(len(positions)) / 30.0
        positions += 1.5 * scale * np.sin(2 * np.pi * rng.uniform(3, 6) * t[:, None]
                                          + rng.uniform(0, 2 * np.pi, size=2))
        positions += rng.normal(0.0, 1.2 * scale, size=positions.shape)
        tracks.append(np.clip(np.floor(positions), 0, (width - 1, height - 1)))
    return TrajectorySet.from_list(tracks, [NONE_LABEL] * count)

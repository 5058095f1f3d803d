"""Synthetic corpus of hand-centroid trajectories for the seven thesis gestures.

What the FPGA hands to the recogniser is one hand centroid per video frame (thesis
§7.1, eq. 23-24), in whole pixels. This module draws such trajectories for the
gestures of Fig. 16 (:mod:`sim.gesture_shapes`, the one definition of the shapes),
laid out in time like the scene renderer (:mod:`sim.render`) lays out a clip::

    pre-gesture rest   15-30 frames at 30 fps (0.5-1 s)
    motion             40-80 frames (1.33-2.67 s, thesis §9.3)
    post-gesture rest  15-30 frames

All durations scale with ``fps / 30`` and all lengths with
``min(width / 640, height / 480)``, as in the renderer.

Who draws the gesture
---------------------
Each person (``subject`` 0 .. people-1) has a :class:`PersonStyle`: a typical
amplitude (within +-10 % of 200 px at 640x480), aspect (taller or flatter shapes),
tilt, speed (typical motion duration), time-warp tendency (hurrying one part of a
gesture, lingering on another), corner rounding (how much of a constant-speed
movement is mixed into the minimum-jerk one, so corners of ``stop`` are cut),
rest position in front of the chest, tremor level and how well the segmentation
works for them (centroid jitter, finger cuts, dropped frames). Every sample
varies around its person's style; amplitude stays within +-15 % of 200 px as in
the renderer, unless the gesture has to shrink to fit the image.

What the segmentation adds
--------------------------
* **jitter**: the centroid of a segmented hand wobbles by a pixel or two from
  frame to frame (white noise per frame);
* **finger cuts**: now and then the opening cuts fingers off for 1-3 frames, so
  the centroid jumps by 4-12 px towards the palm (down in the image), more often
  while the hand moves;
* **tremor**: a small low-frequency oscillation (1-3 Hz, about a pixel);
* **dropped frames**: a frame missing from the sequence, so the next point jumps
  by one frame's worth of motion. The durations above count the frames that
  remain; the hand moved for ``motion + dropped`` frame times.

The gesture is kept inside the image with the renderer's hand margins (the
whole hand, and on the left its disparity, must stay in view): the rest
position moves when the gesture does not fit and the amplitude shrinks only if
that is not enough. The final points are integer pixels (the centroid divider
floors) clipped to the image.

Randomness
----------
A person's style depends on ``(seed, person)`` only, and sample ``k`` of a
gesture on ``(seed, gesture, k)`` only; so the same arguments always give the
same corpus, and a corpus with fewer samples per class is a prefix (per class)
of one with more (for the same ``people``).
"""
from __future__ import annotations

import functools
import math
import numbers
from dataclasses import dataclass

import numpy as np

from recognition.datasets import TrajectorySet
from sim.gesture_shapes import GESTURE_NAMES, gesture_id, gesture_path, random_time_warp
from sim.model.pipeline import PipelineParams, track
from sim.model.validation import check_int

__all__ = ["PersonStyle", "SyntheticCorpus", "person_style", "generate_corpus",
           "synthetic_corpus", "spotted_coverage", "CORPUS_LIMITS"]

#: Accepted ranges of the integer arguments of :func:`synthetic_corpus`.
CORPUS_LIMITS = {
    "per_class": (1, 100_000),
    "people": (1, 1000),
    "seed": (0, 2 ** 63 - 1),
    "width": (96, 4096),          # the renderer's ranges
    "height": (64, 4096),
    "fps": (5, 240),
}

_REFERENCE_WIDTH, _REFERENCE_HEIGHT = 640, 480
_AMPLITUDE_PX = 200.0                 # thesis Fig. 77, at the reference size
_PERSON_AMPLITUDE_SPREAD = 0.10       # person +-10 %, sample +-5 %: within the renderer's +-15 %
_SAMPLE_AMPLITUDE_SPREAD = 0.05
_REST_FRAMES = (15, 30)               # at 30 fps, as sim.render
_MOTION_FRAMES = (40, 80)             # thesis §9.3
_PERSON_MOTION_MEAN = (48, 72)        # a person's typical duration, frames at 30 fps
_SAMPLE_MOTION_SD = 6.0

# Renderer geometry (sim.render at the reference size): the hand sprite reaches this
# far from the palm centre, stays 4 px inside the image, and its left edge stays
# hand-disparity (40 px, not scaled) further in so that the right camera sees it.
_HAND_REACH = {"left": 42.0, "right": 32.0, "up": 60.0, "down": 26.0}
_EDGE_MARGIN_PX = 4.0
_HAND_DISPARITY_PX = 40.0

# Independent random streams (SeedSequence entropy words).
_STREAM_PERSON, _STREAM_SAMPLE = 11, 12


@dataclass(frozen=True)
class PersonStyle:
    """How one person performs gestures (lengths in pixels, at the corpus' image size).

    Attributes
    ----------
    amplitude : float
        Typical gesture amplitude (the extent of the unit shapes), px.
    aspect : float
        Typical vertical stretch (``aspect`` of :func:`sim.gesture_shapes.gesture_path`).
    tilt_deg : float
        Typical rotation of the drawn shape, degrees.
    motion_frames : float
        Typical motion duration in frames.
    warp_seed : int
        Seed of the person's own time warp (:func:`random_time_warp`), composed
        with each sample's warp: the person's habit of hurrying or lingering.
    corner_rounding : float in [0, 0.3]
        Weight of the constant-speed profile mixed into the minimum-jerk one.
    rest : (float, float)
        Preferred rest position of the hand (in front of the chest), px.
    tremor_px : float
        Tremor amplitude per axis, px.
    tremor_hz : float
        Tremor frequency.
    jitter_px : float
        Standard deviation of the per-frame segmentation jitter per axis, px.
    cut_rate : float
        Probability per frame (at rest) that the opening starts cutting fingers.
    drop_rate : float
        Probability that a frame is missing from the sequence.
    """
    amplitude: float
    aspect: float
    tilt_deg: float
    motion_frames: float
    warp_seed: int
    corner_rounding: float
    rest: tuple[float, float]
    tremor_px: float
    tremor_hz: float
    jitter_px: float
    cut_rate: float
    drop_rate: float


@dataclass(frozen=True)
class SyntheticCorpus:
    """A synthetic corpus and its ground truth.

    Attributes
    ----------
    data : TrajectorySet
        Per-frame centroids in pixels; ``label`` = gesture name, ``subject`` = person.
    motion : (N, 2) int64
        First and last (inclusive) frame of the motion in each trajectory.
    amplitude : (N,) float64
        Gesture amplitude of each sample, px (after any shrinking to fit the image).
    dropped : (N,) int64
        Number of frames missing from each trajectory.
    people : tuple of PersonStyle
        The style of each person, indexed by ``subject``.
    """
    data: TrajectorySet
    motion: np.ndarray
    amplitude: np.ndarray
    dropped: np.ndarray
    people: tuple[PersonStyle, ...]


def _scale(width: int, height: int) -> float:
    return min(width / _REFERENCE_WIDTH, height / _REFERENCE_HEIGHT)


def person_style(seed: int, person: int, width: int = 640, height: int = 480,
                 fps: int = 30) -> PersonStyle:
    """The style of person ``person`` for corpus seed ``seed`` (see the module docstring).

    Parameters
    ----------
    seed : int in [0, 2**63 - 1]
        Corpus seed; the style depends on ``(seed, person)`` only.
    person : int in [0, 999]
        The person's number (``subject`` in the corpus).
    width, height, fps : int
        Image size and frame rate the lengths and durations are scaled to.

    Returns
    -------
    PersonStyle

    Raises
    ------
    ValueError
        A parameter out of range (the message names it).
    """
    seed = check_int("seed", seed, *CORPUS_LIMITS["seed"])
    people_max = CORPUS_LIMITS["people"][1]
    if isinstance(person, bool) or not isinstance(person, numbers.Integral) \
            or not 0 <= person < people_max:
        raise ValueError(f"person must be an integer in [0, {people_max - 1}], got {person!r}")
    width, height, fps = (check_int("width", width, *CORPUS_LIMITS["width"]), check_int("height", height, *CORPUS_LIMITS["height"]),
                          check_int("fps", fps, *CORPUS_LIMITS["fps"]))
    rng = np.random.default_rng([seed, _STREAM_PERSON, person])
    scale = _scale(width, height)
    rate = fps / 30.0
    return PersonStyle(
        amplitude=_AMPLITUDE_PX * scale * (1 + rng.uniform(-1, 1) * _PERSON_AMPLITUDE_SPREAD),
        aspect=float(rng.uniform(0.88, 1.12)),
        tilt_deg=float(rng.uniform(-6.0, 6.0)),
        motion_frames=float(rng.uniform(*_PERSON_MOTION_MEAN) * rate),
        warp_seed=int(rng.integers(0, 2 ** 62)),
        corner_rounding=float(rng.uniform(0.0, 0.3)),
        rest=(float(width / 2 + rng.uniform(-25, 25) * scale),
              float(0.66 * height + rng.uniform(-12, 12) * scale)),
        tremor_px=float(rng.uniform(0.3, 1.5) * scale),
        tremor_hz=float(rng.uniform(1.0, 3.0)),
        jitter_px=float(rng.uniform(0.7, 1.8) * scale),
        cut_rate=float(rng.uniform(0.003, 0.015)),
        drop_rate=float(rng.uniform(0.0, 0.01)),
    )


def _frames(span: tuple[int, int], rate: float, floor: int) -> tuple[int, int]:
    """A duration range at 30 fps converted to frames at ``30 * rate`` fps."""
    return tuple(max(floor, round(v * rate)) for v in span)


def _clamp(value: float, lo: float, hi: float) -> float:
    return float(min(max(value, lo), hi))


@functools.lru_cache(maxsize=1024)
def _person_warp(warp_seed: int, num_points: int) -> np.ndarray:
    """A person's own time warp: the same coefficients for every sample (reseeded)."""
    warp = random_time_warp(num_points, np.random.default_rng(warp_seed), strength=0.12)
    warp.flags.writeable = False
    return warp


def _shape(name: str, num_points: int, style: PersonStyle,
           rng: np.random.Generator) -> np.ndarray:
    """Sampled unit path of one sample: (num_points, 2) in amplitude units, image
    axes, first and last point at the origin (the rest position)."""
    aspect = _clamp(style.aspect + rng.uniform(-0.03, 0.03), 0.85, 1.15)
    tilt = math.radians(style.tilt_deg + rng.uniform(-3.0, 3.0))
    rounding = _clamp(style.corner_rounding + rng.uniform(-0.05, 0.05), 0.0, 0.35)

    # The person's warp (same coefficients every time: the generator is reseeded)
    # composed with a milder per-sample one; both are monotone from 0 to 1.
    person_warp = _person_warp(style.warp_seed, num_points)
    sample_warp = random_time_warp(num_points, rng, strength=0.06)
    uniform = np.linspace(0.0, 1.0, num_points)
    warp = np.interp(sample_warp, uniform, person_warp)
    warp[0], warp[-1] = 0.0, 1.0

    smooth = gesture_path(name, num_points, aspect=aspect, time_warp=warp)
    constant = gesture_path(name, num_points, aspect=aspect, speed_profile="constant",
                            time_warp=warp)
    # Mixing in the constant-speed profile keeps the hand moving through the
    # corners, which cuts them a little (a hurried "stop" triangle).
    mixed = (1.0 - rounding) * smooth + rounding * constant
    cos, sin = math.cos(tilt), math.sin(tilt)
    return mixed @ np.array([[cos, sin], [-sin, cos]])


def _fit(path: np.ndarray, amplitude: float, rest: np.ndarray, width: int, height: int,
         scale: float, name: str) -> tuple[float, np.ndarray]:
    """Amplitude and rest position that keep the whole gesture in view (as sim.render)."""
    lo, hi = path.min(axis=0), path.max(axis=0)
    room_lo = np.array([_HAND_DISPARITY_PX + _EDGE_MARGIN_PX + _HAND_REACH["left"] * scale,
                        _EDGE_MARGIN_PX + _HAND_REACH["up"] * scale])
    room_hi = np.array([width - 1 - _EDGE_MARGIN_PX - _HAND_REACH["right"] * scale,
                        height - 1 - _EDGE_MARGIN_PX - _HAND_REACH["down"] * scale])
    room = room_hi - room_lo - 1.0
    span = hi - lo
    for axis, what in ((0, "width"), (1, "height")):
        if room[axis] <= 0 or (span[axis] > 0 and room[axis] / span[axis]
                               < 0.25 * _AMPLITUDE_PX * scale):
            size = width if axis == 0 else height
            raise ValueError(f"{what} {size} leaves no room for the {name} gesture; "
                             f"use a larger {what}")
        if span[axis] > 0:
            amplitude = min(amplitude, room[axis] / span[axis])
    rest = np.clip(rest, room_lo + 0.5 - amplitude * lo, room_hi - 0.5 - amplitude * hi)
    return amplitude, rest


def _sample(name: str, style: PersonStyle, rng: np.random.Generator, width: int,
            height: int, fps: int) -> tuple[np.ndarray, tuple[int, int], float, int]:
    """One trajectory: (points (T, 2) float64, motion span, amplitude, dropped frames)."""
    scale = _scale(width, height)
    rate = fps / 30.0
    rest_lo, rest_hi = _frames(_REST_FRAMES, rate, 1)
    motion_lo, motion_hi = _frames(_MOTION_FRAMES, rate, 2)
    pre = int(rng.integers(rest_lo, rest_hi + 1))
    post = int(rng.integers(rest_lo, rest_hi + 1))
    motion = int(_clamp(round(rng.normal(style.motion_frames, _SAMPLE_MOTION_SD * rate)),
                        motion_lo, motion_hi))
    recorded = pre + motion + post

    # Dropped frames: True where a camera frame is lost before the recorded frame.
    lost_before = rng.random(recorded) < style.drop_rate
    lost_before[0] = False
    true_index = np.arange(recorded) + np.cumsum(lost_before)   # frame times of the kept frames
    true_pre = int(true_index[pre])                              # first motion frame's time
    true_motion = int(true_index[pre + motion - 1]) - true_pre + 1

    # The path includes the rest points at both ends, as in sim.render.
    path = _shape(name, true_motion + 2, style, rng)
    # Person and sample deviations add up to at most the renderer's +-15 %.
    amplitude = style.amplitude + (_AMPLITUDE_PX * scale * rng.uniform(-1, 1)
                                   * _SAMPLE_AMPLITUDE_SPREAD)
    rest = np.asarray(style.rest) + rng.normal(0.0, 6.0 * scale, size=2)
    amplitude, rest = _fit(path, amplitude, rest, width, height, scale, name)

    total = int(true_index[-1]) + 1
    positions = np.repeat(rest[None, :], total, axis=0)
    positions[true_pre:true_pre + true_motion] += amplitude * path[1:-1]
    # The hand does not come back exactly where it started.
    miss = np.clip(rng.normal(0.0, 3.0 * scale, size=2), -8 * scale, 8 * scale)
    progress = np.clip((np.arange(total) - true_pre + 1) / (true_motion + 1), 0.0, 1.0)
    positions += progress[:, None] * miss

    # Tremor: a slow oscillation per axis with its own phase.
    seconds = np.arange(total) / fps
    tremor_amp = style.tremor_px * rng.uniform(0.7, 1.3, size=2)
    tremor_hz = style.tremor_hz * rng.uniform(0.9, 1.1, size=2)
    phase = rng.uniform(0.0, 2 * np.pi, size=2)
    positions += tremor_amp * np.sin(2 * np.pi * tremor_hz * seconds[:, None] + phase)

    points = positions[true_index]
    points += rng.normal(0.0, style.jitter_px, size=points.shape)   # segmentation jitter

    # Finger cuts: the centroid drops towards the palm for 1-3 frames; motion blur
    # and the moving edges make them twice as likely during the motion.
    cut_rate = np.full(recorded, style.cut_rate)
    cut_rate[pre:pre + motion] *= 2.0
    for start in np.flatnonzero(rng.random(recorded) < cut_rate):
        length = int(rng.integers(1, 4))
        points[start:start + length] += (rng.normal(0.0, 2.0 * scale),
                                         rng.uniform(4.0, 12.0) * scale)

    # Integer pixels, as the FPGA's centroid divider delivers them.
    points = np.floor(points)
    np.clip(points, 0, (width - 1, height - 1), out=points)
    return points, (pre, pre + motion - 1), float(amplitude), int(lost_before.sum())


def generate_corpus(per_class: int = 180, people: int = 3, seed: int = 0, width: int = 640,
                    height: int = 480, fps: int = 30) -> SyntheticCorpus:
    """Draw the synthetic corpus and keep its ground truth (see :func:`synthetic_corpus`).

    Returns
    -------
    SyntheticCorpus
        ``data`` and the motion span, amplitude and dropped-frame count of every sample.
    """
    per_class = check_int("per_class", per_class, *CORPUS_LIMITS["per_class"])
    people = check_int("people", people, *CORPUS_LIMITS["people"])
    seed = check_int("seed", seed, *CORPUS_LIMITS["seed"])
    width, height = check_int("width", width, *CORPUS_LIMITS["width"]), check_int("height", height, *CORPUS_LIMITS["height"])
    fps = check_int("fps", fps, *CORPUS_LIMITS["fps"])
    styles = tuple(person_style(seed, p, width, height, fps) for p in range(people))

    trajectories, labels, subjects, spans, amplitudes, dropped = [], [], [], [], [], []
    for name in GESTURE_NAMES:
        for k in range(per_class):
            person = k % people                      # people take turns
            rng = np.random.default_rng([seed, _STREAM_SAMPLE, gesture_id(name), k])
            points, span, amplitude, lost = _sample(name, styles[person], rng, width,
                                                     height, fps)
            trajectories.append(points)
            labels.append(name)
            subjects.append(person)
            spans.append(span)
            amplitudes.append(amplitude)
            dropped.append(lost)
    data = TrajectorySet.from_list(trajectories, labels, subjects)
    return SyntheticCorpus(data, np.asarray(spans, np.int64).reshape(-1, 2),
                           np.asarray(amplitudes, np.float64), np.asarray(dropped, np.int64),
                           styles)


def synthetic_corpus(per_class: int = 180, people: int = 3, seed: int = 0, width: int = 640,
                     height: int = 480, fps: int = 30) -> TrajectorySet:
    """Per-frame hand-centroid trajectories of the seven thesis gestures, in pixels.

    Parameters
    ----------
    per_class : int in [1, 100000]
        Samples per gesture; the people take turns (sample ``k`` is by person
        ``k % people``).
    people : int in [1, 1000]
        Number of people, each with their own :class:`PersonStyle`.
    seed : int in [0, 2**63 - 1]
    width, height : int
        Image size (width 96..4096, height 64..4096); every point lies inside it.
    fps : int in [5, 240]
        Frame rate; the durations (15-30 rest, 40-80 motion frames at 30 fps) scale with it.

    Returns
    -------
    TrajectorySet
        ``7 * per_class`` trajectories ordered by gesture (:data:`GESTURE_NAMES`) then
        sample; ``label`` is the gesture name, ``subject`` the person (0 .. people-1).
        Points are integer-valued pixel positions ``(x, y)``, y down.

    Raises
    ------
    ValueError
        A parameter out of range, or an image too small for a gesture (the message
        names the parameter).
    """
    return generate_corpus(per_class, people, seed, width, height, fps).data


def spotted_coverage(trajectory, motion: tuple[int, int],
                     params: PipelineParams = PipelineParams()) -> float:
    """Fraction of the motion frames inside the longest flagged segment.

    The trajectory goes through the FPGA's feature chain as in
    :func:`recognition.features.camera_symbols` (integer centroid, moving average,
    gesture spotting); the longest run of flagged frames is the segment whose
    symbols the board classifies.

    Parameters
    ----------
    trajectory : (T, 2) array
        Per-frame centroids in pixels.
    motion : (first, last)
        Inclusive frame span of the true motion.

    Returns
    -------
    float in [0, 1]
    """
    pts = np.floor(np.asarray(trajectory, dtype=np.float64).reshape(-1, 2)).astype(np.int64)
    first, last = int(motion[0]), int(motion[1])
    if not 0 <= first <= last < len(pts):
        raise ValueError(f"motion must be a frame span inside the trajectory "
                         f"(0 <= first <= last < {len(pts)}), got {motion!r}")
    flag = track(pts, np.ones(len(pts), np.int64), params).flag
    if not flag.any():
        return 0.0
    edges = np.diff(np.concatenate([[0], flag.astype(np.int8), [0]]))
    starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    longest = int(np.argmax(ends - starts))
    overlap = min(ends[longest], last + 1) - max(starts[longest], first)
    return max(0, int(overlap)) / (last - first + 1)

"""Non-gesture hand motion (issue 28): what a robot operator does between
commands, which the continuous spotting must not name.

Thesis §10.1 names the rest-gesture-rest protocol as its first limitation; a
person performing commands back to back also drops the hand, scratches the
face, reaches for a cup. Each kind of :data:`DISTRACTOR_KINDS` is a seeded
path that starts and ends at the hand's position before it (so it can sit
between any two gestures):

``out-of-view``
    the hand drops below the picture, stays out, comes back;
``scratch``
    the hand goes to the face, scratches (a small fast jitter), comes back;
``reach``
    the hand reaches far to one side (for a cup), waits, comes back;
``drift``
    a slow drift away and back (about a pixel per frame at 640 wide);
``wave``
    a shapeless wave: a few sines of random frequency on each axis under a
    window;
``depth``
    the hand moves towards or away from the cameras across the disparity
    band (thesis §6.2: TL < d < TH) and back, with a little sideways drift.

Each distractor also has the hands people make in it
(:func:`distractor_hands`): a reach opens the hand and closes it round the
object, a scratch curls the fingers at the face, a wave is an open palm, a
drift a relaxed hand, ``depth`` and ``out-of-view`` any hand but a fist (the
stop posture); or, for a share
of them (:data:`COMMAND_SHARE`), the command posture throughout, so that the
trajectory's own rejection is still measured.

Paths are in units of the gesture amplitude (the renderer's 200 reference
pixels at 640 x 480; a trajectory dataset's typical gesture size), so the
renderer (:class:`sim.render.DistractorScene`) and the trajectory streams
(:mod:`recognition.streams`) draw the same motion.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from sim.gesture_shapes import minimum_jerk

__all__ = ["DISTRACTOR_KINDS", "DistractorMotion", "distractor_motion", "distractor_hands",
           "check_kind", "DEPTH_TOWARDS", "DEPTH_AWAY", "COMMAND_SHARE"]

#: The kinds of non-gesture motion (module docstring), in a fixed order.
DISTRACTOR_KINDS = ("out-of-view", "scratch", "reach", "drift", "wave", "depth")
#: Disparity change (pixels, from the hand's) of a ``depth`` distractor towards
#: the cameras and away from them: with the hand at 40 and the band 33 < d < 46
#: (the thesis' TL, TH = D - 2), both leave the band.
DEPTH_TOWARDS, DEPTH_AWAY = (7.0, 7.0), (-18.0, -10.0)


class DistractorMotion(NamedTuple):
    """One distractor, a frame per row.

    Attributes
    ----------
    kind : str
        One of :data:`DISTRACTOR_KINDS`.
    offset : (T, 2) float64
        Hand position minus the start position, in gesture amplitudes; the
        first and last rows are 0.
    disparity : (T,) float64
        Change of the hand's disparity in pixels (0 but for ``depth``).
    in_view : (T,) bool
        False while the hand is below the picture (``out-of-view``: at or
        beyond ``exit_below``): a trajectory stream has no picture edge, so
        this says where a camera would see no hand.
    hold : (int, int)
        First and last frame the hand waits at the far end (a reach at the
        object, a scratch at the face, out of view); (0, -1) for none.
    """
    kind: str
    offset: np.ndarray
    disparity: np.ndarray
    in_view: np.ndarray
    hold: tuple = (0, -1)

    @property
    def frames(self) -> int:
        return len(self.offset)


def check_kind(kind) -> str:
    """``kind`` if it is one of :data:`DISTRACTOR_KINDS`; ``ValueError`` naming them."""
    if kind not in DISTRACTOR_KINDS:
        raise ValueError(f"distractor kind must be one of {', '.join(DISTRACTOR_KINDS)}, "
                         f"got {kind!r}")
    return kind


def _frames(rng: np.random.Generator, seconds: tuple[float, float], fps: int) -> int:
    lo, hi = (max(2, round(s * fps)) for s in seconds)
    return int(rng.integers(lo, hi + 1))


def _move(start: np.ndarray, end: np.ndarray, frames: int) -> np.ndarray:
    """``frames`` positions from ``start`` (exclusive) to ``end`` (inclusive),
    minimum jerk."""
    u = minimum_jerk(np.arange(1, frames + 1) / frames)
    return start + u[:, None] * (end - start)


def _out_and_back(rng, target, fps, hold_s, *, go_s=(0.4, 0.8)) -> list:
    zero = np.zeros(2)
    go = _move(zero, target, _frames(rng, go_s, fps))
    hold = np.repeat(target[None], _frames(rng, hold_s, fps), axis=0)
    back = _move(target, zero, _frames(rng, go_s, fps))
    return [zero[None], go, hold, back]


def distractor_motion(kind: str, rng: np.random.Generator, *, fps: int = 30,
                      face=(0.0, -1.4), exit_below: float = 1.6) -> DistractorMotion:
    """A seeded distractor path (module docstring).

    Parameters
    ----------
    kind : str
        One of :data:`DISTRACTOR_KINDS`.
    rng : numpy.random.Generator
    fps : int in [5, 240]
        Frame rate; the durations are in seconds.
    face : (float, float)
        Where the face is from the start position, in gesture amplitudes
        (``scratch``).
    exit_below : float > 0
        How far down the hand must go to leave the picture, in gesture
        amplitudes (``out-of-view``).
    """
    check_kind(kind)
    if isinstance(fps, bool) or not isinstance(fps, (int, np.integer)) or not 5 <= fps <= 240:
        raise ValueError(f"fps must be an integer in [5, 240], got {fps!r}")
    face = np.asarray(face, dtype=np.float64)
    if face.shape != (2,) or not np.isfinite(face).all():
        raise ValueError(f"face must be two finite numbers, got {face!r}")
    if not (np.isfinite(exit_below) and exit_below > 0):
        raise ValueError(f"exit_below must be a positive number, got {exit_below!r}")
    if kind == "out-of-view":
        target = np.array([rng.uniform(-0.2, 0.2), exit_below * rng.uniform(1.05, 1.3)])
        parts = _out_and_back(rng, target, fps, (0.5, 2.0), go_s=(0.3, 0.6))
    elif kind == "scratch":
        target = face + rng.uniform(-0.1, 0.1, 2) + np.array([0.0, 0.25])   # cheek or chin
        parts = _out_and_back(rng, target, fps, (0.0, 0.0))
        n = _frames(rng, (0.7, 1.5), fps)
        t = np.arange(n) / fps
        rate = rng.uniform(3.0, 5.0)
        size = rng.uniform(0.03, 0.07)
        jitter = size * np.stack([np.sin(2 * np.pi * rate * t),
                                  0.5 * np.sin(4 * np.pi * rate * t + rng.uniform(0, 6.3))], 1)
        jitter *= np.sin(np.pi * (np.arange(n) + 0.5) / n)[:, None]        # fades in and out
        parts[2] = target + jitter
    elif kind == "reach":
        side = rng.choice([-1.0, 1.0])
        target = np.array([side * rng.uniform(0.9, 1.3), rng.uniform(-0.4, 0.1)])
        parts = _out_and_back(rng, target, fps, (0.3, 0.8), go_s=(0.5, 0.9))
    elif kind == "drift":
        angle = rng.uniform(0, 2 * np.pi)
        target = rng.uniform(0.25, 0.45) * np.array([np.cos(angle), np.sin(angle)])
        parts = _out_and_back(rng, target, fps, (0.2, 0.6), go_s=(2.0, 3.5))
    elif kind == "wave":
        n = _frames(rng, (1.5, 3.0), fps)
        t = np.arange(n + 1) / fps
        window = np.sin(np.pi * np.arange(n + 1) / n) ** 2
        wave = np.zeros((n + 1, 2))
        for axis in range(2):
            for _ in range(int(rng.integers(2, 4))):
                wave[:, axis] += rng.uniform(0.06, 0.18) * np.sin(
                    2 * np.pi * rng.uniform(0.4, 2.0) * t + rng.uniform(0, 2 * np.pi))
        wave = (wave - wave[0]) * window[:, None]
        parts = [wave]
    else:  # depth
        lo, hi = DEPTH_TOWARDS if rng.random() < 0.5 else DEPTH_AWAY
        change = rng.uniform(lo, hi)
        drift = rng.uniform(-0.12, 0.12, 2)
        go, hold, back = (_frames(rng, s, fps) for s in ((0.4, 0.9), (0.3, 1.0), (0.4, 0.9)))
        ramp = np.concatenate([[0.0], minimum_jerk(np.arange(1, go + 1) / go), np.ones(hold),
                               1 - minimum_jerk(np.arange(1, back + 1) / back)])
        return DistractorMotion(kind, ramp[:, None] * drift, change * ramp,
                                np.ones(len(ramp), bool), (1 + go, go + hold))
    offset = np.concatenate(parts)
    offset[-1] = 0.0
    held = (0, -1)
    if len(parts) == 4:                 # rest, go, hold, back
        first = len(parts[0]) + len(parts[1])
        held = (first, first + len(parts[2]) - 1)
    return DistractorMotion(kind, offset, np.zeros(len(offset)), offset[:, 1] < exit_below,
                            held)


#: Share of distractors made in the command posture, drawn per stream from
#: this range (:func:`distractor_hands`' ``command``).
COMMAND_SHARE = (0.2, 0.4)


def distractor_hands(motion: DistractorMotion, rng: np.random.Generator,
                     command: str | None = None) -> tuple:
    """The hand's shape in each frame of ``motion`` (names of
    :data:`sim.hand_postures.HAND_SHAPES`): the kind's (module docstring),
    or ``command`` throughout when given (a distractor made in the command
    posture)."""
    from sim.hand_postures import HAND_SHAPE_NAMES
    n = motion.frames
    if command is not None:
        return (command,) * n
    first, last = motion.hold
    if motion.kind == "reach":          # open on the way, closed round the object after
        return ("asl5",) * first + ("grasp",) * (n - first)
    if motion.kind == "scratch":        # relaxed on the way, curled at the face
        return ("relaxed",) * first + ("claw",) * (last - first + 1) + \
            ("relaxed",) * (n - last - 1)
    if motion.kind == "wave":
        return ("asl5",) * n
    if motion.kind == "drift":
        return ("relaxed",) * n
    anything = [name for name in HAND_SHAPE_NAMES if name != "fist"]   # a fist is a stop
    return (str(anything[int(rng.integers(len(anything)))]),) * n

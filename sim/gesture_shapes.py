"""The seven gesture trajectories of the thesis (Guerrero-Balaguera 2016, Fig. 16).

This module is the single definition of the gesture shapes. The scene renderer
(:mod:`sim.render`) moves the synthetic hand along them, and a synthetic
trajectory corpus for recognition can be drawn from them with per-person
variation (``aspect``, ``speed_profile``, ``time_warp``, plus amplitude, offset
and jitter applied by the caller).

Coordinates
-----------
Positions are in units of the gesture amplitude, in image axes: ``x`` grows to
the right of the image and ``y`` grows DOWNWARDS. Every path starts and ends at
the rest position ``(0, 0)`` (the hand held in front of the chest). The user
faces the cameras, so the user's right hand side is the image's LEFT side.

The shapes (each fits in a box of extent 1 along its main axes)
----------------------------------------------------------------
``forward``
    Straight up to ``(0, -1)`` and straight back.
``back``
    Straight down to ``(0, +1)`` and straight back.
``right``
    Towards the image's left edge, to ``(-1, 0)``, and back (the user's right).
``left``
    Towards the image's right edge, to ``(+1, 0)``, and back (the user's left).
``rotate-right``
    One full circle of diameter 1 lying on the image-LEFT side of the rest
    position (centre ``(-0.5, 0)``; the user's right side). The hand leaves the
    rest position moving UP, passes the top ``(-0.5, -0.5)``, the far point
    ``(-1, 0)``, the bottom ``(-0.5, +0.5)`` and returns: counter-clockwise on
    the image, i.e. clockwise as seen by the user.
``rotate-left``
    The mirror image: a circle of diameter 1 on the image-RIGHT side (centre
    ``(+0.5, 0)``). The hand leaves moving UP, passes ``(0.5, -0.5)``, ``(1, 0)``,
    ``(0.5, +0.5)`` and returns: clockwise on the image, counter-clockwise as
    seen by the user.
``stop``
    A downward-pointing equilateral triangle of side 1 whose bottom apex is the
    rest position: up-left to the top-left corner ``(-0.5, -sqrt(3)/2)``, right
    along the top edge to ``(+0.5, -sqrt(3)/2)``, then down-left back to the apex.

8-way step directions
---------------------
:func:`direction_codes` quantises the steps of a path into compass codes
(``0=E 1=NE 2=N 3=NW 4=W 5=SW 6=S 7=SE``, "N" meaning up in the image) and
merges repeats. With ``aspect=1`` the seven shapes give pairwise different
sequences::

    forward       N S
    back          S N
    right         W E
    left          E W
    rotate-right  N NW W SW S SE E NE N
    rotate-left   N NE E SE S SW W NW N
    stop          NW E SW

These hold for the default ``"smooth"`` profile with 30 or more points (with
or without a :func:`random_time_warp`); the loop sequences hold for any
``aspect`` and the ``stop`` one for ``aspect`` in about ``[0.24, 1.39]``. At
``"constant"`` speed a step that cuts a corner of ``stop`` can add a transient
code (e.g. ``NW N E S SW``).
"""
from __future__ import annotations

import math
import numbers
from typing import Callable, Tuple

import numpy as np

from soc.hps_interface import GESTURE_NAMES   # the class order the board app shares
from sw_hps.orientation import orientation_symbols

__all__ = [
    "GESTURE_NAMES", "SPEED_PROFILES", "DIRECTION_NAMES",
    "check_gesture_name", "gesture_id", "gesture_path", "random_time_warp", "direction_codes",
    "direction_names",
]


#: Accepted values of ``speed_profile`` in :func:`gesture_path`.
SPEED_PROFILES = ("smooth", "constant")

#: Names of the 8-way direction codes returned by :func:`direction_codes`.
DIRECTION_NAMES = ("E", "NE", "N", "NW", "W", "SW", "S", "SE")

_TRIANGLE_HEIGHT = math.sqrt(3.0) / 2.0

# A stroke maps s in [0, 1] (fraction of its own length) to (n, 2) positions.
_Stroke = Tuple[Callable[[np.ndarray], np.ndarray], float]   # typing: Python 3.7 runs the board tests


def _segment(start: tuple[float, float], end: tuple[float, float]) -> _Stroke:
    a = np.asarray(start, dtype=float)
    b = np.asarray(end, dtype=float)

    def at(s: np.ndarray) -> np.ndarray:
        return a + s[:, None] * (b - a)

    return at, float(np.hypot(*(b - a)))


def _loop(side: float) -> _Stroke:
    """Circle of diameter 1 through the origin, centred at ``(side * 0.5, 0)``.

    It leaves the origin moving up (``y`` decreasing) and away from the centre
    line towards ``side`` (-1: image left, +1: image right).
    """
    def at(s: np.ndarray) -> np.ndarray:
        theta = 2.0 * np.pi * s
        return np.stack([side * 0.5 * (1.0 - np.cos(theta)), -0.5 * np.sin(theta)], axis=1)

    return at, math.pi


def _strokes(name: str) -> list[_Stroke]:
    """The strokes (pieces between stops of the hand) of a gesture."""
    h = _TRIANGLE_HEIGHT
    table = {
        "forward": [_segment((0, 0), (0, -1)), _segment((0, -1), (0, 0))],
        "back": [_segment((0, 0), (0, 1)), _segment((0, 1), (0, 0))],
        "right": [_segment((0, 0), (-1, 0)), _segment((-1, 0), (0, 0))],
        "left": [_segment((0, 0), (1, 0)), _segment((1, 0), (0, 0))],
        "rotate-right": [_loop(-1.0)],
        "rotate-left": [_loop(+1.0)],
        "stop": [_segment((0, 0), (-0.5, -h)), _segment((-0.5, -h), (0.5, -h)),
                 _segment((0.5, -h), (0, 0))],
    }
    return table[check_gesture_name(name)]


def check_gesture_name(name) -> str:
    """Return ``name`` if it is one of :data:`GESTURE_NAMES`, else raise ``ValueError``."""
    if name not in GESTURE_NAMES:
        raise ValueError(f"gesture must be one of {', '.join(GESTURE_NAMES)}; got {name!r}")
    return name


def gesture_id(name: str) -> int:
    """Class id of a gesture: its index in :data:`GESTURE_NAMES`.

    Raises
    ------
    ValueError
        If ``name`` is not a gesture name (the message lists the valid names).
    """
    return GESTURE_NAMES.index(check_gesture_name(name))


def minimum_jerk(u: np.ndarray) -> np.ndarray:
    """Minimum-jerk position profile: 0 -> 1 with zero speed and acceleration at both ends."""
    return u * u * u * (10.0 + u * (-15.0 + 6.0 * u))


def _check_time_warp(time_warp, num_points: int) -> np.ndarray:
    warp = np.asarray(time_warp, dtype=float)
    if warp.shape != (num_points,):
        raise ValueError(f"time_warp must have shape ({num_points},), got {warp.shape}")
    if not np.all(np.isfinite(warp)) or np.any(np.diff(warp) < 0):
        raise ValueError("time_warp must be finite and non-decreasing")
    if abs(warp[0]) > 1e-9 or abs(warp[-1] - 1.0) > 1e-9:
        raise ValueError(f"time_warp must run from 0 to 1, got {warp[0]:g} .. {warp[-1]:g}")
    return np.clip(warp, 0.0, 1.0)


def gesture_path(name: str, num_points: int, *, aspect: float = 1.0,
                 speed_profile: str = "smooth", time_warp=None) -> np.ndarray:
    """Sample one gesture trajectory (thesis Fig. 16).

    Parameters
    ----------
    name : str
        One of :data:`GESTURE_NAMES` (see the module docstring for the exact shapes).
    num_points : int, >= 2
        Number of samples, equally spaced in (warped) time; the first and the last
        sample are the rest position ``(0, 0)``.
    aspect : float in [0.25, 4]
        Vertical stretch: every ``y`` is multiplied by ``aspect`` (a person who
        draws taller or flatter shapes).
    speed_profile : {"smooth", "constant"}
        ``"smooth"``: the hand stops at the start, at every corner/turning point
        and at the end; each stroke follows a minimum-jerk profile and takes a
        share of the time proportional to its length (a natural hand movement).
        ``"constant"``: constant speed along the whole path.
    time_warp : (num_points,) array or None
        Optional non-decreasing normalised sample times from 0 to 1 used instead
        of ``linspace(0, 1, num_points)``, e.g. from :func:`random_time_warp`.

    Returns
    -------
    (num_points, 2) float64
        Positions ``(x, y)`` in units of the amplitude, image axes (``y`` down).

    Raises
    ------
    ValueError
        Unknown gesture (message lists the valid names) or a bad parameter.
    """
    strokes = _strokes(name)
    if isinstance(num_points, bool) or not isinstance(num_points, numbers.Integral) \
            or num_points < 2:
        raise ValueError(f"num_points must be an integer >= 2, got {num_points!r}")
    num_points = int(num_points)
    if not (isinstance(aspect, numbers.Real) and 0.25 <= aspect <= 4.0):
        raise ValueError(f"aspect must be a number in [0.25, 4], got {aspect!r}")
    if speed_profile not in SPEED_PROFILES:
        raise ValueError(f"speed_profile must be one of {', '.join(SPEED_PROFILES)}; "
                         f"got {speed_profile!r}")
    times = (np.linspace(0.0, 1.0, num_points) if time_warp is None
             else _check_time_warp(time_warp, num_points))

    lengths = np.array([length for _, length in strokes])
    # Both profiles share time among strokes in proportion to their lengths, so
    # "constant" is exactly uniform speed along the whole path.
    bounds = np.concatenate([[0.0], np.cumsum(lengths) / lengths.sum()])
    index = np.clip(np.searchsorted(bounds, times, side="right") - 1, 0, len(strokes) - 1)
    local = np.clip((times - bounds[index]) / (bounds[index + 1] - bounds[index]), 0.0, 1.0)
    if speed_profile == "smooth":
        local = minimum_jerk(local)

    path = np.empty((num_points, 2))
    for k, (at, _) in enumerate(strokes):
        chosen = index == k
        if np.any(chosen):
            path[chosen] = at(local[chosen])
    path[0] = path[-1] = 0.0          # exact rest, free of rounding
    path[:, 1] *= float(aspect)
    return path


def random_time_warp(num_points: int, rng: np.random.Generator, *,
                     strength: float = 0.1) -> np.ndarray:
    """A random smooth monotone time warp for :func:`gesture_path`.

    ``w(u) = u + sum_{k=1..3} c_k sin(k pi u) / (k pi)`` with ``c_k`` drawn
    uniformly in ``[-strength, strength]``: ``w(0) = 0``, ``w(1) = 1`` and
    ``w'(u) >= 1 - 3 strength > 0``, so a person who hurries one part of a
    gesture and lingers on another.

    Parameters
    ----------
    num_points : int, >= 2
    rng : numpy.random.Generator
    strength : float in [0, 0.33]

    Returns
    -------
    (num_points,) float64, non-decreasing, from exactly 0 to exactly 1.
    """
    if isinstance(num_points, bool) or not isinstance(num_points, numbers.Integral) \
            or num_points < 2:
        raise ValueError(f"num_points must be an integer >= 2, got {num_points!r}")
    if not (isinstance(strength, numbers.Real) and 0.0 <= strength <= 0.33):
        raise ValueError(f"strength must be in [0, 0.33], got {strength!r}")
    u = np.linspace(0.0, 1.0, int(num_points))
    coeffs = rng.uniform(-strength, strength, size=3)
    k = np.arange(1, 4)[:, None]
    warp = u + np.sum(coeffs[:, None] * np.sin(k * np.pi * u) / (k * np.pi), axis=0)
    warp = np.maximum.accumulate(np.clip(warp, 0.0, 1.0))
    warp[0], warp[-1] = 0.0, 1.0
    return warp


def direction_codes(path, *, min_step: float | None = None,
                    merge_repeats: bool = True) -> tuple[int, ...]:
    """Quantise the steps of a path into 8-way compass codes.

    Parameters
    ----------
    path : (N, 2) array
        Positions in image axes (``y`` down), e.g. from :func:`gesture_path`.
    min_step : float or None
        Steps shorter than this are ignored: the hand at rest has no direction,
        and the slow steps around a stop (e.g. one straddling a corner of
        ``stop``) have an unreliable one. ``None`` means 0.2 times the longest
        step of the path.
    merge_repeats : bool
        Merge runs of the same code into one.

    Returns
    -------
    tuple of int in 0..7
        ``0=E 1=NE 2=N 3=NW 4=W 5=SW 6=S 7=SE``; "N" is up in the image. Each code
        covers a 45 degree sector centred on its direction. The numbering is the
        one of the board's orientation symbols (:mod:`sw_hps.orientation`, thesis
        Fig. 82), computed by the same integer quantiser on the path scaled by 2**16.
    """
    pts = np.asarray(path, dtype=float)
    if pts.ndim != 2 or pts.shape[1] != 2:
        raise ValueError(f"path must have shape (N, 2), got {pts.shape}")
    steps = np.diff(pts, axis=0)
    lengths = np.hypot(steps[:, 0], steps[:, 1])
    if min_step is None:
        min_step = 0.2 * float(lengths.max(initial=0.0))
    steps = steps[(lengths >= min_step) & (lengths > 0)]
    # The board's integer quantiser, on a fine fixed-point copy of the kept steps.
    track = np.cumsum(np.vstack([np.zeros((1, 2)), steps]), axis=0)
    codes = orientation_symbols(np.rint(track * 65536).astype(np.int64)).astype(int)
    if merge_repeats and codes.size:
        codes = codes[np.concatenate([[True], codes[1:] != codes[:-1]])]
    return tuple(int(c) for c in codes)


def direction_names(codes) -> tuple[str, ...]:
    """Compass names (:data:`DIRECTION_NAMES`) of direction codes."""
    return tuple(DIRECTION_NAMES[int(c)] for c in codes)

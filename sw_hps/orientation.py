"""Quantise trajectory steps into 8 orientation symbols (thesis §7.4, Fig. 82).

Runs on the board's ARM and is deployable alone: it needs Python 3 and numpy only
and imports nothing else from the project. The golden model re-exports it
(``sim.model.orientation``), so there is one implementation.
"""
from __future__ import annotations

import numpy as np

__all__ = ["NUM_SYMBOLS", "NO_SYMBOL", "orientation_symbols", "DistanceSymbols"]

#: Number of orientation symbols (45-degree sectors).
NUM_SYMBOLS = 8
#: Symbol of a zero step (no motion); callers drop these steps before the HMM.
NO_SYMBOL = -1

# 106 / 256 = 0.41406 approximates tan(22.5 deg) = 0.41421, the sector half-width.
_TAN_NUM = 106
_TAN_DEN = 256


def orientation_symbols(points) -> np.ndarray:
    """Orientation symbol of each step of a trajectory (thesis §7.4, Fig. 82).

    Parameters
    ----------
    points : (T, 2) integer array, T >= 1
        Positions ``(x, y)`` in image coordinates (y grows downward); integer pixels
        or fixed-point values (any common scale).

    Returns
    -------
    (T-1,) int8
        For step ``t`` with ``dx = x[t+1] - x[t]``, ``dy = y[t+1] - y[t]``,
        ``ax = |dx|``, ``ay = |dy|``: horizontal if ``256*ay < 106*ax``, vertical if
        ``256*ax < 106*ay``, otherwise diagonal. Symbols count counter-clockwise as a
        viewer of the image sees it: 0 right (+x), 1 up-right, 2 up (dy < 0),
        3 up-left, 4 left, 5 down-left, 6 down, 7 down-right. Thus ``dx = 0, dy < 0``
        is 2 (Fig. 82 leaves it undefined), and ``dx = dy = 0`` is ``NO_SYMBOL``
        (-1). Pure integer arithmetic, no atan.

    Raises
    ------
    ValueError
        If ``points`` is not a non-empty (T, 2) integer array, or its values are so
        large that the products above could overflow int64.
    """
    arr = np.asarray(points)
    if arr.ndim != 2 or arr.shape[1] != 2 or arr.shape[0] < 1:
        raise ValueError(f"points must have shape (T, 2) with T >= 1, got {arr.shape}")
    if arr.dtype.kind not in "iu":
        raise ValueError(f"points must have an integer dtype, got {arr.dtype}")
    if arr.size and max(abs(int(arr.min())), abs(int(arr.max()))) >= 2 ** 52:
        raise ValueError("points values must be in (-2**52, 2**52) so that steps "
                         "times 256 fit in int64")
    arr = arr.astype(np.int64)

    dx = np.diff(arr[:, 0])
    dy = np.diff(arr[:, 1])
    ax, ay = np.abs(dx), np.abs(dy)
    horizontal = _TAN_DEN * ay < _TAN_NUM * ax
    vertical = _TAN_DEN * ax < _TAN_NUM * ay
    right, up = dx > 0, dy < 0

    diagonal_symbol = np.where(up, np.where(right, 1, 3), np.where(right, 7, 5))
    symbols = np.where(horizontal, np.where(right, 0, 4),
                       np.where(vertical, np.where(up, 2, 6), diagonal_symbol))
    symbols = np.where((dx == 0) & (dy == 0), NO_SYMBOL, symbols)
    return symbols.astype(np.int8)


class DistanceSymbols:
    """Causal symbols at equal travel: a symbol each time the position has moved
    ``step`` or more (Euclidean, the positions' units) from where the last one
    was taken; its orientation is that of the whole move (thesis Fig. 82's
    sectors). A continuous stream then gives symbols at a pace set by the
    path, not by the speed, and a still or jittering hand gives none: the
    causal counterpart of resampling a whole stroke to equidistant points.
    """

    def __init__(self, step: int):
        if isinstance(step, bool) or not isinstance(step, (int, np.integer)) \
                or not 1 <= step <= 1 << 24:
            raise ValueError(f"step must be an integer in [1, {1 << 24}], got {step!r}")
        self.step = int(step)
        self._anchor = None

    def reset(self) -> None:
        """Forget the anchor (the hand left)."""
        self._anchor = None

    def push(self, point):
        """Take an integer position ``(x, y)``; its symbol, or None."""
        x, y = int(point[0]), int(point[1])
        if self._anchor is None:
            self._anchor = (x, y)
            return None
        ax, ay = self._anchor
        if (x - ax) ** 2 + (y - ay) ** 2 < self.step ** 2:
            return None
        self._anchor = (x, y)
        return int(orientation_symbols(np.array([[ax, ay], [x, y]], np.int64))[0])

    def symbols(self, points) -> np.ndarray:
        """The symbols of a whole path (None steps dropped), from a fresh anchor."""
        self.reset()
        out = [self.push(p) for p in np.asarray(points)]
        return np.array([s for s in out if s is not None], np.int8)

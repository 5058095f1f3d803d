"""Parameter and array validation: the project's one set of checks.

The golden model validates with these, and so do the hardware (which takes its
parameter ranges from the model), the SoC, the renderer, the recogniser and the
command line (with option names for ``name``). Each check raises
``ValueError`` whose message names the parameter and the allowed range, so a
bad call never ends in a traceback from deep inside numpy or Amaranth.
"""
from __future__ import annotations

import math
import numbers

import numpy as np

__all__ = [
    "check_power_of_two",
    "check_int", "check_number", "check_odd_window", "check_byte_range", "check_image",
    "check_same_shape", "check_bool_image", "check_points", "check_flags",
]


def check_int(name: str, value, lo: int | None = None, hi: int | None = None) -> int:
    """Return ``value`` as ``int`` if it is an integer in ``[lo, hi]``."""
    lo_s = "-inf" if lo is None else str(lo)
    hi_s = "inf" if hi is None else str(hi)
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        where = "" if lo is None and hi is None else f" in [{lo_s}, {hi_s}]"
        raise ValueError(f"{name} must be an integer{where}, got {value!r}")
    value = int(value)
    if (lo is not None and value < lo) or (hi is not None and value > hi):
        raise ValueError(f"{name} must be in [{lo_s}, {hi_s}], got {value}")
    return value


def check_power_of_two(name: str, value, lo: int, hi: int) -> int:
    """Return ``value`` as ``int`` if it is a power of two in ``[lo, hi]``."""
    value = check_int(name, value, lo, hi)
    if value & (value - 1):
        raise ValueError(f"{name} must be a power of two in [{lo}, {hi}], got {value}")
    return value


def check_number(name: str, value, lo: float, hi: float, *, unit: str = "",
                 lo_open: bool = False) -> float:
    """Return ``value`` as ``float`` if it is a finite real number in ``[lo, hi]``
    (``(lo, hi]`` with ``lo_open``); ``unit`` is named in the message (``"Hz"``)."""
    ok = isinstance(value, numbers.Real) and not isinstance(value, bool) \
        and math.isfinite(value) and (lo < value if lo_open else lo <= value) and value <= hi
    if not ok:
        span = f"({lo:g}, {hi:g}]" if lo_open else f"[{lo:g}, {hi:g}]"
        raise ValueError(f"{name} must be a number in {span}{' ' + unit if unit else ''}, "
                         f"got {value!r}")
    return float(value)


def check_byte_range(name: str, value) -> tuple[int, int]:
    """Return ``value`` as ``(lo, hi)`` with ``0 <= lo <= hi <= 255`` (a box edge
    of 8-bit pixel values)."""
    try:
        lo, hi = value
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a pair (lo, hi) with 0 <= lo <= hi <= 255, "
                         f"got {value!r}") from None
    lo = check_int(f"{name}[0]", lo, 0, 255)
    hi = check_int(f"{name}[1]", hi, lo, 255)
    return lo, hi


def check_odd_window(name: str, value, lo: int = 3, hi: int = 63) -> int:
    """Return ``value`` if it is an odd integer window size in ``[lo, hi]``."""
    value = check_int(name, value, lo, hi)
    if value % 2 == 0:
        raise ValueError(f"{name} must be odd in [{lo}, {hi}], got {value}")
    return value


def check_image(name: str, image, *, dtype_kind: str = "ui", max_value: int | None = None,
                min_shape: tuple[int, int] = (1, 1)) -> np.ndarray:
    """Return ``image`` as a 2-D integer ndarray, or raise ``ValueError``.

    ``dtype_kind`` lists accepted numpy dtype kinds ("u" unsigned, "i" signed,
    "b" bool). ``max_value`` bounds the pixel values (e.g. 255 for 8-bit).
    """
    arr = np.asarray(image)
    if arr.ndim != 2:
        raise ValueError(f"{name} must be a 2-D image (height, width), got shape {arr.shape}")
    if arr.dtype.kind not in dtype_kind:
        raise ValueError(f"{name} must have an integer dtype, got {arr.dtype}")
    h, w = arr.shape
    if h < min_shape[0] or w < min_shape[1]:
        raise ValueError(
            f"{name} must be at least {min_shape[1]}x{min_shape[0]} (width x height), got {w}x{h}")
    if arr.size and arr.dtype.kind in "iu":
        if arr.min() < 0 or (max_value is not None and arr.max() > max_value):
            raise ValueError(
                f"{name} values must be in [0, {max_value}], got [{arr.min()}, {arr.max()}]")
    return arr


def check_bool_image(name: str, image) -> np.ndarray:
    """Return ``image`` as a 2-D bool array; accepts bool or 0/1 integer images."""
    arr = np.asarray(image)
    if arr.ndim != 2:
        raise ValueError(f"{name} must be a 2-D mask (height, width), got shape {arr.shape}")
    if arr.dtype == bool:
        return arr
    if arr.dtype.kind not in "iu" or (arr.size and (arr.min() < 0 or arr.max() > 1)):
        raise ValueError(f"{name} must be a boolean mask (values 0 or 1)")
    return arr.astype(bool)


def check_same_shape(**arrays: np.ndarray) -> None:
    """Raise ``ValueError`` unless every keyword array has the same shape."""
    shapes = {k: np.shape(v) for k, v in arrays.items()}
    if len(set(shapes.values())) > 1:
        desc = ", ".join(f"{k} {s}" for k, s in shapes.items())
        raise ValueError(f"{' and '.join(shapes)} must have the same shape, got {desc}")


def check_points(name: str, points) -> np.ndarray:
    """Return ``points`` as an (F, 2) int64 array (x, y per frame)."""
    arr = np.asarray(points)
    if arr.ndim != 2 or arr.shape[1] != 2:
        raise ValueError(f"{name} must have shape (F, 2) (x, y per frame), got {arr.shape}")
    if arr.dtype.kind not in "iu":
        raise ValueError(f"{name} must have an integer dtype, got {arr.dtype}")
    return arr.astype(np.int64)


def check_flags(name: str, flags, frames: int) -> np.ndarray:
    """Return ``flags`` as an (F,) bool array (bool, or integers 0 and 1)."""
    arr = np.asarray(flags)
    if arr.shape != (frames,):
        raise ValueError(f"{name} must have shape ({frames},) (one flag per frame), "
                         f"got {arr.shape}")
    if arr.dtype != bool:
        if arr.dtype.kind not in "iu" or (arr.size and (arr.min() < 0 or arr.max() > 1)):
            raise ValueError(f"{name} must be boolean (values 0 or 1)")
        arr = arr.astype(bool)
    return arr

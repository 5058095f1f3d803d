"""Parameter and array validation shared by every golden-model stage.

Each check raises ``ValueError`` whose message names the parameter and the
allowed range, so a bad call never ends in a traceback from deep inside numpy.
"""
from __future__ import annotations

import numbers

import numpy as np

__all__ = [
    "check_int", "check_odd_window", "check_image", "check_same_shape",
    "check_bool_image",
]


def check_int(name: str, value, lo: int | None = None, hi: int | None = None) -> int:
    """Return ``value`` as ``int`` if it is an integer in ``[lo, hi]``."""
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise ValueError(f"{name} must be an integer, got {value!r}")
    value = int(value)
    if (lo is not None and value < lo) or (hi is not None and value > hi):
        lo_s = "-inf" if lo is None else str(lo)
        hi_s = "inf" if hi is None else str(hi)
        raise ValueError(f"{name} must be in [{lo_s}, {hi_s}], got {value}")
    return value


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

"""Binary erosion, dilation, opening and closing (thesis §6.4, Figs. 63-64, 68-69, 100).

The hand mask is cleaned with an opening by an 11x11 cross (Fig. 100: the centre
row plus the centre column of the window). Semantics follow OpenCV exactly
(``cv2.erode`` / ``cv2.dilate`` / ``cv2.morphologyEx``): the element is used as
given, never reflected, with its anchor at the centre. Taps that fall outside the
frame are ignored -- the hardware masks them with its x/y counters -- which equals
OpenCV's default constant border (1 for erosion, 0 for dilation).
"""
from __future__ import annotations

import numpy as np

from .validation import check_bool_image, check_odd_window

__all__ = ["SHAPES", "structuring_element", "resolve_element", "erode", "dilate", "opening", "closing"]

SHAPES = ("cross", "square", "diamond")
_DEFAULT_SIZE = 11


def structuring_element(shape: str = "cross", size: int = _DEFAULT_SIZE) -> np.ndarray:
    """Build a square boolean structuring element (thesis §6.4, Fig. 100).

    Parameters
    ----------
    shape : {"cross", "square", "diamond"}
        ``"cross"``: the centre row and centre column (thesis Fig. 100);
        ``"square"``: every tap; ``"diamond"``: taps with ``|dx| + |dy| <= size // 2``.
    size : odd int in [3, 63]
        Side of the window.

    Returns
    -------
    (size, size) bool
        ``True`` where the element has a tap; the centre is ``[size // 2, size // 2]``.

    Raises
    ------
    ValueError
        On an unknown ``shape`` or a ``size`` that is even or outside [3, 63].
    """
    size = check_odd_window("size", size, 3, 63)
    radius = size // 2
    offsets = np.abs(np.arange(size) - radius)
    dy, dx = offsets[:, None], offsets[None, :]
    if shape == "cross":
        return (dy == 0) | (dx == 0)
    if shape == "square":
        return np.ones((size, size), dtype=bool)
    if shape == "diamond":
        return dx + dy <= radius
    raise ValueError(f"shape must be one of {SHAPES}, got {shape!r}")


def resolve_element(element, size) -> np.ndarray:
    """A structuring element, named (``shape``, ``size``) or an array, as a bool
    array with an odd side and at least one tap; ``ValueError`` otherwise."""
    if isinstance(element, str):
        if element not in SHAPES:
            raise ValueError(f"element must be one of {SHAPES} or an odd square bool array, "
                             f"got {element!r}")
        return structuring_element(element, _DEFAULT_SIZE if size is None else size)
    if size is not None:
        raise ValueError("size applies only to a named element; "
                         "an explicit element array carries its own size")
    arr = np.asarray(element)
    if arr.ndim != 2 or arr.shape[0] != arr.shape[1] or arr.shape[0] % 2 == 0 \
            or not 1 <= arr.shape[0] <= 63:
        raise ValueError(f"element must be a square array with an odd side in [1, 63], "
                         f"got shape {arr.shape}")
    arr = check_bool_image("element", arr)
    if not arr.any():
        raise ValueError("element must contain at least one tap (True value)")
    return arr


def _combine_shifted(acc: np.ndarray, src: np.ndarray, dy: int, dx: int, op) -> None:
    """``acc[y, x] = op(acc[y, x], src[y + dy, x + dx])`` where the tap is in the frame.

    Positions whose tap leaves the frame keep ``acc`` unchanged (tap ignored).
    """
    height, width = src.shape
    if abs(dy) >= height or abs(dx) >= width:
        return
    dst_rows = slice(max(0, -dy), height - max(0, dy))
    dst_cols = slice(max(0, -dx), width - max(0, dx))
    src_rows = slice(max(0, dy), height - max(0, -dy))
    src_cols = slice(max(0, dx), width - max(0, -dx))
    view = acc[dst_rows, dst_cols]
    op(view, src[src_rows, src_cols], out=view)


def _morph(mask: np.ndarray, element: np.ndarray, op, neutral: bool) -> np.ndarray:
    """Reduce ``op`` over the element's taps, ignoring taps outside the frame.

    Separable by rows: each distinct row pattern of the element is reduced
    horizontally once, then the rows are combined vertically. Exact, because a tap
    outside the frame vertically drops its whole row and horizontally only itself.
    """
    radius = element.shape[0] // 2
    row_results: dict[tuple[int, ...], np.ndarray] = {}
    result = np.full(mask.shape, neutral, dtype=bool)
    for row in range(element.shape[0]):
        dxs = tuple(int(c) - radius for c in np.flatnonzero(element[row]))
        if not dxs:
            continue
        horizontal = row_results.get(dxs)
        if horizontal is None:
            horizontal = np.full(mask.shape, neutral, dtype=bool)
            for dx in dxs:
                _combine_shifted(horizontal, mask, 0, dx, op)
            row_results[dxs] = horizontal
        _combine_shifted(result, horizontal, row - radius, 0, op)
    return result


_ELEMENT_DOC = """
    Parameters
    ----------
    mask : (H, W) bool, or integer array of 0/1
    element : {"cross", "square", "diamond"} or (k, k) bool array, k odd in [1, 63]
        A shape name (built with :func:`structuring_element` at ``size``) or an
        explicit element whose anchor is its centre ``[k // 2, k // 2]``; it must have
        at least one tap. The element is not reflected (OpenCV convention).
    size : odd int in [3, 63], optional
        Window side for a named element (default 11); must be omitted for an array.
"""


def erode(mask, element="cross", *, size: int | None = None) -> np.ndarray:
    """Binary erosion (thesis §6.4, Figs. 63-64).
    {params}
    Returns
    -------
    (H, W) bool
        ``out[y, x] = AND of mask[y + dy, x + dx]`` over the taps
        ``(dy, dx) = (i - k // 2, j - k // 2)`` with ``element[i, j]`` set. Border
        policy: taps outside the frame are ignored (count as 1), as ``cv2.erode``.

    Raises
    ------
    ValueError
        On a malformed mask or element, or a bad ``size``.
    """
    mask = check_bool_image("mask", mask)
    return _morph(mask, resolve_element(element, size), np.logical_and, True)


def dilate(mask, element="cross", *, size: int | None = None) -> np.ndarray:
    """Binary dilation (thesis §6.4, Figs. 68-69).
    {params}
    Returns
    -------
    (H, W) bool
        ``out[y, x] = OR of mask[y + dy, x + dx]`` over the taps
        ``(dy, dx) = (i - k // 2, j - k // 2)`` with ``element[i, j]`` set (no
        reflection, as ``cv2.dilate``). Border policy: taps outside the frame are
        ignored (count as 0).

    Raises
    ------
    ValueError
        On a malformed mask or element, or a bad ``size``.
    """
    mask = check_bool_image("mask", mask)
    return _morph(mask, resolve_element(element, size), np.logical_or, False)


def opening(mask, element="cross", *, size: int | None = None) -> np.ndarray:
    """Morphological opening: erosion then dilation (thesis §6.4, Fig. 100).
    {params}
    Returns
    -------
    (H, W) bool
        ``dilate(erode(mask, element), element)`` with the same, unreflected element,
        equal to ``cv2.morphologyEx(..., cv2.MORPH_OPEN, element)``. For an asymmetric
        element this differs from the textbook opening, which dilates with the
        reflected element. Border policy as :func:`erode` and :func:`dilate`.

    Raises
    ------
    ValueError
        On a malformed mask or element, or a bad ``size``.
    """
    mask = check_bool_image("mask", mask)
    element = resolve_element(element, size)
    return _morph(_morph(mask, element, np.logical_and, True), element, np.logical_or, False)


def closing(mask, element="cross", *, size: int | None = None) -> np.ndarray:
    """Morphological closing: dilation then erosion (thesis §6.4).
    {params}
    Returns
    -------
    (H, W) bool
        ``erode(dilate(mask, element), element)`` with the same, unreflected element,
        equal to ``cv2.morphologyEx(..., cv2.MORPH_CLOSE, element)``. Border policy as
        :func:`erode` and :func:`dilate`.

    Raises
    ------
    ValueError
        On a malformed mask or element, or a bad ``size``.
    """
    mask = check_bool_image("mask", mask)
    element = resolve_element(element, size)
    return _morph(_morph(mask, element, np.logical_or, False), element, np.logical_and, True)


# Shared parameter section; docstrings are None under ``python -OO``.
for _func in (erode, dilate, opening, closing):
    if _func.__doc__:
        _func.__doc__ = _func.__doc__.replace("    {params}", _ELEMENT_DOC)
del _func

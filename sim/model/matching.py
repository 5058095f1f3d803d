"""Census matching cost, window aggregation and disparity selection (thesis §6.2).

Stages, as in the Fife & Archibald stream architecture the thesis follows:

1. Hamming distance between the left census code and the right census code
   ``d`` pixels to the left (eq. 2, Fig. 48);
2. SHD: its sum over a ``hamming_window`` x ``hamming_window`` window (Wh,
   eq. 3, Figs. 49 and 51);
3. winner-take-all over d = 0 .. D-1 for the left-to-right (L2R) and the
   right-to-left (R2L) maps with the best-of selector of Fig. 55: of two
   candidates the later one wins only when its cost is strictly smaller
   (``C1 > C2`` takes 2), so ties keep the smaller disparity;
4. left-right consistency check (eq. 21, Figs. 43 and 56).

Border policy (copied by the hardware):

* A window position outside the frame contributes 0 to the SHD, the same
  for every candidate disparity, so the frame borders bias no candidate.
* The left band: left pixel x' has a right partner at x' - d only when
  ``d <= x'``. A window position without a partner costs ``no_match_cost``
  (default a third of the census bits, the value measured best on the
  Middlebury scenes, see docs/figures/stereo.md). The L2R search covers all D
  disparities at every pixel, so a left-band pixel whose match lies partly
  outside the right image still gets an answer instead of giving up.
* The R2L search at right pixel x covers d = 0 .. min(D-1, W-1-x): the
  left pixel x + d must exist.
* The consistency check keeps a left pixel whose partner x - d is outside
  the right image (nothing to check it against).
"""
from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor
from typing import NamedTuple

import numpy as np

from .validation import check_image, check_int, check_odd_window, check_same_shape

__all__ = [
    "HAMMING_WINDOW_RANGE", "MAX_DISPARITY_RANGE", "default_no_match_cost",
    "hamming_volume", "column_sum", "row_sum", "window_sum", "shd_volume", "winner_take_all",
    "lr_consistency", "DisparityMaps", "disparity_maps",
]

HAMMING_WINDOW_RANGE = (1, 63)
MAX_DISPARITY_RANGE = (1, 256)


def default_no_match_cost(census_bits: int) -> int:
    """Cost of a window position without a right partner: a third of the census bits."""
    return census_bits // 3


def _check_census_pair(census_left, census_right):
    cl = np.asarray(census_left)
    cr = np.asarray(census_right)
    for name, arr in (("census_left", cl), ("census_right", cr)):
        if arr.ndim != 2 or arr.dtype.kind != "u":
            raise ValueError(f"{name} must be a 2-D unsigned census code image, "
                             f"got shape {arr.shape} dtype {arr.dtype}")
    check_same_shape(census_left=cl, census_right=cr)
    return cl, cr


def _check_disparity(max_disparity, width):
    return check_int("max_disparity", max_disparity, MAX_DISPARITY_RANGE[0],
                     min(MAX_DISPARITY_RANGE[1], width))


def _sum_dtype(window_area: int, max_term: int):
    """Smallest unsigned dtype in which a window sum cannot overflow."""
    return np.uint16 if window_area * max_term < 1 << 16 else np.uint32


def hamming_volume(census_left, census_right, max_disparity: int,
                   census_bits: int, no_match_cost: int | None = None) -> np.ndarray:
    """Hamming distances for every disparity (thesis eq. 2, Fig. 48).

    ``volume[d, y, x] = popcount(census_left[y, x] ^ census_right[y, x - d])``
    for ``x >= d`` and ``no_match_cost`` for ``x < d``.

    Returns
    -------
    volume : (D, H, W) uint8
    """
    cl, cr = _check_census_pair(census_left, census_right)
    h, w = cl.shape
    ndisp = _check_disparity(max_disparity, w)
    census_bits = check_int("census_bits", census_bits, 1, 64)
    if no_match_cost is None:
        no_match_cost = default_no_match_cost(census_bits)
    no_match_cost = check_int("no_match_cost", no_match_cost, 0, census_bits)
    vol = np.full((ndisp, h, w), no_match_cost, dtype=np.uint8)
    for d in range(ndisp):
        vol[d, :, d:] = np.bitwise_count(cl[:, d:] ^ cr[:, :w - d])
    return vol


def _check_sum_input(values, window):
    arr = np.asarray(values)
    window = check_odd_window("hamming_window", window, *HAMMING_WINDOW_RANGE)
    if arr.ndim < 2 or arr.dtype.kind not in "ui":
        raise ValueError(f"values must be an integer array with at least 2 axes, got {arr.shape}")
    max_term = int(arr.max()) if arr.size else 0
    return arr, window, max(max_term, 1)


def column_sum(values, window: int) -> np.ndarray:
    """Sum over the ``window`` rows centred on each pixel (the column sums C_d
    of Figs. 49 and 51, :class:`hdl.column_sum.ColumnSum`).

    Works on the second-last axis; rows outside the frame count 0. The sum is
    computed in the smallest unsigned dtype that cannot overflow.
    """
    arr, window, max_term = _check_sum_input(values, window)
    return _axis_sum(arr, window, -2, _sum_dtype(window, max_term))


def row_sum(values, window: int) -> np.ndarray:
    """Sum over the ``window`` columns centred on each pixel (the window sums
    S_d of column sums, :class:`hdl.window_sum.WindowSum`).

    Works on the last axis; columns outside the frame count 0.
    """
    arr, window, max_term = _check_sum_input(values, window)
    return _axis_sum(arr, window, -1, _sum_dtype(window, max_term))


def window_sum(values, window: int) -> np.ndarray:
    """Sum over a ``window`` x ``window`` box centred on each pixel (eq. 3):
    :func:`row_sum` of :func:`column_sum`.

    Works on the last two axes; positions outside the frame count 0. The sum
    is computed in the smallest unsigned dtype that cannot overflow.
    """
    arr, window, max_term = _check_sum_input(values, window)
    return _box_sum(arr, window, _sum_dtype(window * window, max_term))


def _sliding_sum(values, window: int, axis: int):
    """Sums of ``window`` consecutive entries along ``axis`` (length L-window+1).

    Built from power-of-two partial sums (S_2p[i] = S_p[i] + S_p[i+p]), so
    it costs about 2 log2(window) whole-array additions, all vectorised.
    """
    def part(arr, start, stop):
        index = [slice(None)] * arr.ndim
        index[axis] = slice(start, stop)
        return arr[tuple(index)]

    n = values.shape[axis] - window + 1
    total, offset, partial, span = None, 0, values, 1
    while span <= window:
        if window & span:
            piece = part(partial, offset, offset + n)
            total = piece.copy() if total is None else np.add(total, piece, out=total)
            offset += span
        if 2 * span <= window:
            m = partial.shape[axis] - span
            partial = part(partial, 0, m) + part(partial, span, span + m)
        span *= 2
    return total


def _axis_sum(arr, window, axis, dtype):
    """Zero-padded sums of ``window`` entries centred on each one along ``axis``."""
    r = window // 2
    pad = [(0, 0)] * arr.ndim
    pad[axis] = (r, r)
    return _sliding_sum(np.pad(arr.astype(dtype, copy=False), pad), window, axis)


def _box_sum(arr, window, dtype):
    """Zero-padded ``window`` x ``window`` box sum over the last two axes."""
    return _axis_sum(_axis_sum(arr, window, -2, dtype), window, -1, dtype)


def shd_volume(census_left, census_right, hamming_window: int, max_disparity: int,
               census_bits: int, no_match_cost: int | None = None) -> np.ndarray:
    """Sum of Hamming distances for every disparity: (D, H, W) costs (eq. 3)."""
    return window_sum(hamming_volume(census_left, census_right, max_disparity,
                                     census_bits, no_match_cost), hamming_window)


def winner_take_all(shd) -> tuple[np.ndarray, np.ndarray]:
    """L2R and R2L disparity maps from an SHD volume (Figs. 45 and 55).

    ``l2r[y, x]`` is the d in 0 .. D-1 of least ``shd[d, y, x]``;
    ``r2l[y, x]`` is the d in 0 .. min(D-1, W-1-x) of least
    ``shd[d, y, x + d]`` (the same left-pixel cost seen from the right image).
    Ties keep the smaller d. Both maps are uint8 (uint16 when D > 256 is
    impossible: D <= 256).
    """
    vol = np.asarray(shd)
    if vol.ndim != 3:
        raise ValueError(f"shd must be a (D, H, W) volume, got shape {vol.shape}")
    ndisp, h, w = vol.shape
    big = np.iinfo(np.uint32).max
    cost = vol.astype(np.uint32)
    l2r = np.argmin(cost, axis=0)
    # R2L: right pixel x sees left pixel x + d.
    r2l_cost = np.full_like(cost, big)
    for d in range(ndisp):
        r2l_cost[d, :, :w - d] = cost[d, :, d:]
    r2l = np.argmin(r2l_cost, axis=0)
    return l2r.astype(np.uint8), r2l.astype(np.uint8)


def lr_consistency(l2r, r2l, threshold: int) -> np.ndarray:
    """Left-right consistency check (thesis eq. 21, Figs. 43 and 56).

    A left pixel keeps its disparity ``d = l2r[y, x]`` when
    ``|d - r2l[y, x - d]| < threshold`` (Th), or when ``x - d < 0`` (its
    partner lies outside the right image: nothing to check against);
    otherwise it becomes 0, the invalid value (so a true disparity of 0
    cannot be told from invalid).

    Parameters
    ----------
    l2r, r2l : (H, W) uint8 disparity maps
    threshold : int in [1, 256]
    """
    left = check_image("l2r", l2r, max_value=255)
    right = check_image("r2l", r2l, max_value=255)
    check_same_shape(l2r=left, r2l=right)
    threshold = check_int("threshold", threshold, 1, 256)
    h, w = left.shape
    cols = np.arange(w)[None, :]
    partner = cols - left.astype(np.int64)
    outside = partner < 0
    rows = np.arange(h)[:, None]
    seen = right[rows, np.maximum(partner, 0)].astype(np.int64)
    keep = outside | (np.abs(left.astype(np.int64) - seen) < threshold)
    return np.where(keep, left, 0).astype(np.uint8)


class DisparityMaps(NamedTuple):
    """Result of :func:`disparity_maps`: the two winner-take-all maps."""
    l2r: np.ndarray
    r2l: np.ndarray


def _maps_for_rows(cl, cr, y0, y1, window, ndisp, no_match_cost, dtype):
    """L2R and R2L maps for rows [y0, y1), streaming over d (no cost volume)."""
    h, w = cl.shape
    r = window // 2
    # Rows the windows of rows [y0, y1) touch; outside the frame counts 0.
    t0, t1 = max(0, y0 - r), min(h, y1 + r)
    top = r - (y0 - t0)
    cl_rows, cr_rows = cl[t0:t1], cr[t0:t1]
    n = y1 - y0
    big = np.iinfo(dtype).max
    best_l = np.full((n, w), big, dtype=dtype)
    disp_l = np.zeros((n, w), dtype=np.uint8)
    best_r = np.full((n, w), big, dtype=dtype)
    disp_r = np.zeros((n, w), dtype=np.uint8)
    ham = np.zeros((n + window - 1, w + window - 1), dtype=dtype)
    body = ham[top:top + (t1 - t0), r:r + w]
    for d in range(ndisp):
        body[:, :d] = no_match_cost
        body[:, d:] = np.bitwise_count(cl_rows[:, d:] ^ cr_rows[:, :w - d])
        cost = _sliding_sum(_sliding_sum(ham, window, 0), window, 1)
        # L2R: strict '<' keeps the smaller d on ties (Fig. 55).
        better = cost < best_l
        np.copyto(best_l, cost, where=better)
        np.copyto(disp_l, d, where=better)
        # R2L: right pixel x sees the cost of left pixel x + d.
        seen = cost[:, d:]
        better = seen < best_r[:, :w - d]
        np.copyto(best_r[:, :w - d], seen, where=better)
        np.copyto(disp_r[:, :w - d], d, where=better)
    return disp_l, disp_r


def disparity_maps(census_left, census_right, hamming_window: int = 29,
                   max_disparity: int = 48, census_bits: int = 24,
                   no_match_cost: int | None = None, threads: int | None = None
                   ) -> DisparityMaps:
    """L2R and R2L winner-take-all maps without storing the cost volume.

    Same result as ``winner_take_all(shd_volume(...))`` (tested), computed
    one disparity at a time on horizontal strips of the image in ``threads``
    worker threads (default: the number of CPUs, at most 4).
    """
    cl, cr = _check_census_pair(census_left, census_right)
    h, w = cl.shape
    window = check_odd_window("hamming_window", hamming_window, *HAMMING_WINDOW_RANGE)
    ndisp = _check_disparity(max_disparity, w)
    census_bits = check_int("census_bits", census_bits, 1, 64)
    if no_match_cost is None:
        no_match_cost = default_no_match_cost(census_bits)
    no_match_cost = check_int("no_match_cost", no_match_cost, 0, census_bits)
    if threads is None:
        threads = min(4, os.cpu_count() or 1)
    threads = check_int("threads", threads, 1, 64)
    dtype = _sum_dtype(window * window, census_bits)
    strips = min(threads, h)
    bounds = [h * i // strips for i in range(strips + 1)]
    jobs = [(bounds[i], bounds[i + 1]) for i in range(strips)]
    if strips == 1:
        parts = [_maps_for_rows(cl, cr, 0, h, window, ndisp, no_match_cost, dtype)]
    else:
        with ThreadPoolExecutor(max_workers=strips) as pool:
            parts = list(pool.map(
                lambda job: _maps_for_rows(cl, cr, job[0], job[1], window, ndisp,
                                           no_match_cost, dtype), jobs))
    return DisparityMaps(np.concatenate([p[0] for p in parts]),
                         np.concatenate([p[1] for p in parts]))

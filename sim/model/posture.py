"""The hand's posture: a shape-preserving mask and a one-pass shape descriptor
(thesis §10.1, future work: "the configuration of the hand" for "more complex
gestures").

The 11x11 opening that feeds the centroid (thesis §6.4) cuts fingers to stubs.
The posture's mask is the segmented mask (skin AND band) after a 3x3 square
opening, which keeps fingers 3 px wide and removes speckle.

The descriptor is what the hardware accumulates while that mask streams past,
one pixel per clock, about a reference taken from the previous two frames'
registers (:func:`next_reference`: where the hand's top and column will be if
it moves on as it did; a still picture presented three times is described
about its own):

* the frame's own statistics: area, sums of x and y, second moments, bounding
  box (they give the next frame's reference);
* **polar occupancy**: per mask pixel, its angular sector (``SECTORS`` of
  11.25 degrees, counted anticlockwise from pointing right) and its ring (radius
  below 0.5, 0.75, 1, 1.25 hand widths, or beyond) about the reference anchor;
  one counter per (ring, sector);
* **finger crossings**: per row, the number of mask runs that start in it; the
  rows from the anchor up to 1.5 hand widths above it are grouped in ``BANDS``
  bands, and each band keeps the sum of its rows' counts, its rows and the
  largest count. Raised fingers cross a row as separate runs.

The anchor and the scale are the previous frame's **hand width** W (bounding
box) and **top**: anchor column = the previous centroid's x, anchor row = top
+ W // 2. A forearm hanging below the hand moves neither (it moves the centroid
and the area, which is why they are not the anchor and the scale).

Every comparison is on integers (the sector against a Q12 tangent table, the
rings and bands as products of W), as the hardware does it.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from soc.hps_interface import (POSTURE_BAND_SPAN, POSTURE_BANDS, POSTURE_RING_EDGES_16THS,
                               POSTURE_RINGS, POSTURE_SECTORS, POSTURE_WORD_COUNT,
                               posture_word_offsets)
from sw_hps.posture import posture_features as board_features

from .morphology import opening
from .validation import check_bool_image

__all__ = ["SECTORS", "RINGS", "RING_EDGES_16THS", "BANDS", "BAND_SPAN", "FEATURES",
           "PostureReference", "PostureRegisters", "posture_mask", "posture_registers",
           "posture_reference", "next_reference", "posture_features", "describe_still", "sector_of",
           "posture_words",
           "TAN_Q", "TANGENTS"]

# The descriptor's geometry is what the FPGA and the board agree on.
SECTORS = POSTURE_SECTORS
RING_EDGES_16THS = POSTURE_RING_EDGES_16THS
RINGS = POSTURE_RINGS
#: Band b holds the rows with 3 W b <= 16 (anchor row - y) < 3 W (b + 1).
BANDS = POSTURE_BANDS
BAND_SPAN = POSTURE_BAND_SPAN     # 1.5 W over 8 bands: 3/16 W per band
#: Fraction bits of the tangent table.
TAN_Q = 12
#: tan(j * 360 / SECTORS degrees) in Q12 for j = 1 .. SECTORS / 8 - 1: the
#: sector boundaries inside an octant.
TANGENTS = tuple(int(round(math.tan(j * 2 * math.pi / SECTORS) * (1 << TAN_Q)))
                 for j in range(1, SECTORS // 8))
#: Length of the feature vector :func:`posture_features` gives.
FEATURES = SECTORS * RINGS + 2 * BANDS
#: The posture mask's opening.
OPENING = ("square", 3)


class PostureReference(NamedTuple):
    """What the descriptor of a frame is taken about: the previous frame's
    centroid column ``x``, top row ``top`` and hand width ``width``
    (``width == 0``: no hand then, the frame's descriptor is all zero)."""

    x: int
    top: int
    width: int

    @property
    def anchor_y(self) -> int:
        return self.top + self.width // 2


class PostureRegisters(NamedTuple):
    """One frame's descriptor, as the hardware's registers hold it."""

    area: int
    sum_x: int
    sum_y: int
    sum_xx: int
    sum_yy: int
    sum_xy: int
    #: bounding box (inclusive); all 0 for an empty mask
    x_min: int
    x_max: int
    y_min: int
    y_max: int
    #: (RINGS * SECTORS) counts, index ring * SECTORS + sector
    polar: tuple
    #: per band: the sum of the rows' run starts, the rows, the largest count
    band_sum: tuple
    band_rows: tuple
    band_max: tuple


def posture_mask(hand) -> np.ndarray:
    """The posture's mask: ``hand`` (skin AND band, bool H x W) after a 3x3
    square opening (taps outside the frame ignored, as in
    :func:`sim.model.morphology.opening`)."""
    hand = check_bool_image("hand", hand)
    return opening(hand, OPENING[0], size=OPENING[1])


def sector_of(dx, dyu) -> np.ndarray:
    """The sector (0 .. SECTORS - 1) of integer offsets ``dx`` (right) and
    ``dyu`` (up): sector k spans [k, k + 1) * 360 / SECTORS degrees
    anticlockwise from pointing right; (0, 0) is sector 0.

    The hardware's way: fold into the quadrant (u > 0, v >= 0), then count the
    octant's boundaries below the angle with ``minor << TAN_Q >= major * t``."""
    dx = np.asarray(dx, np.int64)
    dyu = np.asarray(dyu, np.int64)
    quadrant = np.select([(dx > 0) & (dyu >= 0), (dx <= 0) & (dyu > 0),
                          (dx < 0) & (dyu <= 0)], [0, 1, 2], 3)
    u = np.choose(quadrant, [dx, dyu, -dx, -dyu])
    v = np.choose(quadrant, [dyu, -dx, -dyu, dx])
    low = v < u
    major, minor = np.where(low, u, v), np.where(low, v, u)
    count = np.zeros(np.broadcast(dx, dyu).shape, np.int64)
    for t in TANGENTS:
        count += (minor << TAN_Q) >= major * t
    quarter = SECTORS // 4
    sector = quadrant * quarter + np.where(low, count, quarter - 1 - count)
    return np.where((dx == 0) & (dyu == 0), 0, sector)


def posture_registers(mask, reference: PostureReference) -> PostureRegisters:
    """The descriptor of one frame's posture mask about ``reference``."""
    mask = check_bool_image("mask", mask)
    height, width = mask.shape
    ys, xs = np.nonzero(mask)
    xs, ys = xs.astype(np.int64), ys.astype(np.int64)
    area = len(xs)
    polar = np.zeros(RINGS * SECTORS, np.int64)
    band_sum = np.zeros(BANDS, np.int64)
    band_rows = np.zeros(BANDS, np.int64)
    band_max = np.zeros(BANDS, np.int64)
    w = reference.width
    if w > 0:
        dx, dyu = xs - reference.x, reference.anchor_y - ys
        r2_16 = 16 * (dx * dx + dyu * dyu)
        ring = sum((r2_16 >= edge * w * w).astype(np.int64) for edge in RING_EDGES_16THS)
        polar = np.bincount(ring * SECTORS + sector_of(dx, dyu), minlength=RINGS * SECTORS)
        # run starts per row (a set pixel whose left neighbour is clear, or x = 0)
        starts = mask & ~np.pad(mask, ((0, 0), (1, 0)))[:, :width]
        per_row = starts.sum(axis=1).astype(np.int64)
        num, den = BAND_SPAN
        up = reference.anchor_y - np.arange(height, dtype=np.int64)
        inside = (up >= 0) & (den * up < num * w * BANDS)
        band = np.where(inside, den * np.maximum(up, 0) // max(num * w, 1), 0)
        for b in range(BANDS):
            rows = inside & (band == b)
            band_sum[b] = per_row[rows].sum()
            band_rows[b] = rows.sum()
            band_max[b] = per_row[rows].max(initial=0)
    box = (int(xs.min()), int(xs.max()), int(ys.min()), int(ys.max())) if area else (0, 0, 0, 0)
    return PostureRegisters(
        area, int(xs.sum()), int(ys.sum()), int((xs * xs).sum()), int((ys * ys).sum()),
        int((xs * ys).sum()), *box, tuple(int(v) for v in polar),
        tuple(int(v) for v in band_sum), tuple(int(v) for v in band_rows),
        tuple(int(v) for v in band_max))


def posture_reference(registers: PostureRegisters) -> PostureReference:
    """The next frame's reference from this frame's registers: the centroid's
    column ``sum_x // area``, the top row and the width of the bounding box
    (all 0 without a hand)."""
    if registers.area == 0:
        return PostureReference(0, 0, 0)
    return PostureReference(registers.sum_x // registers.area, registers.y_min,
                            registers.x_max - registers.x_min + 1)


def next_reference(latest: PostureReference, before: PostureReference, width: int,
                   height: int) -> PostureReference:
    """The reference the next frame's descriptor is about, from the last two
    frames' own references (:func:`posture_reference`): the latest one, its
    column and top moved on by their change since the one before when both
    saw a hand (a hand in motion is described about where it is now, not
    where it was), clamped to the ``width`` x ``height`` frame; the width is
    the latest. A still hand's is its own."""
    if latest.width == 0 or before.width == 0:
        return latest
    return PostureReference(min(max(2 * latest.x - before.x, 0), width - 1),
                            min(max(2 * latest.top - before.top, 0), height - 1),
                            latest.width)


def posture_features(registers: PostureRegisters, reference: PostureReference) -> np.ndarray:
    """The classifier's input (FEATURES floats), as the board computes it
    (:func:`sw_hps.posture.posture_features`): each polar count over W squared,
    then per band the mean run starts per row and the largest. All zero
    without a hand in the reference."""
    return board_features(registers.polar, registers.band_sum, registers.band_rows,
                          registers.band_max, reference.width)


def describe_still(hand) -> tuple[PostureRegisters, np.ndarray]:
    """A still picture's descriptor as the hardware gives it: the picture's
    posture mask presented twice, the second frame's registers about the
    first's reference (the frame before it had no hand, so nothing is
    predicted); returns those registers and the features."""
    mask = posture_mask(hand)
    empty = PostureReference(0, 0, 0)
    reference = posture_reference(posture_registers(mask, empty))
    registers = posture_registers(mask, reference)
    return registers, posture_features(registers, reference)


def posture_words(registers: PostureRegisters, reference: PostureReference) -> list:
    """The frame's record as the hardware sends it: the 32-bit words of
    :data:`soc.hps_interface.POSTURE_WORDS` (``POSTURE_WORD_COUNT`` of them)."""
    at = posture_word_offsets()
    words = [0] * POSTURE_WORD_COUNT
    mask = (1 << 32) - 1

    def pair(low, high):
        return low | high << 16

    words[at["reference"]] = pair(reference.x, reference.top)
    words[at["reference_width"]] = reference.width
    words[at["area"]] = registers.area
    for name in ("sum_x", "sum_y", "sum_xx", "sum_yy", "sum_xy"):
        value = getattr(registers, name)
        words[at[name]:at[name] + 2] = [value & mask, value >> 32]
    words[at["box_x"]] = pair(registers.x_min, registers.x_max)
    words[at["box_y"]] = pair(registers.y_min, registers.y_max)
    words[at["band_sum"]:at["band_sum"] + BANDS] = registers.band_sum
    words[at["band_rows_max"]:at["band_rows_max"] + BANDS] = [
        pair(rows, top) for rows, top in zip(registers.band_rows, registers.band_max)]
    words[at["polar"]:] = registers.polar
    return [int(w) for w in words]

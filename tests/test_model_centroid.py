"""Tests for sim.model.centroid (thesis §7.1, eq. 23-24, Fig. 72)."""
import math

import cv2
import numpy as np
import pytest

from sim.model.centroid import Centroid, centroid, counted_pixels, moment_widths


def _cv_centroid(mask):
    m = cv2.moments(mask.astype(np.uint8), binaryImage=True)
    return math.floor(m["m10"] / m["m00"]), math.floor(m["m01"] / m["m00"]), round(m["m00"])


@pytest.mark.parametrize("shape, density", [((7, 9), 0.5), ((48, 64), 0.1), ((480, 640), 0.3),
                                            ((480, 640), 0.001)])
def test_matches_opencv_moments(shape, density):
    rng = np.random.default_rng(shape[0] + int(density * 1000))
    mask = rng.random(shape) < density
    result = centroid(mask)
    assert isinstance(result, Centroid)
    assert all(type(v) is int for v in result)
    assert tuple(result) == _cv_centroid(mask)


def test_floor_not_round():
    mask = np.zeros((5, 5), bool)
    mask[0, 1] = mask[3, 2] = True          # mean x = 1.5, mean y = 1.5
    assert centroid(mask) == Centroid(1, 1, 2)
    mask[4, 2] = True                       # mean x = 5/3, mean y = 7/3
    assert centroid(mask) == Centroid(1, 2, 3)


def test_empty_mask_means_no_hand():
    assert centroid(np.zeros((480, 640), bool)) == Centroid(0, 0, 0)


def test_full_mask():
    assert centroid(np.ones((480, 640), np.uint8)) == Centroid(319, 239, 480 * 640)
    assert centroid(np.ones((3, 6), bool)) == Centroid(2, 1, 18)


def test_single_pixel():
    for y, x in [(0, 0), (479, 639), (123, 45)]:
        mask = np.zeros((480, 640), bool)
        mask[y, x] = True
        assert centroid(mask) == Centroid(x, y, 1)


@pytest.mark.parametrize("bad", [np.full((3, 3), 2), np.zeros((3, 3), float), np.zeros(9, bool),
                                 np.zeros((3, 3, 2), bool)])
def test_rejects_bad_mask(bad):
    with pytest.raises(ValueError, match="mask"):
        centroid(bad)


def test_moment_widths_vga():
    # Full 640x480 mask: M00 = 307200 < 2**19, M10 = 98150400 < 2**27, M01 = 73574400 < 2**27.
    assert tuple(moment_widths(640, 480)) == (19, 27, 27)


@pytest.mark.parametrize("width, height", [(1, 1), (2, 3), (5, 4), (16, 16), (33, 7)])
def test_moment_widths_hold_full_mask_tightly(width, height):
    xs, ys = np.meshgrid(np.arange(width), np.arange(height))
    maxima = (width * height, int(xs.sum()), int(ys.sum()))
    widths = moment_widths(width, height)
    for value, bits in zip(maxima, widths):
        assert value < 2 ** bits
        assert bits == 1 or value >= 2 ** (bits - 1)


@pytest.mark.parametrize("name, args", [("width", (0, 480)), ("width", (70000, 480)),
                                        ("height", (640, 0)), ("height", (640, 2.5))])
def test_moment_widths_rejects_bad_size(name, args):
    with pytest.raises(ValueError, match=name):
        moment_widths(*args)


# ---------------------------------------------------------------- hand tracking


def _counted_in_raster_order(mask, previous, track_gate, hand_rows):
    """counted_pixels as the hardware decides it, pixel by pixel in raster order."""
    height, width = mask.shape
    gate = (0, width - 1, 0, height - 1)
    if track_gate and previous is not None and previous[2] > 0:
        px, py = previous[:2]
        gate = (max(px - track_gate, 0), min(px + track_gate, width - 1),
                max(py - track_gate, 0), min(py + track_gate, height - 1))
    out = np.zeros_like(mask)
    row_end = None
    for y in range(height):
        for x in range(width):
            count = (mask[y, x] and gate[0] <= x <= gate[1] and gate[2] <= y <= gate[3]
                     and (not hand_rows or row_end is None or y < row_end))
            if count and hand_rows and row_end is None:
                row_end = y + hand_rows
            out[y, x] = count
    return out


@pytest.mark.parametrize("seed", range(6))
def test_counted_pixels_equals_the_raster_order_decision(seed):
    rng = np.random.default_rng(seed)
    height, width = 11, 17
    mask = rng.random((height, width)) < 0.3
    previous = [None, Centroid(int(rng.integers(width)), int(rng.integers(height)), 5),
                Centroid(3, 4, 0)][seed % 3]
    for track_gate, hand_rows in ((0, 0), (3, 0), (0, 2), (2, 3), (20, 1), (1, 20)):
        got = counted_pixels(mask, previous=previous, track_gate=track_gate,
                             hand_rows=hand_rows)
        assert np.array_equal(got, _counted_in_raster_order(mask, previous, track_gate,
                                                            hand_rows)), (track_gate, hand_rows)
        assert centroid(mask, previous=previous, track_gate=track_gate,
                        hand_rows=hand_rows) == centroid(got)


def test_tracking_keeps_the_hand_and_drops_forearm_and_intruder():
    mask = np.zeros((60, 80), bool)
    mask[20:30, 30:40] = True                   # the hand, centre (34, 24)
    mask[30:60, 33:37] = True                   # the forearm below it, to the edge
    mask[2:12, 70:78] = True                    # a second blob (the intruder)
    hand = Centroid(34, 24, 100)
    assert centroid(mask) != hand               # the thesis' centroid is dragged away
    assert centroid(mask, previous=(35, 26, 80), track_gate=15, hand_rows=10) == hand
    # Without the gate the intruder is the top of the mask; without a previous hand
    # (or one with area 0) the gate is the whole frame.
    assert centroid(mask, previous=(35, 26, 80), hand_rows=10) == centroid(mask[:12])
    for previous in (None, (35, 26, 0)):
        assert centroid(mask, previous=previous, track_gate=15) == centroid(mask)
    # Off: the thesis, whatever the previous centroid.
    assert centroid(mask, previous=(35, 26, 80)) == centroid(mask)


@pytest.mark.parametrize("kwargs, message", [
    (dict(track_gate=-1), r"track_gate must be in \[0, 4095\], got -1"),
    (dict(track_gate=4096), r"track_gate must be in \[0, 4095\]"),
    (dict(hand_rows=4097), r"hand_rows must be in \[0, 4096\]"),
    (dict(hand_rows=1.5), r"hand_rows must be"),
    (dict(previous=(1, 2)), r"previous must be a centroid \(x, y, area\)"),
    (dict(previous=(1, -2, 3)), r"previous\.y must be"),
])
def test_tracking_arguments_are_validated(kwargs, message):
    with pytest.raises(ValueError, match=message):
        centroid(np.zeros((4, 4), bool), **kwargs)

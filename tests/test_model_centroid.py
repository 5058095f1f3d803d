"""Tests for sim.model.centroid (thesis §7.1, eq. 23-24, Fig. 72)."""
import math

import cv2
import numpy as np
import pytest

from sim.model.centroid import Centroid, centroid, moment_widths


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

"""Tests for sim.model.median (thesis §6.1, Figs. 36-37)."""
import cv2
import numpy as np
import pytest
from numpy.lib.stride_tricks import sliding_window_view

from sim.model.median import median3x3


def _interior_median(image):
    windows = sliding_window_view(image, (3, 3))
    return np.median(windows, axis=(-2, -1)).astype(image.dtype)


@pytest.mark.parametrize("shape", [(3, 3), (4, 7), (31, 45), (120, 160)])
def test_interior_equals_numpy_median(shape):
    rng = np.random.default_rng(sum(shape))
    image = rng.integers(0, 256, size=shape, dtype=np.uint8)
    out = median3x3(image)
    assert out.dtype == np.uint8 and out.shape == shape
    assert np.array_equal(out[1:-1, 1:-1], _interior_median(image))


def test_interior_equals_opencv_median_blur():
    rng = np.random.default_rng(5)
    image = rng.integers(0, 256, size=(60, 80), dtype=np.uint8)
    # Few distinct values make ties, which a sorting network must handle too.
    coarse = (rng.integers(0, 3, size=(60, 80)) * 100).astype(np.uint8)
    for img in (image, coarse):
        assert np.array_equal(median3x3(img)[1:-1, 1:-1], cv2.medianBlur(img, 3)[1:-1, 1:-1])


def test_border_pixels_pass_through():
    rng = np.random.default_rng(6)
    image = rng.integers(0, 256, size=(20, 25), dtype=np.uint8)
    out = median3x3(image)
    for sl in [np.s_[0, :], np.s_[-1, :], np.s_[:, 0], np.s_[:, -1]]:
        assert np.array_equal(out[sl], image[sl])


def test_uint16_disparity_map():
    rng = np.random.default_rng(7)
    image = rng.integers(0, 65536, size=(30, 40), dtype=np.uint16)
    out = median3x3(image)
    assert out.dtype == np.uint16
    assert np.array_equal(out[1:-1, 1:-1], _interior_median(image))


def test_impulse_removed():
    image = np.full((5, 5), 10, np.uint8)
    image[2, 2] = 255
    assert np.array_equal(median3x3(image), np.full((5, 5), 10, np.uint8))


@pytest.mark.parametrize("shape", [(1, 1), (2, 9), (9, 2)])
def test_small_images_unchanged(shape):
    image = np.arange(np.prod(shape), dtype=np.uint8).reshape(shape)
    out = median3x3(image)
    assert np.array_equal(out, image) and out is not image


def test_input_not_modified():
    rng = np.random.default_rng(8)
    image = rng.integers(0, 256, size=(10, 10), dtype=np.uint8)
    copy = image.copy()
    median3x3(image)
    assert np.array_equal(image, copy)


@pytest.mark.parametrize("bad", [
    np.zeros((5, 5), np.float32),
    np.zeros((5, 5), np.int16),
    np.zeros((5, 5), bool),
    np.zeros((5,), np.uint8),
    np.zeros((5, 5, 3), np.uint8),
    np.zeros((0, 5), np.uint8),
])
def test_rejects_bad_image(bad):
    with pytest.raises(ValueError, match="image"):
        median3x3(bad)

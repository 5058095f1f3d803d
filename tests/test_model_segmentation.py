"""Tests for sim.model.segmentation (thesis §6.3, eq. 22, Fig. 58)."""
import cv2
import numpy as np
import pytest

from sim.model.segmentation import disparity_band, hand_mask, skin_mask


def test_skin_mask_matches_opencv_in_range():
    rng = np.random.default_rng(10)
    cb = rng.integers(0, 256, size=(64, 80), dtype=np.uint8)
    cr = rng.integers(0, 256, size=(64, 80), dtype=np.uint8)
    cases = [((77, 127), (133, 173)), ((0, 255), (10, 10)), ((200, 255), (0, 60))]
    for cb_range, cr_range in cases:
        expected = cv2.inRange(np.dstack([cb, cr]), (cb_range[0], cr_range[0]),
                               (cb_range[1], cr_range[1])) > 0
        out = skin_mask(cb, cr, cb_range, cr_range)
        assert out.dtype == bool
        assert np.array_equal(out, expected)


def test_skin_mask_default_boundaries_inclusive():
    cb = np.array([[76, 77, 127, 128]], np.uint8)
    assert skin_mask(cb, np.full_like(cb, 150)).tolist() == [[False, True, True, False]]
    cr = np.array([[132, 133, 173, 174]], np.uint8)
    assert skin_mask(np.full_like(cr, 100), cr).tolist() == [[False, True, True, False]]


@pytest.mark.parametrize("name, kwargs", [
    ("cb_range", {"cb_range": (128, 127)}),
    ("cb_range", {"cb_range": (-1, 10)}),
    ("cb_range", {"cb_range": (0, 256)}),
    ("cb_range", {"cb_range": (1, 2, 3)}),
    ("cb_range", {"cb_range": 5}),
    ("cr_range", {"cr_range": (10.5, 20)}),
    ("cr_range", {"cr_range": (174, 173)}),
])
def test_skin_mask_rejects_bad_range(name, kwargs):
    plane = np.zeros((2, 2), np.uint8)
    with pytest.raises(ValueError, match=name):
        skin_mask(plane, plane, **kwargs)


def test_skin_mask_rejects_bad_planes():
    with pytest.raises(ValueError, match="cb"):
        skin_mask(np.zeros((2, 3), np.uint8), np.zeros((2, 2), np.uint8))
    with pytest.raises(ValueError, match="cr"):
        skin_mask(np.zeros((2, 2), np.uint8), np.full((2, 2), 256, np.uint16))


def test_disparity_band_is_strict_with_thesis_thresholds():
    disparity = np.arange(48, dtype=np.uint8).reshape(6, 8)
    out = disparity_band(disparity)
    assert out.dtype == bool
    assert np.flatnonzero(out.ravel()).tolist() == list(range(34, 46))
    assert not out.ravel()[33] and not out.ravel()[46]


def test_disparity_band_matches_loop_reference():
    rng = np.random.default_rng(11)
    disparity = rng.integers(0, 64, size=(20, 30), dtype=np.uint16)
    out = disparity_band(disparity, low=5, high=40, max_disparity=64)
    for (row, col), value in np.ndenumerate(disparity):
        assert out[row, col] == (5 < int(value) < 40)


def test_disparity_band_default_high_follows_max_disparity():
    disparity = np.array([[60, 61, 62, 63]], np.uint8)
    out = disparity_band(disparity, low=0, max_disparity=64)
    assert out.tolist() == [[True, True, False, False]]


@pytest.mark.parametrize("name, kwargs", [
    ("max_disparity", {"max_disparity": 1}),
    ("max_disparity", {"max_disparity": 256}),
    ("low", {"low": -1}),
    ("low", {"low": 47}),
    ("low", {"low": 3.0}),
    ("high", {"high": 33}),
    ("high", {"high": 48}),
    ("high", {"low": 10, "high": 5}),
])
def test_disparity_band_rejects_bad_params(name, kwargs):
    with pytest.raises(ValueError, match=name):
        disparity_band(np.zeros((2, 2), np.uint8), **kwargs)


def test_disparity_band_rejects_out_of_range_disparity():
    with pytest.raises(ValueError, match="disparity"):
        disparity_band(np.full((2, 2), 48, np.uint8))
    with pytest.raises(ValueError, match="disparity"):
        disparity_band(np.full((2, 2), -1, np.int16))
    with pytest.raises(ValueError, match="disparity"):
        disparity_band(np.zeros((2, 2), np.float64))


def test_hand_mask_is_and():
    skin = np.array([[0, 0, 1, 1]], bool)
    band = np.array([[0, 1, 0, 1]], np.uint8)
    out = hand_mask(skin, band)
    assert out.dtype == bool and out.tolist() == [[False, False, False, True]]


def test_hand_mask_rejects_bad_masks():
    with pytest.raises(ValueError, match="skin"):
        hand_mask(np.full((2, 2), 2), np.zeros((2, 2), bool))
    with pytest.raises(ValueError, match="band"):
        hand_mask(np.zeros((2, 2), bool), np.zeros((2, 3), bool))

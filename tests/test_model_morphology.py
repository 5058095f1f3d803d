"""Tests for sim.model.morphology (thesis §6.4, Figs. 63-64, 68-69, 100).

OpenCV is the oracle over the whole frame: its default border value for erode /
dilate is the neutral one, which is the model's "ignore taps outside the frame".
"""

import cv2
import numpy as np
import pytest

from sim.model.morphology import closing, dilate, erode, opening, structuring_element

SIZES = [3, 5, 7, 9, 11]
SHAPES = ["cross", "square", "diamond"]


def _blobby_mask(seed, shape=(45, 61), block=9, salt=0.04, pepper=0.005):
    """Large random blocks (so erosion leaves something) plus salt-and-pepper noise."""
    rng = np.random.default_rng(seed)
    coarse = rng.random((shape[0] // block + 1, shape[1] // block + 1)) < 0.5
    mask = np.kron(coarse, np.ones((block, block), bool))[:shape[0], :shape[1]]
    return (mask | (rng.random(shape) < salt)) & (rng.random(shape) >= pepper)


def _cv(mask, element, op):
    kernel = element.astype(np.uint8)
    src = mask.astype(np.uint8)
    if op == "erode":
        out = cv2.erode(src, kernel)
    elif op == "dilate":
        out = cv2.dilate(src, kernel)
    else:
        out = cv2.morphologyEx(src, {"open": cv2.MORPH_OPEN, "close": cv2.MORPH_CLOSE}[op], kernel)
    return out.astype(bool)


MODEL_OPS = {"erode": erode, "dilate": dilate, "open": opening, "close": closing}


def test_cross_is_centre_row_and_column():
    for size in SIZES + [63]:
        expected = np.zeros((size, size), bool)
        expected[size // 2, :] = True
        expected[:, size // 2] = True
        element = structuring_element("cross", size)
        assert element.dtype == bool and np.array_equal(element, expected)
        opencv = cv2.getStructuringElement(cv2.MORPH_CROSS, (size, size)).astype(bool)
        assert np.array_equal(element, opencv)


def test_square_and_diamond_elements():
    for size in SIZES:
        assert np.array_equal(structuring_element("square", size), np.ones((size, size), bool))
        diamond = structuring_element("diamond", size)
        radius = size // 2
        for (row, col), value in np.ndenumerate(diamond):
            assert value == (abs(row - radius) + abs(col - radius) <= radius)


@pytest.mark.parametrize("shape", SHAPES)
@pytest.mark.parametrize("op", list(MODEL_OPS))
def test_matches_opencv_whole_frame(shape, op):
    for size in SIZES:
        mask = _blobby_mask(seed=size)
        element = structuring_element(shape, size)
        expected = _cv(mask, element, op)
        assert 0 < expected.sum() < expected.size   # the comparison is not vacuous
        out = MODEL_OPS[op](mask, shape, size=size)
        assert out.dtype == bool
        assert np.array_equal(out, expected), (shape, size, op)
        assert np.array_equal(MODEL_OPS[op](mask, element), expected)


@pytest.mark.parametrize("op", list(MODEL_OPS))
def test_asymmetric_explicit_element_matches_opencv(op):
    element = np.array([
        [1, 1, 0, 0, 0],
        [0, 0, 0, 0, 1],
        [0, 1, 0, 0, 0],
        [0, 0, 0, 1, 1],
        [0, 0, 0, 0, 0],
    ], bool)
    for seed in range(3):
        mask = _blobby_mask(seed=100 + seed, shape=(23, 31), block=5)
        expected = _cv(mask, element, op)
        assert 0 < expected.sum() < expected.size
        assert np.array_equal(MODEL_OPS[op](mask, element), expected)


def test_taps_all_outside_give_neutral_value():
    # One tap two rows below: the last two rows have no tap inside the frame.
    element = np.zeros((5, 5), bool)
    element[4, 2] = True
    mask = np.zeros((6, 4), bool)
    assert erode(mask, element)[-2:].all() and not erode(mask, element)[:-2].any()
    full = np.ones((6, 4), bool)
    assert not dilate(full, element)[-2:].any() and dilate(full, element)[:-2].all()


def test_element_larger_than_frame():
    mask = _blobby_mask(seed=9, shape=(4, 6), block=2, salt=0.2)
    element = structuring_element("square", 11)
    assert np.array_equal(erode(mask, element), _cv(mask, element, "erode"))
    assert np.array_equal(dilate(mask, element), _cv(mask, element, "dilate"))


def test_integer_mask_accepted_and_default_is_thesis_cross():
    mask = _blobby_mask(seed=4, shape=(40, 40), block=13, salt=0.0, pepper=0.0).astype(np.uint8)
    expected = _cv(mask.astype(bool), structuring_element("cross", 11), "open")
    assert np.array_equal(opening(mask), expected)


@pytest.mark.parametrize("size", [1, 2, 4, 12, 65, 3.0, True])
def test_structuring_element_rejects_bad_size(size):
    with pytest.raises(ValueError, match="size"):
        structuring_element("cross", size)


def test_structuring_element_rejects_bad_shape():
    with pytest.raises(ValueError, match="shape"):
        structuring_element("circle", 5)


@pytest.mark.parametrize("func", list(MODEL_OPS.values()))
def test_ops_reject_bad_arguments(func):
    mask = np.zeros((8, 8), bool)
    with pytest.raises(ValueError, match="size"):
        func(mask, "square", size=4)
    with pytest.raises(ValueError, match="size"):
        func(mask, np.ones((3, 3), bool), size=3)
    with pytest.raises(ValueError, match="element must be one of"):    # the argument's name
        func(mask, "ring")
    for bad_element in (np.ones((4, 4), bool), np.ones((3, 5), bool), np.ones(3, bool),
                        np.zeros((3, 3), bool), np.full((3, 3), 2), np.ones((65, 65), bool)):
        with pytest.raises(ValueError, match="element"):
            func(mask, bad_element)
    for bad_mask in (np.full((8, 8), 2), np.zeros((8, 8, 1), bool), np.zeros((8, 8), float)):
        with pytest.raises(ValueError, match="mask"):
            func(bad_mask, "cross", size=3)

"""The whole stereo matcher (sim.model.stereo.stereo_match): Middlebury accuracy
against ground truth, a synthetic shifted pair, the median flags and validation."""
from pathlib import Path

import numpy as np
import pytest

from sim.evaluate import score_disparity
from sim.images import read_array, read_grey
from sim.model.census import census_bits
from sim.model.matching import lr_consistency
from sim.model.median import median3x3
from sim.model.stereo import stereo_match

MIDDLEBURY = Path(__file__).resolve().parent.parent / "data" / "middlebury"


# ---------------------------------------------------------------- Middlebury


@pytest.mark.parametrize("scene, gt_scale, max_disparity, vhdl_pct_good", [
    # pct_good of the thesis author's VHDL core (Wc 7, Wh 13, Th 8) on the same pairs.
    ("tsukuba", 16, 32, 88.75),
    ("venus", 8, 32, 94.83),
    ("cones", 4, 64, 84.52),
])
def test_middlebury_at_least_as_good_as_the_vhdl_core(scene, gt_scale, max_disparity,
                                                      vhdl_pct_good):
    folder = MIDDLEBURY / scene
    left, right = read_grey(folder / "left.png"), read_grey(folder / "right.png")
    truth = read_array(folder / "disp_left.png")
    result = stereo_match(left, right, census_window=7, hamming_window=13,
                          max_disparity=max_disparity, lrcc_threshold=8)
    assert result.disparity.shape == left.shape and result.disparity.dtype == np.uint8
    score = score_disparity(result.disparity, truth, gt_scale)
    assert score["pct_good"] >= vhdl_pct_good


# ---------------------------------------------------------------- synthetic pair

CENSUS, HAMMING, NDISP = 5, 9, 16


def shifted_pair(shift, height=40, width=96, noise=2, seed=0):
    """Random texture; a left pixel x shows the same point as the right pixel x - shift."""
    rng = np.random.default_rng(seed)
    scene = rng.integers(0, 256, (height, width + shift)).astype(np.int64)
    left = scene[:, :width]
    right = scene[:, shift:shift + width] + rng.integers(-noise, noise + 1, (height, width))
    return left.astype(np.uint8), np.clip(right, 0, 255).astype(np.uint8)


def interior(shift, margin=HAMMING // 2 + CENSUS // 2 + 2):
    """Rows and columns whose windows see only pixels with a partner in the right image."""
    return np.s_[margin:-margin, shift + margin:-margin]


@pytest.mark.parametrize("shift", [3, 7, 12])
def test_shifted_random_texture_gives_the_shift(shift):
    left, right = shifted_pair(shift, seed=shift)
    result = stereo_match(left, right, census_window=CENSUS, hamming_window=HAMMING,
                          max_disparity=NDISP, lrcc_threshold=2)
    inner = interior(shift)
    for name in ("disparity", "l2r", "checked"):
        assert np.all(getattr(result, name)[inner] == shift), name
    # R2L is indexed by the right pixel: right x sees left x + shift.
    margin = HAMMING // 2 + CENSUS // 2 + 2
    assert np.all(result.r2l[margin:-margin, margin:-margin - shift] == shift)


def test_result_fields_shapes_and_consistency_stage():
    left, right = shifted_pair(5, noise=6, seed=1)
    result = stereo_match(left, right, census_window=CENSUS, hamming_window=HAMMING,
                          max_disparity=NDISP, lrcc_threshold=2)
    for arr in result:
        assert arr.shape == left.shape and arr.dtype == np.uint8
        assert arr.max() < NDISP
    assert np.array_equal(result.checked, lr_consistency(result.l2r, result.r2l, 2))


def test_disparity_median_flag():
    # Heavy noise so that the checked map has holes and outliers for the median to change.
    left, right = shifted_pair(6, noise=40, seed=2)
    kwargs = dict(census_window=CENSUS, hamming_window=HAMMING, max_disparity=NDISP,
                  lrcc_threshold=1)
    with_median = stereo_match(left, right, **kwargs)
    without = stereo_match(left, right, disparity_median=False, **kwargs)
    assert np.array_equal(without.disparity, without.checked)
    assert np.array_equal(with_median.disparity, median3x3(with_median.checked))
    for name in ("l2r", "r2l", "checked"):            # the flag acts after the check only
        assert np.array_equal(getattr(with_median, name), getattr(without, name)), name
    assert not np.array_equal(with_median.disparity, without.disparity)


def test_prefilter_median_flag():
    left, right = shifted_pair(4, noise=20, seed=3)
    kwargs = dict(census_window=CENSUS, hamming_window=HAMMING, max_disparity=NDISP,
                  lrcc_threshold=2)
    prefiltered = stereo_match(left, right, prefilter_median=True, **kwargs)
    by_hand = stereo_match(median3x3(left), median3x3(right), **kwargs)
    plain = stereo_match(left, right, **kwargs)
    for a, b, name in zip(prefiltered, by_hand, prefiltered._fields):
        assert np.array_equal(a, b), name
    assert not np.array_equal(prefiltered.l2r, plain.l2r)


def test_threads_do_not_change_the_result():
    left, right = shifted_pair(9, noise=30, seed=4)
    kwargs = dict(census_window=CENSUS, hamming_window=HAMMING, max_disparity=NDISP,
                  lrcc_threshold=3)
    one = stereo_match(left, right, threads=1, **kwargs)
    three = stereo_match(left, right, threads=3, **kwargs)
    for a, b, name in zip(one, three, one._fields):
        assert np.array_equal(a, b), name


def test_list_input_is_accepted():
    left, right = shifted_pair(3, height=20, width=40, seed=5)
    a = stereo_match(left, right, census_window=3, hamming_window=5, max_disparity=8)
    b = stereo_match(left.tolist(), right.tolist(), census_window=3, hamming_window=5,
                     max_disparity=8)
    assert np.array_equal(a.disparity, b.disparity)


# ---------------------------------------------------------------- validation

W = 40


@pytest.mark.parametrize("kwargs, name", [
    (dict(census_window=6), "census_window"),
    (dict(census_window=13), "census_window"),
    (dict(census_window=1), "census_window"),
    (dict(hamming_window=12), "hamming_window"),
    (dict(hamming_window=65), "hamming_window"),
    (dict(max_disparity=W + 1), "max_disparity"),
    (dict(max_disparity=0), "max_disparity"),
    (dict(max_disparity=8.0), "max_disparity"),
    (dict(max_disparity=8, lrcc_threshold=0), "lrcc_threshold"),
    (dict(max_disparity=8, lrcc_threshold=9), "lrcc_threshold"),
    (dict(census_window=7, no_match_cost=census_bits(7) + 1), "no_match_cost"),
    (dict(census_window=3, no_match_cost=-1), "no_match_cost"),
])
def test_bad_parameters_name_the_parameter(kwargs, name):
    left, right = shifted_pair(2, height=16, width=W)
    kwargs = {"max_disparity": 16, **kwargs}
    with pytest.raises(ValueError, match=name):
        stereo_match(left, right, **kwargs)


def test_largest_valid_parameters_are_accepted():
    left, right = shifted_pair(2, height=16, width=W)
    result = stereo_match(left, right, census_window=11, hamming_window=63, max_disparity=W,
                          lrcc_threshold=W, no_match_cost=census_bits(11))
    assert result.disparity.shape == (16, W)


def test_left_right_shape_mismatch():
    left, right = shifted_pair(2, height=16, width=W)
    with pytest.raises(ValueError, match="left and right"):
        stereo_match(left, right[:, :-2], max_disparity=8)
    with pytest.raises(ValueError, match="left and right"):
        stereo_match(left[:-1], right, max_disparity=8)


def test_image_must_be_2d_8bit():
    left, right = shifted_pair(2, height=16, width=W)
    with pytest.raises(ValueError, match="left must be a 2-D image"):
        stereo_match(np.stack([left] * 3, axis=-1), right, max_disparity=8)
    with pytest.raises(ValueError, match="right must be a 2-D image"):
        stereo_match(left, right[None], max_disparity=8)
    with pytest.raises(ValueError, match="right values"):
        stereo_match(left, right.astype(np.int32) + 1000, max_disparity=8)
    with pytest.raises(ValueError, match="left must have an integer dtype"):
        stereo_match(left.astype(np.float32), right, max_disparity=8)

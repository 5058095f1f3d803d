"""sim/model/moving_average.py: the smoothing of the trajectory (thesis §7.2, eq. 27, Fig. 75)."""
import numpy as np
import pytest

from sim.model.moving_average import moving_average

# ---------------------------------------------------------------- moving average


def _float_moving_average(points, window):
    """Float reference: history primed with copies of the first sample, then a box filter."""
    padded = np.concatenate([np.repeat(points[:1], window - 1, axis=0), points]).astype(float)
    kernel = np.ones(window) / window
    return np.stack([np.convolve(padded[:, axis], kernel, mode="valid") for axis in (0, 1)], 1)


@pytest.mark.parametrize("window", [1, 2, 4, 8, 16])
def test_moving_average_matches_float_reference(window):
    rng = np.random.default_rng(window)
    points = rng.integers(0, 1024, size=(200, 2))
    out = moving_average(points, np.ones(200, bool), window=window, frac_bits=8)
    assert out.dtype == np.int64 and out.shape == (200, 2)
    expected = _float_moving_average(points, window) * 2 ** 8   # exact: window divides 256
    assert np.array_equal(out, expected)


def test_moving_average_before_first_valid_is_zero_then_no_ramp():
    rng = np.random.default_rng(20)
    points = rng.integers(0, 640, size=(50, 2))
    valid = np.zeros(50, bool)
    valid[7:] = True
    out = moving_average(points, valid, window=4, frac_bits=8)
    assert not out[:7].any()
    assert np.array_equal(out[7], points[7] * 256)   # history filled, no ramp from 0
    expected = _float_moving_average(points[7:], 4) * 256
    assert np.array_equal(out[7:], expected)


def test_moving_average_invalid_frames_hold_history():
    rng = np.random.default_rng(21)
    points = rng.integers(0, 640, size=(120, 2))
    valid = rng.random(120) < 0.6
    valid[:3] = False
    valid[3] = True
    out = moving_average(points, valid, window=8, frac_bits=8)
    # Same filter over the valid samples only, then held through invalid frames.
    compressed = _float_moving_average(points[valid], 8) * 256
    latest_valid = np.cumsum(valid) - 1
    assert not out[:3].any()
    assert np.array_equal(out[3:], compressed[latest_valid[3:]])
    held = np.flatnonzero(~valid[4:]) + 4
    assert np.array_equal(out[held], out[held - 1])


def test_moving_average_floors_when_fraction_too_short():
    # Last frame: history sums to (3, 3); 3/4 px is 0 whole px, or 1.5 -> 1 half-px.
    points = np.array([[0, 0], [0, 0], [0, 1], [3, 2]])
    out = moving_average(points, np.ones(4, bool), window=4, frac_bits=0)
    assert out.tolist() == [[0, 0], [0, 0], [0, 0], [0, 0]]
    out = moving_average(points, np.ones(4, bool), window=4, frac_bits=1)
    assert out.tolist() == [[0, 0], [0, 0], [0, 0], [1, 1]]


@pytest.mark.parametrize("window", [0, 3, 5, 12, 32, 2.0])
def test_moving_average_rejects_bad_window(window):
    with pytest.raises(ValueError, match="window"):
        moving_average(np.zeros((4, 2), int), np.ones(4, bool), window=window)


def test_moving_average_window_error_mentions_power_of_two():
    with pytest.raises(ValueError, match="window must be a power of two"):
        moving_average(np.zeros((4, 2), int), np.ones(4, bool), window=6)


@pytest.mark.parametrize("name, points, valid, kwargs", [
    ("points", np.zeros((4, 3), int), np.ones(4, bool), {}),
    ("points", np.zeros(4, int), np.ones(4, bool), {}),
    ("points", np.zeros((4, 2), float), np.ones(4, bool), {}),
    ("valid", np.zeros((4, 2), int), np.ones(5, bool), {}),
    ("valid", np.zeros((4, 2), int), np.full(4, 2), {}),
    ("frac_bits", np.zeros((4, 2), int), np.ones(4, bool), {"frac_bits": 17}),
    ("frac_bits", np.zeros((4, 2), int), np.ones(4, bool), {"frac_bits": -1}),
])
def test_moving_average_rejects_bad_arguments(name, points, valid, kwargs):
    with pytest.raises(ValueError, match=name):
        moving_average(points, valid, **kwargs)

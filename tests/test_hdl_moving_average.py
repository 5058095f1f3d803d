# amaranth: UnusedElaboratable=no
"""hdl/moving_average.py: MovingAverage, bit for bit against
sim.model.moving_average.moving_average (thesis §7.2)."""
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from hdl.moving_average import MovingAverage
from sim.model.moving_average import moving_average
from tests.hdl_helpers import run_moving_average


def _check_moving_average(points, valid, window, frac_bits, coord_bits=10, idle=0.4, seed=0):
    got, primed = run_moving_average(points, valid, window, frac_bits, coord_bits, idle, seed)
    assert np.array_equal(got, moving_average(points, valid, window, frac_bits))
    assert np.array_equal(primed.astype(bool), np.logical_or.accumulate(valid))


def _random_track(rng, frames, coord_bits, invalid=0.3):
    points = rng.integers(0, 1 << coord_bits, (frames, 2))
    valid = rng.random(frames) >= invalid
    valid[:int(rng.integers(0, 6))] = False  # no hand yet
    return points, valid


@pytest.mark.parametrize("window", [1, 2, 4, 8, 16])
@pytest.mark.parametrize("frac_bits", [0, 4, 8])
def test_moving_average_sweep(window, frac_bits):
    rng = np.random.default_rng(window * 100 + frac_bits)
    points, valid = _random_track(rng, 70, 10)
    # extremes: every register at its maximum (the sum's width), then 0
    points[-20:-10], points[-10:] = 1023, 0
    valid[-20:] = True
    _check_moving_average(points, valid, window, frac_bits, seed=window + frac_bits)


def test_moving_average_small_coordinates_and_no_valid_frame():
    rng = np.random.default_rng(3)
    points, valid = _random_track(rng, 40, 3)
    _check_moving_average(points, valid, 8, 1, coord_bits=3)
    got, primed = run_moving_average(points, np.zeros(40, bool), 4, 8)
    assert not got.any() and not primed.any()


@settings(max_examples=40, deadline=None)
@given(st.data())
def test_moving_average_hypothesis(data):
    window = data.draw(st.sampled_from([1, 2, 4, 8, 16]), "window")
    frac_bits = data.draw(st.integers(0, 16), "frac_bits")
    coord_bits = data.draw(st.integers(1, 16), "coord_bits")
    frames = data.draw(st.integers(1, 40), "frames")
    top = (1 << coord_bits) - 1
    points = np.array(data.draw(st.lists(st.tuples(st.integers(0, top), st.integers(0, top)),
                                         min_size=frames, max_size=frames)), dtype=np.int64)
    valid = np.array(data.draw(st.lists(st.booleans(), min_size=frames, max_size=frames)))
    idle = data.draw(st.sampled_from([0.0, 0.5]), "idle")
    _check_moving_average(points, valid, window, frac_bits, coord_bits, idle)


@pytest.mark.parametrize("make, name", [
    (lambda: MovingAverage(0, 4, 8), r"coord_bits must be in \[1, 16\]"),
    (lambda: MovingAverage(10, 3, 8), "window must be a power of two"),
    (lambda: MovingAverage(10, 32, 8), r"window must be in \[1, 16\]"),
    # the id it had in the table shared with GestureSpotting's frac_bits case
    pytest.param(lambda: MovingAverage(10, 4, 17), r"frac_bits must be in \[0, 16\]",
                 id=r"<lambda>-frac_bits must be in \[0, 16\]0"),
])
def test_bad_parameters_raise_value_error_naming_them(make, name):
    with pytest.raises(ValueError, match=name):
        make()

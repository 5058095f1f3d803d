"""sim/model/validation.py: each check accepts what its docstring allows, and
refuses everything else with a ValueError naming the parameter and the range."""
import numpy as np
import pytest

from sim.model.validation import (check_bool_image, check_byte_range, check_flags,
                                  check_image, check_int, check_number, check_odd_window,
                                  check_points, check_same_shape)


def test_accepted_values_come_back_normalised():
    assert check_int("n", np.int16(5), 0, 9) == 5 and type(check_int("n", np.int16(5))) is int
    assert check_number("f", 3, 0, 5, unit="Hz") == 3.0
    assert check_byte_range("box", (np.uint8(3), 200)) == (3, 200)
    assert check_odd_window("w", 7) == 7
    assert check_image("img", np.zeros((2, 3), np.uint8), max_value=255).shape == (2, 3)
    assert check_bool_image("m", np.array([[0, 1]])).dtype == bool
    assert check_points("p", np.array([[1, 2]], np.uint16)).dtype == np.int64
    assert check_flags("f", [0, 1, 1], 3).tolist() == [False, True, True]
    check_same_shape(a=np.zeros(3), b=np.ones(3))


@pytest.mark.parametrize("call, message", [
    (lambda: check_int("count", True, 0, 9), "count must be an integer in [0, 9], got True"),
    (lambda: check_int("count", 2.0), "count must be an integer, got 2.0"),
    (lambda: check_int("count", 10, 0, 9), "count must be in [0, 9], got 10"),
    (lambda: check_int("count", -1, 0), "count must be in [0, inf], got -1"),
    (lambda: check_number("clock", float("nan"), 1, 5, unit="Hz"),
     "clock must be a number in [1, 5] Hz, got nan"),
    (lambda: check_number("gain", 0, 0, 1, lo_open=True), "gain must be a number in (0, 1]"),
    (lambda: check_number("gain", "1", 0, 1), "gain must be a number in [0, 1]"),
    (lambda: check_byte_range("skin_cb", 5), "skin_cb must be a pair (lo, hi)"),
    (lambda: check_byte_range("skin_cb", (9, 3)), "skin_cb[1] must be in [9, 255], got 3"),
    (lambda: check_byte_range("skin_cb", (0, 256)), "skin_cb[1] must be in [0, 255], got 256"),
    (lambda: check_odd_window("census_window", 4, 3, 9), "census_window must be odd in [3, 9]"),
    (lambda: check_odd_window("census_window", 11, 3, 9), "census_window must be in [3, 9]"),
    (lambda: check_image("left", np.zeros(4, np.uint8)), "left must be a 2-D image"),
    (lambda: check_image("left", np.zeros((2, 2))), "left must have an integer dtype"),
    (lambda: check_image("left", np.zeros((2, 2), np.uint8), min_shape=(3, 1)),
     "left must be at least 1x3"),
    (lambda: check_image("left", np.full((2, 2), 300), max_value=255),
     "left values must be in [0, 255]"),
    (lambda: check_bool_image("mask", np.array([[2]])), "mask must be a boolean mask"),
    (lambda: check_bool_image("mask", np.zeros(3, bool)), "mask must be a 2-D mask"),
    (lambda: check_same_shape(left=np.zeros((2, 2)), right=np.zeros((2, 3))),
     "left and right must have the same shape"),
    (lambda: check_points("points", np.zeros((3, 3), int)), "points must have shape (F, 2)"),
    (lambda: check_points("points", np.zeros((3, 2))), "points must have an integer dtype"),
    (lambda: check_flags("valid", [1, 0], 3), "valid must have shape (3,)"),
    (lambda: check_flags("valid", [2, 0, 1], 3), "valid must be boolean"),
])
def test_refusals_name_the_parameter_and_range(call, message):
    with pytest.raises(ValueError) as info:
        call()
    assert str(info.value).startswith(message), str(info.value)

# amaranth: UnusedElaboratable=no
"""hdl/gesture_spotting.py: GestureSpotting, bit for bit against
sim.model.gesture_spotting.gesture_spotting (thesis §7.3)."""
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from hdl.gesture_spotting import GestureSpotting
from verif.streams import field
from sim.model.gesture_spotting import gesture_spotting
from sim.model.moving_average import moving_average
from tests.hdl_helpers import feed_frames, run_moving_average


def _gesture_track(rng, frames=120):
    """A hand (10-bit coordinates) resting with jitter, swiping, pausing,
    swiping back and resting, with dropouts; as raw centroids."""
    pos = np.array([300.0, 240.0])
    points, valid = [], []
    plan = []
    for _ in range(4):
        plan += [("rest", int(rng.integers(5, 25)))]
        plan += [("move", int(rng.integers(4, 15)))]
    velocity = np.zeros(2)
    for kind, length in plan:
        if kind == "move":
            velocity = rng.uniform(-25, 25, 2)
        for _ in range(length):
            if kind == "move":
                pos = np.clip(pos + velocity, 0, 1023)
            jitter = rng.integers(-2, 3, 2)
            points.append(np.clip(np.round(pos) + jitter, 0, 1023))
            valid.append(rng.random() > 0.1)
    points = np.array(points, dtype=np.int64)[:frames]
    valid = np.array(valid)[:frames]
    valid[:3] = False
    return points, valid


def _run_spotting(points, primed, point_bits=18, window=8, threshold=30, hold=16,
                  frac_bits=8, idle=0.4, seed=0):
    dut = GestureSpotting(point_bits, window, threshold, hold, frac_bits)
    rows = [dict(x=int(x), y=int(y), primed=int(p)) for (x, y), p in zip(points, primed)]
    layout, out = feed_frames(dut, rows, idle, seed)
    assert np.array_equal(field(layout, out, "x"), points[:, 0])  # passed through
    assert np.array_equal(field(layout, out, "y"), points[:, 1])
    flags = field(layout, out, "flag").astype(bool)
    ref = gesture_spotting(points, primed, window, threshold, hold, frac_bits)
    assert np.array_equal(flags, ref)
    return flags


@pytest.mark.parametrize("window, threshold, hold, frac_bits", [
    (1, 0, 1, 8), (1, 10, 16, 8), (8, 0, 16, 8), (8, 30, 1, 8), (8, 30, 16, 8),
    (8, 30, 16, 4), (3, 10, 5, 0), (64, 30, 16, 8)])
def test_gesture_spotting_gesture_like(window, threshold, hold, frac_bits):
    rng = np.random.default_rng(window * 7 + threshold + hold)
    points, valid = _gesture_track(rng)
    smooth = moving_average(points, valid, 4, frac_bits)
    primed = np.logical_or.accumulate(valid)
    flags = _run_spotting(smooth, primed, 10 + frac_bits, window, threshold, hold, frac_bits,
                          seed=window + hold)
    # The track has both gestures and rests at these settings (the test can fail).
    assert flags.any() and not flags.all()


@pytest.mark.parametrize("window", [1, 2, 8])
def test_gesture_spotting_random_full_range(window):
    rng = np.random.default_rng(window)
    point_bits, frames = 18, 80
    points = rng.integers(0, 1 << point_bits, (frames, 2))
    points[40:60] = points[40]  # a still stretch to end the gesture
    points[70], points[71] = (0, (1 << point_bits) - 1), ((1 << point_bits) - 1, 0)
    primed = np.arange(frames) >= 4
    _run_spotting(points, primed, point_bits, window, 1023, 8, 8, idle=0.3, seed=window)


@settings(max_examples=40, deadline=None)
@given(st.data())
def test_gesture_spotting_hypothesis(data):
    window = data.draw(st.sampled_from([1, 2, 5, 8]), "window")
    threshold = data.draw(st.sampled_from([0, 1, 3, 30]), "threshold")
    hold = data.draw(st.sampled_from([1, 2, 16]), "hold")
    frac_bits = data.draw(st.sampled_from([0, 4, 8]), "frac_bits")
    point_bits = 6 + frac_bits
    frames = data.draw(st.integers(1, 50), "frames")
    top = (1 << point_bits) - 1
    points = np.array(data.draw(st.lists(st.tuples(st.integers(0, top), st.integers(0, top)),
                                         min_size=frames, max_size=frames)), dtype=np.int64)
    primed = np.arange(frames) >= data.draw(st.integers(0, frames), "first primed")
    idle = data.draw(st.sampled_from([0.0, 0.5]), "idle")
    _run_spotting(points, primed, point_bits, window, threshold, hold, frac_bits, idle)


def test_moving_average_into_gesture_spotting_thesis_parameters():
    rng = np.random.default_rng(11)
    points, valid = _gesture_track(rng, 150)
    smooth, primed = run_moving_average(points, valid, 4, 8, idle=0.2, seed=3)
    flags = _run_spotting(smooth, primed.astype(bool), idle=0.2, seed=4)
    assert flags.any() and not flags.all()


@pytest.mark.parametrize("make, name", [
    (lambda: GestureSpotting(point_bits=33), r"point_bits must be in \[1, 32\]"),
    (lambda: GestureSpotting(window=0), r"window must be in \[1, 64\]"),
    (lambda: GestureSpotting(window=65), r"window must be in \[1, 64\]"),
    (lambda: GestureSpotting(threshold=1024), r"threshold must be in \[0, 1023\]"),
    (lambda: GestureSpotting(hold=0), r"hold must be in \[1, 255\]"),
    # the id it had in the table shared with MovingAverage's frac_bits case
    pytest.param(lambda: GestureSpotting(frac_bits=-1), r"frac_bits must be in \[0, 16\]",
                 id=r"<lambda>-frac_bits must be in \[0, 16\]1"),
])
def test_bad_parameters_raise_value_error_naming_them(make, name):
    with pytest.raises(ValueError, match=name):
        make()

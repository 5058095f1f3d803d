"""sim/model/gesture_spotting.py: the frames of a gesture (thesis §7.3, Figs. 78-79)."""
import numpy as np
import pytest

from sim.model.gesture_spotting import gesture_spotting
from sim.model.moving_average import moving_average

# ---------------------------------------------------------------- gesture spotting


def _reference_spotting(points, primed, window, threshold, hold, frac_bits):
    """Straightforward per-frame reference of the documented state machine."""
    past = []            # every primed point so far, oldest first
    state = "REST"
    quiet = 0
    flags = []
    for (x, y), is_primed in zip(points.tolist(), primed.tolist()):
        if not is_primed:
            flags.append(False)
            continue
        if not past:
            past = [(x, y)] * window
        old_x, old_y = past[-window]
        past.append((x, y))
        moving = max(abs(x - old_x), abs(y - old_y)) > threshold * 2 ** frac_bits
        if state == "REST":
            if moving:
                state = "GESTURE"
        else:
            quiet = 0 if moving else quiet + 1
            if quiet == hold:
                state, quiet = "REST", 0
        flags.append(state == "GESTURE")
    return np.array(flags, dtype=bool)


def _segments(flags):
    edges = np.flatnonzero(np.diff(np.concatenate([[0], flags.astype(int), [0]])))
    return edges.reshape(-1, 2).tolist()   # [start, stop) pairs


def _up_and_back(duration, amplitude=200, rest_before=30, rest_after=60):
    """Hand at rest, raised-cosine trip up by `amplitude` px and back, at rest again."""
    t = np.arange(duration + 1)
    lift = amplitude / 2 * (1 - np.cos(2 * np.pi * t / duration))
    y = np.concatenate([np.full(rest_before, 300.0), 300 - lift, np.full(rest_after, 300.0)])
    x = np.full_like(y, 320.0)
    return np.rint(np.stack([x, y], axis=1)).astype(np.int64), lift


@pytest.mark.parametrize("duration", [40, 80])
def test_up_and_back_gesture_is_one_segment(duration):
    points, lift = _up_and_back(duration)
    valid = np.ones(len(points), bool)
    smooth = moving_average(points, valid)
    flags = gesture_spotting(smooth, np.logical_or.accumulate(valid))
    segments = _segments(flags)
    assert len(segments) == 1
    start, stop = segments[0]
    onset, end = 30, 30 + duration
    assert onset < start
    far = onset + np.flatnonzero(lift >= 60)      # hand well away from its rest position
    assert start <= far[0] and far[-1] < stop
    assert stop <= end + 16 + 8 + 4               # hold + spotting window + smoothing window


def test_short_hold_splits_at_the_reversal():
    points, _ = _up_and_back(80)
    valid = np.ones(len(points), bool)
    flags = gesture_spotting(moving_average(points, valid), valid, hold=2)
    assert len(_segments(flags)) == 2


def test_stationary_jitter_is_not_a_gesture():
    rng = np.random.default_rng(30)
    points = np.array([320, 240]) + rng.integers(-4, 5, size=(300, 2))
    valid = rng.random(300) < 0.9
    valid[0] = True
    flags = gesture_spotting(moving_average(points, valid), np.logical_or.accumulate(valid))
    assert not flags.any()


def test_no_start_spike_when_hand_appears_far_from_origin():
    points = np.tile([[600, 450]], (20, 1))
    valid = np.zeros(20, bool)
    valid[5:] = True
    primed = np.logical_or.accumulate(valid)
    assert not gesture_spotting(moving_average(points, valid), primed, threshold=0).any()


@pytest.mark.parametrize("seed", range(6))
def test_spotting_matches_reference_on_random_walks(seed):
    rng = np.random.default_rng(seed)
    frames = 400
    # Alternate quiet and fast stretches so both states and the hold counter are exercised.
    stretches = frames // 20
    speed = np.repeat(rng.choice([0, 1, 12], size=stretches), 20)
    heading = np.repeat(rng.choice([-1, 1], size=(stretches, 2)), 20, axis=0)
    steps = heading * speed[:, None] + rng.integers(-1, 2, size=(frames, 2))
    points = np.cumsum(steps, axis=0) + 2000
    valid = rng.random(frames) < 0.85
    valid[: rng.integers(0, 30)] = False
    primed = np.logical_or.accumulate(valid)
    window = int(rng.choice([1, 4, 8, 13]))
    threshold = 5 * window
    hold = int(rng.integers(1, 20))
    smooth = moving_average(points, valid, window=4, frac_bits=8)
    flags = gesture_spotting(smooth, primed, window=window, threshold=threshold, hold=hold)
    expected = _reference_spotting(smooth, primed, window, threshold, hold, 8)
    assert 0 < flags.sum() < primed.sum()
    assert np.array_equal(flags, expected)


def test_spotting_matches_reference_integer_pixels():
    rng = np.random.default_rng(99)
    points = np.cumsum(rng.integers(-6, 7, size=(300, 2)), axis=0)
    primed = np.ones(300, bool)
    flags = gesture_spotting(points, primed, window=3, threshold=10, hold=4, frac_bits=0)
    assert np.array_equal(flags, _reference_spotting(points, primed, 3, 10, 4, 0))


@pytest.mark.parametrize("name, kwargs", [
    ("window", {"window": 0}), ("window", {"window": 65}),
    ("threshold", {"threshold": -1}), ("threshold", {"threshold": 1024}),
    ("hold", {"hold": 0}), ("hold", {"hold": 256}),
    ("frac_bits", {"frac_bits": 17}),
])
def test_spotting_rejects_bad_params(name, kwargs):
    with pytest.raises(ValueError, match=name):
        gesture_spotting(np.zeros((4, 2), int), np.ones(4, bool), **kwargs)


def test_spotting_rejects_bad_arrays():
    with pytest.raises(ValueError, match="points"):
        gesture_spotting(np.zeros((4, 2), float), np.ones(4, bool))
    with pytest.raises(ValueError, match="primed"):
        gesture_spotting(np.zeros((4, 2), int), np.ones(3, bool))
    with pytest.raises(ValueError, match="primed"):
        gesture_spotting(np.zeros((4, 2), int), np.array([False, True, False, True]))

"""recognition.features: equidistant resampling, the pen and camera symbol front ends,
and the points and features the Gaussian models take (camera_points, feature_sets)."""
import math

import numpy as np
import pytest

from recognition.datasets import TrajectorySet
from recognition.features import (camera_points, camera_symbols, feature_sets, pen_symbols,
                                   resample_path, sequences)
from sw_hps.orientation import NO_SYMBOL, orientation_symbols
from sw_hps.stroke import stroke_features

# Symbol k points at 45k degrees, counter-clockwise with y up on screen; in image axes
# (y down) its unit step is (cos, -sin).
DIRECTIONS = [(math.cos(math.radians(45 * k)), -math.sin(math.radians(45 * k)))
              for k in range(8)]


def arc_position_on_monotone_polyline(vertices, points):
    """Oracle: the arc length at which each point lies on a polyline whose x strictly
    rises (so the segment holding a point is the one spanning its x)."""
    seg = np.hypot(*np.diff(vertices, axis=0).T)
    along = np.concatenate([[0.0], np.cumsum(seg)])
    index = np.clip(np.searchsorted(vertices[:, 0], points[:, 0], side="right") - 1,
                    0, len(vertices) - 2)
    start = vertices[index]
    return along[index] + np.hypot(*(points - start).T), index


# ---------------------------------------------------------------- resample_path


@pytest.mark.parametrize("num_points", [2, 3, 17, 64, 200])
def test_resample_straight_line_has_equal_steps(num_points):
    rng = np.random.default_rng(num_points)
    # Uneven sampling along a straight line, as a stylus delivers it.
    t = np.sort(np.concatenate([[0.0, 1.0], rng.uniform(0, 1, 30)]))
    line = np.column_stack([10 + 300 * t, 50 - 120 * t])
    out = resample_path(line, num_points)
    assert out.shape == (num_points, 2)
    steps = np.hypot(*np.diff(out, axis=0).T)
    length = math.hypot(300, 120)
    assert np.allclose(steps, length / (num_points - 1), rtol=0, atol=1e-9)
    assert np.allclose(out[0], line[0]) and np.allclose(out[-1], line[-1])


@pytest.mark.parametrize("seed", range(5))
def test_resample_polyline_points_are_equidistant_along_the_path(seed):
    rng = np.random.default_rng(100 + seed)
    xs = np.cumsum(rng.uniform(1, 40, size=12))
    vertices = np.column_stack([xs, rng.uniform(-80, 80, size=12)])
    num_points = int(rng.integers(5, 150))
    out = resample_path(vertices, num_points)
    length = np.hypot(*np.diff(vertices, axis=0).T).sum()
    position, index = arc_position_on_monotone_polyline(vertices, out)
    # Every point lies on the polyline ...
    a, b = vertices[index], vertices[index + 1]
    cross = (b - a)[:, 0] * (out - a)[:, 1] - (b - a)[:, 1] * (out - a)[:, 0]
    assert np.allclose(cross / np.hypot(*(b - a).T), 0.0, atol=1e-9)
    # ... at equal arc-length spacing; between points on one segment that is also the
    # straight-line distance (a chord across a corner is shorter).
    spacing = length / (num_points - 1)
    assert np.allclose(np.diff(position), spacing, rtol=0, atol=1e-9)
    chords = np.hypot(*np.diff(out, axis=0).T)
    same_segment = index[1:] == index[:-1]
    assert np.allclose(chords[same_segment], spacing, rtol=0, atol=1e-9)
    assert (chords <= spacing + 1e-9).all()


def test_resample_zero_length_path_repeats_its_point():
    out = resample_path([[5.0, 7.0], [5.0, 7.0], [5.0, 7.0]], 4)
    assert np.array_equal(out, np.tile([5.0, 7.0], (4, 1)))


@pytest.mark.parametrize("bad", [0, 1, 4097, 2.5, True, "10", None])
def test_bad_resample_is_named(bad):
    path = np.array([[0.0, 0.0], [10.0, 5.0]])
    with pytest.raises(ValueError, match="resample"):
        resample_path(path, bad)
    with pytest.raises(ValueError, match="resample"):
        pen_symbols(path, bad)


# ---------------------------------------------------------------- pen_symbols


@pytest.mark.parametrize("symbol", range(8))
def test_pen_symbols_of_straight_strokes(symbol):
    rng = np.random.default_rng(symbol)
    t = np.sort(np.concatenate([[0.0, 1.0], rng.uniform(0, 1, 25)]))
    dx, dy = DIRECTIONS[symbol]
    stroke = np.column_stack([200 + 150 * dx * t, 200 + 150 * dy * t])
    out = pen_symbols(stroke, 32)
    assert out.dtype == np.int8
    assert out.size == 31 and (out == symbol).all()


def test_pen_symbols_of_an_l_shape():
    stroke = [[0, 0], [0, 100], [100, 100]]         # down, then right (image axes)
    out = pen_symbols(stroke, 21).tolist()
    assert set(out) <= {6, 7, 0} and out[0] == 6 and out[-1] == 0


# ---------------------------------------------------------------- camera_symbols


def swipe(symbol, rest=20, motion=30, amplitude=200.0, start=(320.0, 240.0)):
    """Per-frame centroids: rest, a straight constant-speed swipe, rest (200 px in 30
    frames: fast enough along a diagonal, where spotting sees max(|dx|, |dy|) only)."""
    dx, dy = DIRECTIONS[symbol]
    t = np.linspace(0.0, 1.0, motion)
    moving = np.column_stack([start[0] + amplitude * dx * t, start[1] + amplitude * dy * t])
    return np.vstack([np.repeat(moving[:1], rest, axis=0), moving,
                      np.repeat(moving[-1:], rest, axis=0)])


@pytest.mark.parametrize("symbol", range(8))
def test_camera_symbols_of_a_swipe_is_its_direction_only(symbol):
    out = camera_symbols(swipe(symbol))
    assert out.dtype == np.int8
    assert out.size >= 10 and (out == symbol).all(), out


def test_camera_symbols_of_a_stationary_hand_is_empty():
    assert camera_symbols(np.tile([300.0, 250.0], (80, 1))).size == 0
    # Segmentation jitter of a few pixels is no gesture either.
    rng = np.random.default_rng(7)
    jittery = np.array([300.0, 250.0]) + rng.uniform(-3, 3, size=(80, 2))
    assert camera_symbols(jittery).size == 0


def test_camera_symbols_keeps_the_longest_gesture():
    # A short swipe right, a long rest (ends the gesture), a longer swipe up.
    first = swipe(0, rest=10, motion=12, amplitude=80.0)
    second = swipe(2, rest=30, motion=40, amplitude=200.0, start=tuple(first[-1]))
    out = camera_symbols(np.vstack([first, second]))
    assert out.size > 0 and (out == 2).all()


def test_camera_symbols_rejects_negative_or_non_finite_points():
    for bad in ([[1.0, -2.0], [3.0, 4.0]], [[1.0, np.nan], [3.0, 4.0]]):
        with pytest.raises(ValueError, match="trajectory"):
            camera_symbols(bad)


def test_sequences_uses_the_chosen_front_end():
    data = TrajectorySet.from_list([swipe(0), swipe(4)], ["right", "left"])
    camera = sequences(data)
    assert [set(s.tolist()) for s in camera] == [{0}, {4}]
    pen = sequences(data, resample=16)
    assert [s.tolist() for s in pen] == [[0] * 15, [4] * 15]


# ---------------------------------------------------------------- points for the Gaussian models


def test_camera_points_are_the_pairs_behind_the_camera_symbols():
    """The smoothed 10.8 positions of the longest flagged run: their orientation
    symbols are camera_symbols (what the board pops from the FIFO)."""
    first = swipe(0, rest=10, motion=12, amplitude=80.0)
    second = swipe(2, rest=30, motion=40, amplitude=200.0, start=tuple(first[-1]))
    trajectory = np.vstack([first, second])
    points = camera_points(trajectory)
    assert points.ndim == 2 and points.shape[1] == 2 and points.dtype.kind == "i"
    symbols = orientation_symbols(points)
    assert np.array_equal(symbols[symbols != NO_SYMBOL], camera_symbols(trajectory))
    # 10.8 fixed point: the run moves up (y decreases) from near the second start
    assert points[0, 1] > points[-1, 1]
    assert abs(points[0, 0] / 256 - first[-1, 0]) < 10
    assert camera_points(np.tile([300.0, 250.0], (80, 1))).shape == (0, 2)
    with pytest.raises(ValueError, match="trajectory"):
        camera_points([[1.0, -2.0], [3.0, 4.0]])


def test_feature_sets_of_both_front_ends():
    still = np.tile([300.0, 250.0], (40, 1))
    data = TrajectorySet.from_list([swipe(0), swipe(2), still], ["right", "up", "none"])
    pen = feature_sets(data, 12, camera=False)
    assert np.array_equal(pen[0], stroke_features(swipe(0), 12))
    assert pen[0].shape == (11, 6) and pen[2] is None
    camera = feature_sets(data, 12, camera=True)
    assert np.array_equal(camera[1], stroke_features(camera_points(swipe(2)), 12))
    assert camera[2] is None                      # nothing flagged
    assert np.allclose(camera[0][:, :2], [1.0, 0.0], atol=1e-3)   # rightward
    assert np.allclose(camera[1][:, :2], [0.0, 1.0], atol=1e-3)   # upward


def test_resample_path_is_the_boards():
    import sw_hps.stroke
    assert resample_path is sw_hps.stroke.resample_path

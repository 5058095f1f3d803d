"""Whole-gesture features of the Gaussian models (sw_hps.stroke): the column
meanings, invariance to translation, uniform scale and sampling density, paths
without motion, and bad arguments."""
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sw_hps.stroke import FEATURE_NAMES, resample_path, stroke_features

COL = {name: k for k, name in enumerate(FEATURE_NAMES)}


def polyline(rng, vertices=6):
    # rng: a numpy RandomState, whose legacy stream draws the same on numpy 1.16
    # (the board's floor, tests/test_hps_floor.py) as on 2.x
    return np.cumsum(rng.normal(0, 30, (vertices, 2)), axis=0) + 200


def densify(vertices, per_segment, rng):
    """Points on the same polyline: every vertex plus ``per_segment`` random points
    inside each segment (uneven spacing)."""
    out = [vertices[:1]]
    for a, b in zip(vertices[:-1], vertices[1:]):
        u = np.sort(rng.random_sample(per_segment))[:, None]
        out += [a + u * (b - a), b[None]]
    return np.concatenate(out)


def test_columns_and_shape():
    assert FEATURE_NAMES == ("cos", "sin", "x", "y", "arc", "turn")
    x = stroke_features(polyline(np.random.RandomState(0)), 16)
    assert x.shape == (15, 6) and x.dtype == np.float64
    assert np.allclose(np.hypot(x[:, COL["cos"]], x[:, COL["sin"]]), 1.0)


@pytest.mark.parametrize("step, direction", [
    ((1.0, 0.0), (1.0, 0.0)),       # rightward
    ((0.0, -1.0), (0.0, 1.0)),      # upward: image y decreases
    ((-1.0, 0.0), (-1.0, 0.0)),
    ((0.0, 1.0), (0.0, -1.0)),      # downward
    ((1.0, -1.0), (2 ** -0.5, 2 ** -0.5)),
])
def test_direction_of_a_straight_line(step, direction):
    line = np.array([[100.0, 100.0], [100.0 + 50 * step[0], 100.0 + 50 * step[1]]])
    x = stroke_features(line, 9)
    assert np.allclose(x[:, [COL["cos"], COL["sin"]]], direction, atol=1e-12)
    assert np.allclose(x[:, COL["turn"]], 0.0, atol=1e-12)
    # Position after each step, relative to the start over the length, y up.
    frac = np.arange(1, 9) / 8
    assert np.allclose(x[:, COL["x"]], frac * direction[0], atol=1e-12)
    assert np.allclose(x[:, COL["y"]], frac * direction[1], atol=1e-12)


def test_arc_column_goes_from_0_to_1():
    for resample in (3, 4, 17, 64):
        arc = stroke_features(polyline(np.random.RandomState(resample)), resample)[:, COL["arc"]]
        assert arc[0] == 0.0 and arc[-1] == 1.0
        assert np.allclose(np.diff(arc), 1 / (resample - 2))


def test_turn_of_a_right_angle_and_of_a_circle():
    # right, then up: a left turn of +pi/2 at the corner, 0 elsewhere
    corner = np.array([[0.0, 0.0], [10.0, 0.0], [10.0, -10.0]])
    turn = stroke_features(corner, 5)[:, COL["turn"]]        # steps of length 5
    assert np.allclose(turn, [0, 0, np.pi / 2, 0], atol=1e-12)
    # a counter-clockwise circle on the screen (y up): constant positive turn 2 pi / steps
    t = np.linspace(0, 2 * np.pi, 2001)
    circle = np.column_stack([np.cos(t), -np.sin(t)]) * 100
    turn = stroke_features(circle, 33)[1:, COL["turn"]]
    assert np.allclose(turn, 2 * np.pi / 32, atol=1e-3)
    # turning back on itself lies in [-pi, pi)
    back = stroke_features([[0, 0], [10, 0], [0, 0]], 3)[:, COL["turn"]]
    assert back[1] == -np.pi


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2 ** 32 - 1),
       shift=st.tuples(st.floats(-1e4, 1e4), st.floats(-1e4, 1e4)),
       scale=st.floats(1e-3, 1e3), resample=st.integers(3, 40))
def test_invariant_to_translation_and_uniform_scale(seed, shift, scale, resample):
    path = polyline(np.random.RandomState(seed))
    a = stroke_features(path, resample)
    b = stroke_features(path * scale + np.array(shift), resample)
    assert np.allclose(a[:, :5], b[:, :5], rtol=0, atol=1e-7)
    # turn: angles, compared modulo 2 pi (a turn of exactly -pi may round to +pi)
    d = np.angle(np.exp(1j * (a[:, 5] - b[:, 5])))
    assert np.allclose(d, 0, atol=1e-7)


@pytest.mark.parametrize("seed", range(5))
def test_invariant_to_sampling_density_along_the_same_polyline(seed):
    rng = np.random.RandomState(seed)
    vertices = polyline(rng, vertices=10)
    sparse = stroke_features(vertices, 32)
    dense = densify(vertices, 110, rng)                     # about 1000 points
    assert len(dense) == 1000
    assert np.allclose(stroke_features(dense, 32), sparse, rtol=0, atol=1e-9)
    # Without the corners (1000 points equally spaced along it) the chords cut
    # the corners a little: nearly the same positions; directions differ only at
    # the steps holding a corner (a corner within a tenth of a step of a step's end
    # may fall in either neighbour), turns only there and at the step after.
    along = np.concatenate([[0], np.cumsum(np.hypot(*np.diff(vertices, axis=0).T))])
    s = np.linspace(0, along[-1], 1000)
    cut = np.column_stack([np.interp(s, along, vertices[:, 0]),
                           np.interp(s, along, vertices[:, 1])])
    close = stroke_features(cut, 32)
    assert np.abs(close[:, 2:4] - sparse[:, 2:4]).max() < 3e-3
    assert np.array_equal(close[:, 4], sparse[:, 4])
    corner_at = along[1:-1] / (along[-1] / 31)            # in steps of the resampled path
    corner_steps = {int(np.floor(at + d)) for at in corner_at for d in (-0.1, 0.1)}
    direction = np.abs(close[:, :2] - sparse[:, :2]).max(axis=1)
    turn = np.abs(np.angle(np.exp(1j * (close[:, 5] - sparse[:, 5]))))
    assert set(np.flatnonzero(direction > 1e-6)) <= corner_steps
    assert set(np.flatnonzero(turn > 1e-6)) <= corner_steps | {k + 1 for k in corner_steps}
    assert len(corner_steps) <= 2 * len(corner_at) < len(sparse)    # few steps of the 31


def test_repeated_points_do_not_change_the_features():
    vertices = polyline(np.random.RandomState(9))
    doubled = np.repeat(vertices, 3, axis=0)
    assert np.allclose(stroke_features(doubled, 20), stroke_features(vertices, 20), atol=1e-12)


@pytest.mark.parametrize("path", [[[5.0, 7.0]], [[5.0, 7.0]] * 10, np.full((3, 2), 1e6)])
def test_a_path_without_motion_has_no_features(path):
    assert stroke_features(path, 16) is None


def test_resample_path_spacing_and_ends():
    vertices = polyline(np.random.RandomState(1))
    out = resample_path(vertices, 50)
    assert np.allclose(out[0], vertices[0]) and np.allclose(out[-1], vertices[-1])
    chords = np.hypot(*np.diff(out, axis=0).T)
    assert (chords <= chords.max()).all() and chords.max() - chords.min() < chords.max()
    assert np.array_equal(resample_path([[1.0, 2.0]], 4), np.tile([1.0, 2.0], (4, 1)))


@pytest.mark.parametrize("bad", [2, 1, 4097, 3.0, True, "8", None])
def test_bad_resample_is_named(bad):
    with pytest.raises(ValueError, match="resample"):
        stroke_features([[0, 0], [1, 1]], bad)


@pytest.mark.parametrize("path, words", [
    (np.zeros((0, 2)), "at least one point"),
    ([[0.0, 0.0], [np.nan, 1.0]], "finite"),
    ([[0.0, 0.0], [np.inf, 1.0]], "finite"),
])
def test_bad_path_is_a_value_error(path, words):
    with pytest.raises(ValueError, match=words):
        stroke_features(path, 8)

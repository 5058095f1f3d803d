"""Tests for sw_hps.orientation / sim.model.orientation (thesis §7.4, Fig. 82)."""
import ast
from pathlib import Path

import numpy as np
import pytest

import sw_hps.orientation as hps_orientation
from sim.model import orientation as model_orientation
from sw_hps.orientation import NO_SYMBOL, NUM_SYMBOLS, orientation_symbols


def _steps_to_points(steps):
    steps = np.asarray(steps, dtype=np.int64).reshape(-1, 2)
    return np.concatenate([[[1000, 1000]], 1000 + np.cumsum(steps, axis=0)])


def test_constants():
    assert NUM_SYMBOLS == 8 and NO_SYMBOL == -1


def test_matches_atan2_sectors_away_from_boundaries():
    rng = np.random.default_rng(40)
    steps = rng.integers(-1000, 1001, size=(20000, 2))
    steps = steps[(steps != 0).any(axis=1)]
    # Viewer's angle: y grows downward in the image, so "up" is -dy.
    angle = np.degrees(np.arctan2(-steps[:, 1], steps[:, 0])) % 360
    away = np.abs(((angle + 22.5) % 45) - 22.5) < 22.0     # > 0.5 deg from 22.5 + 45k
    steps, angle = steps[away], angle[away]
    assert len(steps) > 15000
    expected = np.round(angle / 45).astype(int) % 8
    out = orientation_symbols(_steps_to_points(steps))
    assert out.dtype == np.int8 and out.shape == (len(steps),)
    assert np.array_equal(out, expected)


@pytest.mark.parametrize("scale", [1, 7, 256])
def test_axis_and_diagonal_directions(scale):
    # (dx, dy) in image coordinates -> symbol counted counter-clockwise for a viewer.
    table = [((1, 0), 0), ((1, -1), 1), ((0, -1), 2), ((-1, -1), 3),
             ((-1, 0), 4), ((-1, 1), 5), ((0, 1), 6), ((1, 1), 7)]
    steps = [(dx * scale, dy * scale) for (dx, dy), _ in table]
    out = orientation_symbols(_steps_to_points(steps))
    assert out.tolist() == [symbol for _, symbol in table]


def test_straight_up_is_symbol_2():
    points = np.array([[10, 50], [10, 40], [10, 0]])
    assert orientation_symbols(points).tolist() == [2, 2]


def test_zero_step_is_no_symbol():
    points = np.array([[5, 5], [5, 5], [6, 5], [6, 5]])
    assert orientation_symbols(points).tolist() == [NO_SYMBOL, 0, NO_SYMBOL]


def test_integer_decision_at_the_tan_threshold():
    # 256*ay < 106*ax is horizontal; equality falls to diagonal.
    steps = [(256, 105), (256, 106), (-256, -105), (-256, -106),
             (105, -256), (106, -256), (-105, 256), (-106, 256)]
    assert orientation_symbols(_steps_to_points(steps)).tolist() == [0, 7, 4, 3, 2, 1, 6, 5]


def test_short_inputs_and_unsigned_dtype():
    assert orientation_symbols(np.zeros((1, 2), int)).shape == (0,)
    points = np.array([[10, 10], [5, 10], [5, 20]], np.uint16)   # steps must not wrap
    assert orientation_symbols(points).tolist() == [4, 6]


@pytest.mark.parametrize("bad", [np.zeros((0, 2), int), np.zeros((4, 3), int), np.zeros(4, int),
                                 np.zeros((4, 2), float), np.zeros((2, 2, 2), int),
                                 np.array([[0, 0], [2 ** 60, 0]])])
def test_rejects_bad_points(bad):
    with pytest.raises(ValueError, match="points"):
        orientation_symbols(bad)


def test_hps_module_is_standalone_and_model_reexports_it():
    tree = ast.parse(Path(hps_orientation.__file__).read_text())
    imported = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            imported |= {alias.name.split(".")[0] for alias in node.names}
        elif isinstance(node, ast.ImportFrom):
            imported.add((node.module or "").split(".")[0] if node.level == 0 else ".")
    assert imported <= {"numpy", "__future__"}
    assert model_orientation.orientation_symbols is orientation_symbols
    assert model_orientation.NO_SYMBOL == NO_SYMBOL and model_orientation.NUM_SYMBOLS == 8

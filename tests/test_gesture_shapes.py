"""The seven gesture shapes (thesis Fig. 16): rest at both ends, extent, direction sequences."""
import itertools
import math

import numpy as np
import pytest

from sim.gesture_shapes import (
    DIRECTION_NAMES, GESTURE_NAMES, SPEED_PROFILES, direction_codes, direction_names,
    gesture_id, gesture_path, random_time_warp,
)

# The documented 8-way direction sequences (module docstring).
EXPECTED_DIRECTIONS = {
    "forward": "N S",
    "back": "S N",
    "right": "W E",
    "left": "E W",
    "rotate-right": "N NW W SW S SE E NE N",
    "rotate-left": "N NE E SE S SW W NW N",
    "stop": "NW E SW",
}


def directions(path) -> str:
    return " ".join(direction_names(direction_codes(path)))


def test_names_and_class_ids():
    assert GESTURE_NAMES == ("forward", "back", "right", "left", "rotate-right",
                             "rotate-left", "stop")
    assert [gesture_id(name) for name in GESTURE_NAMES] == list(range(7))
    assert DIRECTION_NAMES[0] == "E" and DIRECTION_NAMES[2] == "N"


def test_unknown_gesture_lists_the_valid_names():
    for call in (lambda: gesture_path("wave", 10), lambda: gesture_id("wave")):
        with pytest.raises(ValueError) as err:
            call()
        assert "wave" in str(err.value)
        for name in GESTURE_NAMES:
            assert name in str(err.value)


@pytest.mark.parametrize("name", GESTURE_NAMES)
@pytest.mark.parametrize("profile", SPEED_PROFILES)
@pytest.mark.parametrize("num_points", [2, 3, 17, 60])
def test_starts_and_ends_at_rest(name, profile, num_points):
    path = gesture_path(name, num_points, speed_profile=profile)
    assert path.shape == (num_points, 2) and path.dtype == np.float64
    assert np.array_equal(path[0], [0.0, 0.0])
    assert np.array_equal(path[-1], [0.0, 0.0])


EXTENTS = {  # (xmin, xmax, ymin, ymax) in amplitude units, image axes (y down)
    "forward": (0.0, 0.0, -1.0, 0.0),
    "back": (0.0, 0.0, 0.0, 1.0),
    "right": (-1.0, 0.0, 0.0, 0.0),
    "left": (0.0, 1.0, 0.0, 0.0),
    "rotate-right": (-1.0, 0.0, -0.5, 0.5),
    "rotate-left": (0.0, 1.0, -0.5, 0.5),
    "stop": (-0.5, 0.5, -math.sqrt(3) / 2, 0.0),
}


@pytest.mark.parametrize("name", GESTURE_NAMES)
def test_extent(name):
    path = gesture_path(name, 721, speed_profile="constant")
    got = (path[:, 0].min(), path[:, 0].max(), path[:, 1].min(), path[:, 1].max())
    assert got == pytest.approx(EXTENTS[name], abs=1e-3)


def test_documented_sides_and_first_moves():
    # "right" is towards the image's LEFT edge, "left" towards its right edge.
    assert gesture_path("right", 41)[20, 0] == pytest.approx(-1.0)
    assert gesture_path("left", 41)[20, 0] == pytest.approx(1.0)
    assert gesture_path("forward", 41)[20, 1] == pytest.approx(-1.0)    # up
    assert gesture_path("back", 41)[20, 1] == pytest.approx(1.0)        # down
    # Loops leave the rest position moving up, then head to their own side.
    for name, side in (("rotate-right", -1), ("rotate-left", 1)):
        path = gesture_path(name, 81, speed_profile="constant")
        assert path[1, 1] < 0 and abs(path[1, 0]) < abs(path[1, 1])
        assert path[20] == pytest.approx([side * 0.5, -0.5], abs=1e-9)  # top after 1/4
        assert path[40] == pytest.approx([side * 1.0, 0.0], abs=1e-9)   # far point at 1/2
        assert path[60] == pytest.approx([side * 0.5, 0.5], abs=1e-9)   # bottom at 3/4
    # stop: up-left first, apex (rest) at the bottom.
    stop = gesture_path("stop", 61)
    assert stop[1, 0] < 0 and stop[1, 1] < 0
    assert stop[:, 1].max() == pytest.approx(0.0)


def test_loops_are_mirror_images():
    for profile in SPEED_PROFILES:
        right = gesture_path("rotate-right", 50, speed_profile=profile)
        left = gesture_path("rotate-left", 50, speed_profile=profile)
        assert np.allclose(left[:, 0], -right[:, 0]) and np.allclose(left[:, 1], right[:, 1])


@pytest.mark.parametrize("num_points", [30, 42, 61, 82])
def test_direction_sequences_are_documented_and_pairwise_distinct(num_points):
    seen = {}
    for name in GESTURE_NAMES:
        seq = directions(gesture_path(name, num_points))
        assert seq == EXPECTED_DIRECTIONS[name], name
        seen[name] = seq
    for a, b in itertools.combinations(GESTURE_NAMES, 2):
        assert seen[a] != seen[b], (a, b)


def test_direction_sequences_survive_person_variation():
    rng = np.random.default_rng(5)
    for name in GESTURE_NAMES:
        for _ in range(10):
            num_points = int(rng.integers(30, 90))
            warp = random_time_warp(num_points, rng, strength=0.15)
            aspect = float(rng.uniform(0.8, 1.25))
            path = gesture_path(name, num_points, aspect=aspect, time_warp=warp)
            assert directions(path) == EXPECTED_DIRECTIONS[name], name


def test_aspect_stretches_y_only():
    base = gesture_path("rotate-left", 33)
    tall = gesture_path("rotate-left", 33, aspect=1.5)
    assert np.allclose(tall[:, 0], base[:, 0]) and np.allclose(tall[:, 1], 1.5 * base[:, 1])


def test_constant_profile_has_uniform_speed():
    for name in ("left", "rotate-right", "stop"):
        steps = np.hypot(*np.diff(gesture_path(name, 200, speed_profile="constant"), axis=0).T)
        # All but the few chords that cut a corner or a turning point are equal.
        regular = np.abs(steps / np.median(steps) - 1) < 0.02
        assert regular.sum() >= len(steps) - 3, name


def test_smooth_profile_stops_at_turning_points():
    path = gesture_path("forward", 41)       # sample 20 is the top of the stroke
    steps = np.hypot(*np.diff(path, axis=0).T)
    assert steps[0] < 0.05 * steps.max() and steps[-1] < 0.05 * steps.max()
    assert steps[19] < 0.05 * steps.max() and steps[20] < 0.05 * steps.max()


def test_random_time_warp():
    warp = random_time_warp(50, np.random.default_rng(1), strength=0.3)
    assert warp.shape == (50,) and warp[0] == 0.0 and warp[-1] == 1.0
    assert np.all(np.diff(warp) > 0)
    assert not np.allclose(warp, np.linspace(0, 1, 50))
    again = random_time_warp(50, np.random.default_rng(1), strength=0.3)
    assert np.array_equal(warp, again)
    assert np.array_equal(random_time_warp(7, np.random.default_rng(0), strength=0.0),
                          np.linspace(0, 1, 7))
    path = gesture_path("stop", 50, time_warp=warp)
    assert np.array_equal(path[0], [0, 0]) and np.array_equal(path[-1], [0, 0])


@pytest.mark.parametrize("kwargs, field", [
    (dict(num_points=1), "num_points"),
    (dict(num_points=2.5), "num_points"),
    (dict(aspect=0.1), "aspect"),
    (dict(speed_profile="jerky"), "speed_profile"),
    (dict(time_warp=np.linspace(0, 1, 9)), "time_warp"),
    (dict(time_warp=np.linspace(1, 0, 10)), "time_warp"),
    (dict(time_warp=np.linspace(0, 0.5, 10)), "time_warp"),
])
def test_bad_parameters(kwargs, field):
    args = dict(name="left", num_points=10) | kwargs
    with pytest.raises(ValueError, match=field):
        gesture_path(**args)
    with pytest.raises(ValueError, match="strength"):
        random_time_warp(10, np.random.default_rng(0), strength=0.5)


def test_direction_codes_basics():
    square = np.array([[0, 0], [1, 0], [1, -1], [0, -1], [0, 0]], float)   # E, N, W, S
    assert direction_codes(square) == (0, 2, 4, 6)
    assert direction_codes(np.array([[0, 0], [1, 1], [2, 2]], float)) == (7,)   # down-right
    assert direction_codes(np.zeros((5, 2))) == ()
    assert direction_codes(square, merge_repeats=False) == (0, 2, 4, 6)
    with pytest.raises(ValueError, match="path"):
        direction_codes(np.zeros((4, 3)))

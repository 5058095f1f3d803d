"""recognition.corpus (the synthetic hand-centroid corpus) and `stereogest gestures`."""
import numpy as np
import pytest

import stereogest.cli as cli
from recognition.corpus import (generate_corpus, person_style, spotted_coverage,
                                synthetic_corpus)
from recognition.datasets import load_trajectories
from recognition.features import camera_symbols
from sim.gesture_shapes import GESTURE_NAMES

# The outbound direction of each gesture as the board first sees it (0 right, 2 up,
# 4 left, 6 down, 1/3/5/7 the diagonals, y up on screen).
FIRST_SYMBOL = {"forward": {2}, "back": {6}, "right": {4}, "left": {0},
                "rotate-right": {2, 3}, "rotate-left": {1, 2}, "stop": {3}}
RETURN_SYMBOL = {"forward": 6, "back": 2, "right": 0, "left": 4}


@pytest.fixture(scope="module")
def default_corpus():
    return generate_corpus()


@pytest.fixture(scope="module")
def symbol_subset():
    """30 samples per gesture (10 per person) with their symbol sequences."""
    corpus = generate_corpus(per_class=30)
    symbols = [camera_symbols(t) for t in corpus.data.trajectories()]
    return corpus, symbols


# ---------------------------------------------------------------- layout


def test_default_corpus_shape_labels_subjects(default_corpus):
    data = default_corpus.data
    assert len(data) == 7 * 180
    assert data.label.tolist() == [g for g in GESTURE_NAMES for _ in range(180)]
    assert data.subject.tolist() == [k % 3 for _ in GESTURE_NAMES for k in range(180)]
    for name in GESTURE_NAMES:                          # 60 samples per person and gesture
        counts = np.bincount(data.subject[data.label == name], minlength=3)
        assert counts.tolist() == [60, 60, 60]
    assert default_corpus.motion.shape == (len(data), 2)
    assert default_corpus.people == tuple(person_style(0, p) for p in range(3))


def test_points_are_integer_pixels_inside_the_image(default_corpus):
    points = default_corpus.data.points
    assert np.array_equal(points, np.floor(points))
    assert points[:, 0].min() >= 0 and points[:, 0].max() <= 639
    assert points[:, 1].min() >= 0 and points[:, 1].max() <= 479


def test_durations_are_those_of_the_renderer(default_corpus):
    lengths = np.diff(default_corpus.data.offsets)
    first, last = default_corpus.motion.T
    motion = last - first + 1
    assert motion.min() >= 40 and motion.max() <= 80
    assert first.min() >= 15 and first.max() <= 30                 # pre-gesture rest
    post = lengths - 1 - last
    assert post.min() >= 15 and post.max() <= 30
    assert motion.max() - motion.min() >= 30                       # a real spread
    amplitude = default_corpus.amplitude
    assert amplitude.min() >= 0.85 * 200 - 1e-9 and amplitude.max() <= 1.15 * 200 + 1e-9


def test_rest_is_still_but_jittery_and_motion_is_large(default_corpus):
    data, motion = default_corpus.data, default_corpus.motion
    for i in range(0, len(data), 37):
        track = data.trajectory(i)
        first, last = motion[i]
        rest = track[:first]
        assert np.ptp(rest, axis=0).max() <= 30                    # no gesture at rest
        assert np.abs(np.diff(rest, axis=0)).sum() > 0             # but never frozen
        extent = np.ptp(track[first:last + 1], axis=0).max()
        assert extent >= 0.7 * 170


def test_corpus_has_dropped_frames_and_person_styles_differ(default_corpus):
    assert 0 < (default_corpus.dropped > 0).mean() < 0.7
    styles = default_corpus.people
    assert len({round(s.amplitude, 3) for s in styles}) == 3
    assert len({s.rest for s in styles}) == 3
    # Each person's samples follow their amplitude (per-sample spread +-5 % of 200 px);
    # the horizontal swipes always fit at 640x480, so none was shrunk.
    data = default_corpus.data
    for person, style in enumerate(styles):
        mine = default_corpus.amplitude[(data.subject == person)
                                        & np.isin(data.label, ["right", "left"])]
        assert np.abs(mine - style.amplitude).max() <= 10 + 1e-9


def test_deterministic_and_seeded():
    a = synthetic_corpus(per_class=6, seed=5)
    b = synthetic_corpus(per_class=6, seed=5)
    assert np.array_equal(a.points, b.points) and np.array_equal(a.offsets, b.offsets)
    assert a.label.tolist() == b.label.tolist() and a.subject.tolist() == b.subject.tolist()
    c = synthetic_corpus(per_class=6, seed=6)
    assert not (len(a.points) == len(c.points) and np.array_equal(a.points, c.points))


def test_fewer_samples_per_class_is_a_prefix():
    small = synthetic_corpus(per_class=4, seed=2)
    large = synthetic_corpus(per_class=9, seed=2)
    for g in range(len(GESTURE_NAMES)):
        for k in range(4):
            assert np.array_equal(small.trajectory(4 * g + k), large.trajectory(9 * g + k))


def test_other_sizes_and_frame_rates():
    data = generate_corpus(per_class=3, people=2, seed=1, width=320, height=240, fps=60)
    motion = data.motion[:, 1] - data.motion[:, 0] + 1
    assert motion.min() >= 80 and motion.max() <= 160               # durations scale with fps
    assert data.amplitude.max() <= 1.15 * 100 + 1e-9                # lengths with the size
    points = data.data.points
    assert points.min() >= 0 and points[:, 0].max() <= 319 and points[:, 1].max() <= 239
    assert set(data.data.subject.tolist()) == {0, 1}


@pytest.mark.parametrize("name, value", [("per_class", 0), ("people", 0), ("seed", -1),
                                         ("width", 95), ("height", 5000), ("fps", 4),
                                         ("per_class", 2.0), ("people", True)])
def test_bad_parameters_are_named(name, value):
    with pytest.raises(ValueError, match=name):
        synthetic_corpus(**{"per_class": 1, name: value})


# ---------------------------------------------------------------- what the board sees


def test_every_sample_gives_symbols_and_spotting_covers_the_motion(symbol_subset):
    corpus, symbols = symbol_subset
    assert min(len(s) for s in symbols) > 0
    coverage = np.array([spotted_coverage(t, m) for t, m in
                         zip(corpus.data.trajectories(), corpus.motion)])
    # Spotting starts once the smoothed hand moved > 30 px in 8 frames (after the slow
    # start of the movement) and holds 16 still frames: most of the motion is inside.
    assert coverage.mean() >= 0.75
    assert (coverage >= 0.8).mean() >= 0.75
    assert np.median(coverage) >= 0.8


def test_symbol_sequences_are_distinct_per_class(symbol_subset):
    corpus, symbols = symbol_subset
    labels = corpus.data.label
    histograms = {}
    for name in GESTURE_NAMES:
        mine = [s for s, label in zip(symbols, labels) if label == name]
        first = np.bincount([s[0] for s in mine], minlength=8)
        assert first.argmax() in FIRST_SYMBOL[name], (name, first)
        histograms[name] = np.mean([np.bincount(s, minlength=8) / len(s) for s in mine], 0)
    for name, back in RETURN_SYMBOL.items():
        out = next(iter(FIRST_SYMBOL[name]))
        # The two strokes dominate; spotting misses the start of the first one and
        # runs on for 16 frames after the second, so the return stroke is the longer.
        assert set(np.argsort(histograms[name])[-2:]) == {out, back}
        assert histograms[name][out] > 0.25 and histograms[name][back] > 0.25
        # Order separates forward from back: the outbound symbols come first (unless
        # a slow turn of 16 still frames split the gesture and only the return is left).
        mine = [s for s, label in zip(symbols, labels) if label == name]
        ordered = [np.flatnonzero(s == out).mean() < np.flatnonzero(s == back).mean()
                   for s in mine if (s == out).any() and (s == back).any()]
        assert np.mean(ordered) >= 0.9 and len(ordered) >= 0.9 * len(mine)
    # The two loops run opposite ways round: the board's symbols mirror each other.
    mirror = [4 - k if k <= 4 else 12 - k for k in range(8)]        # x -> -x
    assert np.abs(histograms["rotate-right"][mirror] - histograms["rotate-left"]).max() < 0.05
    # The triangle's edges: up-left, right, down-left.
    assert set(np.argsort(histograms["stop"])[-3:]) == {3, 0, 5}
    names = list(GESTURE_NAMES)
    for i, a in enumerate(names):
        for b in names[i + 1:]:
            if {a, b} not in ({"forward", "back"}, {"right", "left"},
                              {"rotate-right", "rotate-left"}):
                assert np.abs(histograms[a] - histograms[b]).sum() > 0.5, (a, b)


# ---------------------------------------------------------------- command line


def test_cli_writes_a_loadable_corpus(tmp_path, capsys):
    out = tmp_path / "corpus.npz"
    status = cli.main(["gestures", "-o", str(out), "--per-class", "4", "--people", "2",
                       "--seed", "3", "--width", "320", "--height", "240", "--fps", "25"])
    stdout, err = capsys.readouterr()
    assert status == 0 and err == ""
    assert len(stdout.strip().splitlines()) == 1 and "28 trajectories" in stdout
    data = load_trajectories(out)
    expected = synthetic_corpus(per_class=4, people=2, seed=3, width=320, height=240, fps=25)
    assert data.label.tolist() == expected.label.tolist()
    assert data.subject.tolist() == expected.subject.tolist()
    assert np.array_equal(data.points, expected.points)             # integers: exact in float32
    with np.load(out, allow_pickle=False) as raw:
        assert raw["motion"].shape == (28, 2)
        assert int(raw["fps"]) == 25 and raw["image_size"].tolist() == [320, 240]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["corpus.npz"]


@pytest.mark.parametrize("argv, option", [(["--per-class", "0"], "--per-class"),
                                          (["--people", "-2"], "--people"),
                                          (["--seed", "-1"], "--seed"),
                                          (["--width", "20"], "--width"),
                                          (["--height", "9999"], "--height"),
                                          (["--fps", "1"], "--fps")])
def test_cli_bad_values_exit_2_naming_the_option(tmp_path, capsys, argv, option):
    out = tmp_path / "corpus.npz"
    status = cli.main(["gestures", "-o", str(out), *argv])
    _, err = capsys.readouterr()
    lines = err.strip().splitlines()
    assert status == 2 and len(lines) == 1
    assert lines[0].startswith("stereogest gestures: error: ") and option in lines[0]
    assert not out.exists()


def test_cli_missing_output_directory(tmp_path, capsys):
    status = cli.main(["gestures", "-o", str(tmp_path / "no" / "c.npz"), "--per-class", "1"])
    _, err = capsys.readouterr()
    assert status == 2 and "--output" in err

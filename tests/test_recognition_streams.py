"""recognition/streams.py: gestures joined into continuous streams (issue 28),
on real $1 strokes: the truth spans hold the gestures' own points, the pauses
and transits lie between them at the gestures' pace, one subject per stream,
the file round trip and its validation."""
from pathlib import Path

import numpy as np
import pytest

from recognition.datasets import load_trajectories
from recognition.streams import (GestureStream, join_stream, load_streams, save_streams,
                                 subject_streams)

DOLLAR = Path(__file__).resolve().parent.parent / "data/gestures/dollar1_unistroke/dollar1_unistroke.npz"


@pytest.fixture(scope="module")
def dollar():
    return load_trajectories(DOLLAR)


def test_spans_hold_the_gestures_and_the_gaps_are_pauses_and_transits(dollar):
    parts = [dollar.trajectory(i) for i in (0, 500, 1000, 1500)]
    labels = [dollar.label[i] for i in (0, 500, 1000, 1500)]
    stream = join_stream(parts, labels, np.random.default_rng(1), pause=(3, 6))
    assert list(stream.labels) == labels
    for (first, last), part in zip(stream.spans, parts):
        np.testing.assert_array_equal(stream.points[first:last + 1], part)
    assert stream.spans[0, 0] == 0 and stream.spans[-1, 1] == len(stream) - 1
    for k in range(len(parts) - 1):
        gap = stream.points[stream.spans[k, 1]:stream.spans[k + 1, 0] + 1]
        steps = np.linalg.norm(np.diff(gap, axis=0), axis=1)
        held = int(np.argmax(steps > 0))               # the pause: the hand still
        assert 3 <= held <= 6
        paces = [np.median(s[s > 0]) for s in (np.linalg.norm(np.diff(p, axis=0), axis=1)
                                                 for p in parts[k:k + 2])]
        # the transit at the gestures' pace: no jump
        assert steps.max() <= 2 * np.mean(paces) + 1e-9


def test_no_pause_flows_on(dollar):
    parts = [dollar.trajectory(i) for i in (10, 20, 30)]
    stream = join_stream(parts, ["a", "b", "c"], np.random.default_rng(0), pause=(0, 0))
    gaps = stream.spans[1:, 0] - stream.spans[:-1, 1] - 1
    steps = np.linalg.norm(np.diff(stream.points, axis=0), axis=1)
    assert (steps[stream.spans[0, 1]:stream.spans[1, 0]] > 0).all()
    assert len(stream) == sum(len(p) for p in parts) + gaps.sum()


def test_streams_per_subject_cover_every_trajectory_once(dollar):
    data = dollar.subset(np.flatnonzero(np.isin(dollar.subject, [2, 3]))[::8])
    streams = subject_streams(data, 8, seed=4)
    assert sum(len(s.spans) for s in streams) == len(data)
    assert all(len(s.spans) <= 8 for s in streams)
    for subject in (2, 3):
        mine = [s for s in streams if s.subject == subject]
        assert sorted(np.concatenate([s.labels for s in mine]).tolist()) == \
            sorted(data.label[data.subject == subject].tolist())
    again = subject_streams(data, 8, seed=4)
    assert all(np.array_equal(a.points, b.points) for a, b in zip(streams, again))
    other = subject_streams(data, 8, seed=5)
    assert not all(np.array_equal(a.labels, b.labels) for a, b in zip(streams, other))


def test_file_round_trip_and_bad_files(tmp_path, dollar):
    streams = subject_streams(dollar.subset(np.arange(0, 3360, 97)), 5, seed=2)
    path = tmp_path / "s.npz"
    save_streams(streams, path)
    back = load_streams(path)
    assert len(back) == len(streams)
    for a, b in zip(streams, back):
        np.testing.assert_allclose(a.points, b.points, atol=1e-3)
        assert np.array_equal(a.spans, b.spans) and list(a.labels) == list(b.labels)
        assert a.subject == b.subject
    with np.load(path) as f:
        arrays = dict(f)
    arrays["span_last"] = arrays["span_last"].copy()
    arrays["span_last"][1] = arrays["span_first"][2] + 1      # overlaps the next span
    bad = tmp_path / "bad.npz"
    np.savez(bad, **arrays)
    with pytest.raises(ValueError, match="span_first/span_last must rise"):
        load_streams(bad)
    del arrays["span_label"]
    np.savez(bad, **arrays)
    with pytest.raises(ValueError, match="missing key.*span_label"):
        load_streams(bad)


@pytest.mark.parametrize("kwargs, match", [
    ({"pause": (5, 2)}, "pause must satisfy"),
    ({"pause": "x"}, "pause must be two integers"),
])
def test_bad_arguments_name_themselves(kwargs, match):
    with pytest.raises(ValueError, match=match):
        join_stream([np.zeros((3, 2))], ["a"], np.random.default_rng(0), **kwargs)


def test_bad_streams_are_refused():
    with pytest.raises(ValueError, match="spans must rise"):
        GestureStream(np.zeros((10, 2)), [[0, 4], [3, 6]], ["a", "b"])
    with pytest.raises(ValueError, match="labels must be 1 strings"):
        GestureStream(np.zeros((10, 2)), [[0, 4]], ["a", "b"])
    with pytest.raises(ValueError, match="per_stream"):
        from recognition.datasets import TrajectorySet
        subject_streams(TrajectorySet.from_list([np.zeros((2, 2))], ["a"], [1]), 0)


def test_distractors_before_every_gesture(dollar):
    """With distractors the gestures keep their points and order; before each
    one lies a distractor (scaled to the gestures) and a pause; without, the
    streams are the same as before (the distractors draw nothing then)."""
    from recognition.streams import gesture_extent
    plain = subject_streams(dollar, 8, 2)
    mixed = subject_streams(dollar, 8, 2, distractors=True)
    assert len(plain) == len(mixed)
    unit = gesture_extent([dollar.trajectory(i) for i in range(len(dollar))])
    for a, b in zip(plain[:10], mixed[:10]):
        assert list(a.labels) == list(b.labels) and len(b) > len(a)
        for (f0, l0), (f1, l1) in zip(a.spans, b.spans):
            assert np.array_equal(a.points[f0:l0 + 1], b.points[f1:l1 + 1])
        assert b.spans[0][0] > 0               # a distractor before the first one
        before = b.points[:b.spans[0][0]]
        assert np.array_equal(before[-1], b.points[b.spans[0][0]])   # ends where it begins
    reach = [np.ptp(s.points[:s.spans[0][0]], axis=0).max() for s in mixed[:30]]
    assert np.median(reach) > 0.3 * unit
    again = subject_streams(dollar, 8, 2, distractors=True)
    assert all(np.array_equal(a.points, b.points) for a, b in zip(mixed, again))
    assert all(s.present.all() for s in plain)


def test_out_of_view_hides_the_hand(dollar, tmp_path):
    """While an out-of-view distractor has the hand below the picture the
    stream says no hand (``present`` false): only there, never in a gesture,
    and the flag survives the file."""
    from recognition.streams import distractor_stream, gesture_extent
    mixed = subject_streams(dollar, 8, 2, distractors=True)
    hidden = 0
    for s in mixed[:20]:
        inside = np.zeros(len(s), bool)
        for first, last in s.spans:
            inside[first:last + 1] = True
        assert s.present[inside].all()
        hidden += (~s.present).sum()
    assert hidden > 0
    unit = gesture_extent([dollar.trajectory(i) for i in range(len(dollar))])
    start = np.array([100.0, 50.0])
    idle = distractor_stream(start, unit, 3000, np.random.default_rng(1), kinds=("out-of-view",))
    low = idle.points[:, 1] - start[1] >= 1.6 * unit
    assert low.any() and np.array_equal(~idle.present, low)
    alone = distractor_stream(start, unit, 3000, np.random.default_rng(1), kinds=("reach",))
    assert alone.present.all()
    path = tmp_path / "s.npz"
    save_streams(mixed[:3], path)
    assert all(np.array_equal(a.present, b.present) for a, b in zip(mixed, load_streams(path)))
    with np.load(path) as f:
        arrays = {k: f[k] for k in f.files if k != "present"}
    np.savez(path, **arrays)                     # files from before the flag: always in view
    assert all(s.present.all() for s in load_streams(path))
    with pytest.raises(ValueError, match="present must be 3 booleans"):
        GestureStream(np.zeros((3, 2)), [[0, 1]], ["a"], present=[1, 0])


def test_cli_joins_a_dataset_into_streams(tmp_path, dollar):
    from stereogest import cli
    out = tmp_path / "streams.npz"
    assert cli.main(["gestures", "--join", str(DOLLAR), "-o", str(out), "--per-stream", "8",
                     "--pause", "0-3", "--seed", "4"]) == 0
    streams = load_streams(out)
    assert sum(len(s.spans) for s in streams) == len(dollar)
    assert {s.subject for s in streams} == set(np.unique(dollar.subject).tolist())
    again = subject_streams(dollar, 8, 4, pause=(0, 3))
    assert all(np.allclose(a.points, b.points, atol=1e-3) and (a.spans == b.spans).all()
               for a, b in zip(streams, again))
    out = tmp_path / "mixed.npz"
    assert cli.main(["gestures", "--join", str(DOLLAR), "-o", str(out), "--distractors",
                     "--seed", "4"]) == 0
    mixed = load_streams(out)
    assert sum(len(s) for s in mixed) > sum(len(s) for s in streams)
    assert cli.main(["gestures", "-o", str(tmp_path / "c.npz"), "--distractors"]) == 2
    assert not (tmp_path / "c.npz").exists()

"""recognition/continuous.py: how detections are scored against the truth of a
stream (label, overlap of half the shorter span, each gesture once), the
summary figures, and one stream spotted end to end by the board's recogniser."""
import numpy as np
import pytest

from recognition.continuous import match_detections, spot_stream, stream_summary
from recognition.streams import GestureStream
from sw_hps.continuous import ContinuousRecogniser, Detection
from tests.test_hps_continuous import MODELS


def _det(name, first, last, at=None):
    return Detection(0, name, first, last, 1.0, last + 2 if at is None else at)


def test_a_detection_matches_by_label_and_half_overlap_once():
    spans, labels = [(10, 29), (40, 59)], ["a", "b"]
    found = [_det("a", 18, 29), _det("a", 12, 28), _det("b", 52, 70), _det("a", 45, 55)]
    matched, latencies = match_detections(found, spans, labels)
    # 18..29 overlaps 12 of its own 12 frames: a match; the second "a" finds
    # its gesture taken (a command twice); 52..70 overlaps 8 of the shorter
    # span's 19 frames (< half); a wrong label never matches
    assert matched == [0, -1, -1, -1]
    assert latencies == [2]


def test_summary_figures():
    s = stream_summary(true_count=10, detections=9, correct=8, latencies=[1, 3, 5],
                       transit_frames=18_000, false_commands=1, fps=30.0)
    assert s["precision"] == pytest.approx(8 / 9) and s["recall"] == pytest.approx(0.8)
    assert s["f1"] == pytest.approx(2 * 8 / 19)
    assert s["latency_median_frames"] == 3 and s["false_commands_per_10_min"] == pytest.approx(1.0)


def test_spot_stream_names_a_drawn_gesture():
    # up-right's symbols drawn as a path: right (0) then up (2), twice, 2 px a frame
    moves = [(2, 0)] * 6 + [(0, -2)] * 6 + [(2, 0)] * 6 + [(0, -2)] * 6
    still = [(0, 0)] * 15
    points = np.cumsum([(100, 100)] + still + moves + still, axis=0)
    stream = GestureStream(points, np.array([[15, 39]]), np.array(["up-right"]))
    found = spot_stream(ContinuousRecogniser(MODELS, end_delay=5), stream.points, step=4)
    matched, _ = match_detections(found, stream.spans, stream.labels)
    assert [d.name for d in found] == ["up-right"] and matched == [0]


def test_symbol_gap_is_the_longest_wait_inside_the_training_gestures():
    """max_gap learned from gestures: the quantile of each trajectory's longest
    wait between two symbols (the rests around a gesture do not count)."""
    from recognition.continuous import symbol_gap
    from recognition.datasets import TrajectorySet
    # 4 px a frame, a symbol every 2 frames at step 8; one trajectory holds
    # still for 9 frames in the middle (a wait of 9 + 2 frames between symbols)
    run = [(4, 0)] * 8
    plain = np.cumsum([(50, 50)] + [(0, 0)] * 5 + run + [(0, 0)] * 20, axis=0)
    held = np.cumsum([(50, 50)] + run + [(0, 0)] * 9 + run, axis=0)
    parts = [plain] * 9 + [held]
    data = TrajectorySet(np.concatenate(parts).astype(float),
                         np.concatenate([[0], np.cumsum([len(p) for p in parts])]),
                         np.array(["a"] * 10), subject=np.arange(10))
    assert symbol_gap(data, 8, quantile=1.0) == 11
    assert symbol_gap(data, 8, quantile=0.5) == 2
    # max_gap_share: the same waits over each trajectory's span, rounded up to
    # a thousandth: 2 of 6 frames (plain), 11 of 23 (held)
    from recognition.continuous import symbol_gap_share
    assert symbol_gap_share(data, 8, quantile=1.0) == 0.479
    assert symbol_gap_share(data, 8, quantile=0.5) == 0.334
    assert symbol_gap_share(data, 1000) == 0.0                # no trajectory has 3 symbols


def test_distractors_alone_and_the_gap_limit():
    """A stream of distractors alone names nothing it cannot: with the gap limit
    a reach-and-hold that traces a gesture's shape is cut at its hold."""
    from recognition.streams import distractor_stream
    stream = distractor_stream((200, 200), 60.0, 3000, np.random.default_rng(3))
    assert len(stream) == 3000 and len(stream.spans) == 0
    drift = distractor_stream((200, 200), 60.0, 3000, np.random.default_rng(3), kinds=["drift"])
    assert np.abs(drift.points - 200).max() <= 0.45 * 60 + 1e-9      # drifts are small
    with pytest.raises(ValueError, match="kinds must name one or more of out-of-view"):
        distractor_stream((0, 0), 1.0, 10, np.random.default_rng(0), kinds=["jump"])
    # up-right with a hold of 30 frames between its halves: named without the
    # limit, not with it
    half = [(2, 0)] * 6 + [(0, -2)] * 6
    points = np.cumsum([(100, 100)] + half + [(0, 0)] * 30 + half + [(0, 0)] * 15, axis=0)
    free = spot_stream(ContinuousRecogniser(MODELS, end_delay=5), points, step=4)
    cut = spot_stream(ContinuousRecogniser(MODELS, end_delay=5, max_gap=12), points, step=4)
    assert [d.name for d in free] == ["up-right"] and cut == []


def test_calibration_chooses_the_bias_then_the_end_delay(monkeypatch):
    """calibrate_spotting: the bias with the best F1 at the given end delay
    (ties: the larger bias), then at that bias the end delay with the best F1
    (ties: the shorter delay); counts faked per option so the choice is known."""
    import recognition.continuous as rc
    from recognition.corpus import synthetic_corpus
    data = synthetic_corpus(per_class=2, people=2, seed=4)
    sequences = rc.distance_sequences(data, 20, "camera")
    seen = []

    def fake_counts(recogniser, streams, step, front_end="pen"):
        seen.append((recogniser.threshold_bias, recogniser.end_delay))
        correct = {(-1.0, 8): 9, (-0.5, 8): 9, (-0.5, 2): 9, (-0.5, 4): 10}.get(
            (recogniser.threshold_bias, recogniser.end_delay), 5)
        return 10, 10, correct, [], 0, 0

    monkeypatch.setattr(rc, "_spot_counts", fake_counts)
    options = dict(rc.SPOTTING_DEFAULTS, end_delay=8)
    chosen, report = rc.calibrate_spotting(
        data, sequences, states=3, step=20, emission_floor=1e-3, per_stream=4, pause=(0, 5),
        seed=0, spotting=options, grid=(-1.0, -0.5, 0.0), delays=(2, 4, 8), front_end="camera")
    assert chosen == {"threshold_bias": -0.5, "end_delay": 4}
    assert report["threshold_bias"] == {"-1.0": 0.9, "-0.5": 0.9, "0.0": 0.5}
    assert report["end_delay"] == {"2": 0.9, "4": 1.0, "8": 0.9}
    assert {d for b, d in seen if b != -0.5} == {8}         # the bias at the given delay
    chosen, report = rc.calibrate_spotting(
        data, sequences, states=3, step=20, emission_floor=1e-3, per_stream=4, pause=(0, 5),
        seed=0, spotting=options, grid=(-1.0, -0.5), delays=(8, 2), front_end="camera")
    assert chosen["end_delay"] == 2                          # a tie: the shorter delay
    chosen, report = rc.calibrate_spotting(
        data, sequences, states=3, step=20, emission_floor=1e-3, per_stream=4, pause=(0, 5),
        seed=0, spotting=options, grid=(-1.0,), delays=None, front_end="camera")
    assert chosen == {"threshold_bias": -1.0, "end_delay": 8} and "end_delay" not in report

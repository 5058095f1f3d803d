"""sw_hps/continuous.py: the threshold-model recogniser names each gesture of a
stream once, with its frame span, within its delay; refuses noise; options and
models are validated. sw_hps/orientation.DistanceSymbols: symbols at equal travel."""
import numpy as np
import pytest

from sw_hps.continuous import ContinuousRecogniser, check_spotting, threshold_model
from sw_hps.hmm import DiscreteHMM, GestureModels
from sw_hps.orientation import DistanceSymbols


def _chain(symbols, stay=0.8, floor=0.01):
    """A left-right HMM whose state k emits mostly ``symbols[k]``."""
    n = len(symbols)
    a = np.zeros((n, n))
    for k in range(n):
        a[k, k] = stay if k < n - 1 else 1.0
        if k < n - 1:
            a[k, k + 1] = 1 - stay
    b = np.full((n, 8), floor)
    for k, s in enumerate(symbols):
        b[k, s] = 1 - 7 * floor
    pi = np.eye(n)[0]
    return DiscreteHMM(pi, a, b)


# four classes of four states: the threshold model has 16 states to choose
# from, and the noise below (1s and 5s in random order) is what the states
# of "circle" explain in pieces, never in its order
MODELS = GestureModels(("up-right", "down-left", "zigzag", "circle"),
                       (_chain([0, 2, 0, 2]), _chain([4, 6, 4, 6]), _chain([0, 6, 0, 6]),
                        _chain([1, 3, 5, 7])))


def _run(rec, frames):
    """frames: symbols or None, one per frame; everything named, then flushed."""
    named = []
    for f, s in enumerate(frames):
        named += rec.step(f, s)
    return named + rec.flush(len(frames) - 1)


def test_names_each_gesture_once_with_its_span():
    rng = np.random.RandomState(0)   # legacy stream: same draws on the board's numpy 1.16
    noise = [int(s) for s in rng.choice([1, 5], 12)]
    gesture_a = [0] * 3 + [2] * 3 + [0] * 3 + [2] * 3    # frames 12..23
    gesture_b = [4] * 3 + [6] * 3 + [4] * 3 + [6] * 3    # frames 36..47
    frames = noise + gesture_a + noise + gesture_b + [None] * 20
    rec = ContinuousRecogniser(MODELS, end_delay=5)
    named = _run(rec, frames)
    assert [d.name for d in named] == ["up-right", "down-left"]
    a, b = named
    # the start is exact; the end lies in the final state's run (a run of
    # one symbol explains the same under the threshold model's copy of it)
    assert a.first == 12 and 21 <= a.last <= 23
    assert b.first == 36 and 45 <= b.last <= 47
    assert b.named_at - b.last <= 5 + 1                   # within the end delay
    assert all(d.score > 0 for d in named)
    assert _run(ContinuousRecogniser(MODELS, end_delay=5), frames) == named    # deterministic


def test_noise_and_stillness_name_nothing():
    rng = np.random.RandomState(1)
    frames = [None if rng.random_sample() < 0.3 else int(rng.choice([1, 5])) for _ in range(300)]
    assert _run(ContinuousRecogniser(MODELS), frames) == []


def test_back_to_back_gestures_and_a_stricter_threshold():
    frames = ([0] * 3 + [2] * 3) * 2 + ([4] * 3 + [6] * 3) * 2 + [None] * 10
    named = _run(ContinuousRecogniser(MODELS, end_delay=3), frames)
    assert [d.name for d in named] == ["up-right", "down-left"]
    assert named[0].last < named[1].first
    # a threshold raised far above any class refuses everything
    assert _run(ContinuousRecogniser(MODELS, threshold_bias=5.0), frames) == []


def test_flush_names_a_gesture_that_ends_with_the_source():
    rec = ContinuousRecogniser(MODELS, end_delay=50)
    named = []
    for f, s in enumerate(([0] * 3 + [2] * 3) * 2):
        named += rec.step(f, s)
    assert named == []
    named = rec.flush()
    assert [d.name for d in named] == ["up-right"] and named[0].named_at == 11
    assert rec.flush() == []                              # never twice


def test_max_gap_cuts_a_gesture_that_holds_still_in_the_middle():
    """max_gap: a gesture is one motion. The same symbols with a pause of more
    than max_gap frames between two of them are no gesture; with a shorter
    pause, or with no limit (0), they are."""
    first, second = [0] * 3 + [2] * 3, [0] * 3 + [2] * 3
    for pause, max_gap, named in ((12, 10, []), (8, 10, ["up-right"]), (30, 0, ["up-right"])):
        frames = [None] * 4 + first + [None] * pause + second + [None] * 20
        rec = ContinuousRecogniser(MODELS, end_delay=5, max_gap=max_gap)
        assert [d.name for d in _run(rec, frames)] == named, (pause, max_gap)
    # after the pause a whole gesture is named from its own first symbol
    whole = [0] * 3 + [2] * 3 + [0] * 3 + [2] * 3
    frames = first + [None] * 12 + whole + [None] * 20
    named = _run(ContinuousRecogniser(MODELS, end_delay=5, max_gap=10), frames)
    assert [(d.name, d.first) for d in named] == [("up-right", 18)]


def test_max_gap_share_refuses_a_wait_out_of_proportion_at_any_speed():
    """max_gap_share: the longest wait between two symbols of a gesture over
    its span. A gesture made at one symbol a frame with a pause of 4 in the
    middle flows (5 of 15 frames), with a pause of 8 it does not (9 of 19);
    the same shape made four times slower with the pause of 8 flows again
    (12 of 44), which an absolute max_gap of 10 would cut."""
    first, second = [0] * 3 + [2] * 3, [0] * 3 + [2] * 3
    for pause, named in ((4, ["up-right"]), (8, [])):
        frames = [None] * 4 + first + [None] * pause + second + [None] * 20
        rec = ContinuousRecogniser(MODELS, end_delay=5, max_gap_share=0.4)
        assert [d.name for d in _run(rec, frames)] == named, pause
        assert [d.name for d in _run(ContinuousRecogniser(MODELS, end_delay=5), frames)] == \
            ["up-right"]                                     # the option off: no limit

    def slow(symbols):
        return [x for s in symbols for x in (s, None, None, None)]
    frames = [None] * 4 + slow(first) + [None] * 8 + slow(second) + [None] * 30
    for options, named in ((dict(max_gap_share=0.4), [("up-right", 4, 48)]),
                           (dict(max_gap=10), [])):
        rec = ContinuousRecogniser(MODELS, end_delay=5, **options)
        assert [(d.name, d.first, d.last) for d in _run(rec, frames)] == named, options


def test_threshold_model_rows_sum_to_one():
    log_a, log_b = threshold_model(MODELS.models)
    assert log_a.shape == (16, 16) and log_b.shape == (16, 8)
    assert np.allclose(np.exp(log_a).sum(axis=1), 1.0)
    assert np.allclose(np.diag(np.exp(log_a)), [0.8, 0.8, 0.8, 1.0] * 4)


@pytest.mark.parametrize("options, name", [
    (dict(end_delay=0), "end_delay"), (dict(min_symbols=1.5), "min_symbols"),
    (dict(threshold_bias=float("nan")), "threshold_bias"),
    (dict(threshold_bias=True), "threshold_bias"), (dict(max_gap=-1), "max_gap"),
    (dict(max_gap=2.5), "max_gap"), (dict(max_gap_share=1.5), "max_gap_share"),
    (dict(max_gap_share=-0.1), "max_gap_share")])
def test_bad_options_name_the_option(options, name):
    with pytest.raises(ValueError, match=name):
        ContinuousRecogniser(MODELS, **options)
    with pytest.raises(ValueError, match="unknown"):
        check_spotting({"delay": 3})


def test_bad_symbol_and_gaussian_models_are_refused():
    with pytest.raises(ValueError, match="symbol"):
        ContinuousRecogniser(MODELS).step(0, 8)

    class Gaussian:
        emission = "gaussian"
    with pytest.raises(ValueError, match="discrete"):
        ContinuousRecogniser(Gaussian())


def test_distance_symbols_at_equal_travel():
    sym = DistanceSymbols(4)
    # right 1 px per frame: a symbol (0, right) every 4 frames; still: none
    out = [sym.push((x, 10)) for x in range(9)] + [sym.push((8, 10))] * 3
    assert out == [None, None, None, None, 0, None, None, None, 0, None, None, None]
    assert sym.symbols([(0, 0), (0, -5), (5, -5)]).tolist() == [2, 0]   # up, then right
    with pytest.raises(ValueError, match="step"):
        DistanceSymbols(0)


def test_spotting_options_live_in_the_model_file(tmp_path):
    from sw_hps.hmm import load_models, save_models
    models = GestureModels(MODELS.class_names, MODELS.models,
                           spotting={"threshold_bias": -0.5, "end_delay": 6})
    path = tmp_path / "m.json"
    save_models(models, path)
    loaded = load_models(path)
    assert loaded.spotting == {"threshold_bias": -0.5, "end_delay": 6, "min_symbols": 4,
                               "step": 20, "max_gap": 0, "max_gap_share": 0.0}
    rec = ContinuousRecogniser(loaded, **loaded.spotting)
    assert (rec.threshold_bias, rec.end_delay) == (-0.5, 6)


def test_confirm_refuses_a_gesture_and_leaves_its_symbols_to_the_next():
    """``confirm`` is asked with the class and frames a gesture would be named
    with; one it refuses is not named and drops no path, so a gesture that
    began inside its symbols is named in its place."""
    models = GestureModels(("a", "b", "c"), (_chain([0, 2, 0, 2]), _chain([0, 2, 4, 6, 1]),
                                             _chain([1, 3, 5, 7])))
    frames = [s for s in (0, 2, 0, 2, 4, 6, 1) for _ in range(3)] + [None] * 20
    plain = _run(ContinuousRecogniser(models, end_delay=5), frames)
    assert [(d.name, d.first, d.last) for d in plain] == [("a", 0, 11)]
    asked = []

    def refuse_a(class_index, first, last):
        asked.append((class_index, first, last))
        return models.class_names[class_index] != "a"

    named = _run(ContinuousRecogniser(models, end_delay=5, confirm=refuse_a), frames)
    assert asked[0] == (0, 0, 11)
    assert [(d.name, d.first, d.last) for d in named] == [("b", 6, 20)]
    assert asked[-1] == (1, 6, 20)
    # refusing everything names nothing
    assert _run(ContinuousRecogniser(models, end_delay=5, confirm=lambda *_: False),
                frames) == []

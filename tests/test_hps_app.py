"""Tests for the board application sw_hps.app and its CLI (thesis §7.4.1, §8.5)."""
import json
import logging
import re
import signal
import subprocess
import sys
import time

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from sim.gesture_shapes import GESTURE_NAMES, gesture_path
from sw_hps.__main__ import main
from sw_hps.app import HEALTHY_STEPS, GestureApp, GestureClassifier, GestureResult, State
from sw_hps.bus import SimBus
from sw_hps.fifo import CONTROL, DATO_X, FifoPeripheral, to_fixed
from sw_hps.hmm import DiscreteHMM, GestureModels, save_models
from sw_hps.orientation import NO_SYMBOL, orientation_symbols
from sw_hps.robot import NullLink
from sw_hps.telegram import hex_bytes, telegram
from sw_hps.simulated import SimulatedFifoPeripheral, run_on_trajectory, simulate_trajectory

# Direction codes of each shape (sim.gesture_shapes docstring): one left-right state each.
CODES = {"forward": [2, 6], "back": [6, 2], "right": [4, 0], "left": [0, 4],
         "rotate-right": [2, 3, 4, 5, 6, 7, 0, 1, 2], "rotate-left": [2, 1, 0, 7, 6, 5, 4, 3, 2],
         "stop": [3, 0, 5]}


def left_right_model(codes, stay=0.8, hit=0.86):
    """Left-right HMM: state i emits codes[i] with probability ``hit``."""
    n = len(codes)
    a = np.zeros((n, n))
    for i in range(n - 1):
        a[i, i], a[i, i + 1] = stay, 1 - stay
    a[-1, -1] = 1.0
    b = np.full((n, 8), (1 - hit) / 7)
    b[np.arange(n), codes] = hit
    pi = np.zeros(n)
    pi[0] = 1.0
    return DiscreteHMM(pi, a, b)


MODELS = GestureModels(GESTURE_NAMES, [left_right_model(CODES[g]) for g in GESTURE_NAMES])


def gesture_frames(name, points=60, rest=15, amplitude=150.0, centre=(320.0, 240.0)):
    """(x, y, flag) in pixels: rest, the gesture (flagged), rest."""
    path = gesture_path(name, points) * amplitude + centre
    still = np.tile(centre, (rest, 1))
    xy = np.concatenate([still, path, still])
    flag = np.r_[np.zeros(rest), np.ones(points), np.zeros(rest)].astype(bool)
    return xy[:, 0], xy[:, 1], flag


class RecordingLink:
    def __init__(self, result=True):
        self.sent = []
        self.result = result

    def send(self, data):
        self.sent.append(bytes(data))
        if isinstance(self.result, Exception):
            raise self.result
        return self.result

    def close(self):
        pass


def make_app(depth=512, link=None, **options):
    peripheral = SimulatedFifoPeripheral(depth=depth)
    app = GestureApp(MODELS, FifoPeripheral(SimBus(peripheral)), link or RecordingLink(),
                     sleep=lambda s: None, **options)
    return app, peripheral


def push_gesture(peripheral, name, **kwargs):
    x, y, flag = gesture_frames(name, **kwargs)
    for n in range(len(x)):
        peripheral.push_frame(to_fixed(x[n]), to_fixed(y[n]), flag[n])


# ---- recognition end to end on the simulated FIFO ------------------------------------------
@pytest.mark.parametrize("name", GESTURE_NAMES)
def test_recognises_each_gesture_and_sends_its_telegram(name):
    link = RecordingLink()
    x, y, flag = gesture_frames(name)
    run = run_on_trajectory(MODELS, x, y, flag, link=link)
    assert run.recognised == [name]
    assert link.sent == [telegram(name)] == run.telegrams
    result = run.results[0]
    assert result.recognised and result.sent and result.num_points == flag.sum()
    # The streamed symbols and scores equal the offline computation on the raw values.
    raw = np.array([[to_fixed(a), to_fixed(b)] for a, b in zip(x[flag], y[flag])])
    symbols = orientation_symbols(raw)
    symbols = symbols[symbols != NO_SYMBOL]
    assert list(result.symbols) == symbols.tolist()
    assert np.allclose(result.scores, MODELS.scores(symbols))
    assert run.peripheral.go and run.app.state is State.WAIT


def test_sequence_of_gestures_with_slow_polling():
    names = ["stop", "left", "rotate-right", "back"]
    parts = [gesture_frames(n, points=50 + 7 * i) for i, n in enumerate(names)]
    x, y, flag = (np.concatenate([p[k] for p in parts]) for k in range(3))
    for reads_per_frame in (1, 4):
        run = run_on_trajectory(MODELS, x, y, flag, reads_per_frame=reads_per_frame)
        assert run.recognised == names
        assert list(run.link.sent) == [telegram(n) for n in names]


def test_batch_reading_when_the_arm_is_late():
    app, peripheral = make_app()
    app.run(max_iterations=2)                          # S0, then S1 idle
    peripheral.write32(CONTROL, 1)
    push_gesture(peripheral, "rotate-left")            # whole gesture queued before a poll
    results = app.run(max_iterations=10)
    assert [r.class_name for r in results] == ["rotate-left"]
    assert app.link.sent == [telegram("rotate-left")]


def test_on_result_hook_and_unknown_class_names():
    names = ("up", "down")
    models = GestureModels(names, [left_right_model([2]), left_right_model([6])])
    seen = []
    x, y, flag = gesture_frames("forward")
    run = run_on_trajectory(models, x, y, flag, on_result=seen.append)
    assert [r.class_name for r in seen] == ["up"] == run.recognised
    assert seen[0].telegram is None and not seen[0].sent and list(run.link.sent) == []


# ---- rejections ------------------------------------------------------------------------------
def test_short_gesture_is_rejected():
    x, y, flag = gesture_frames("left", points=4)
    run = run_on_trajectory(MODELS, x, y, flag, min_symbols=5)
    assert run.recognised == [] and not run.link.sent
    (result,) = run.results
    assert result.outcome == "rejected" and "too short" in result.reason


def test_zero_probability_gesture_is_rejected(caplog):
    caplog.set_level(logging.INFO, logger="sw_hps")
    only_right = np.zeros((1, 8))
    only_right[0, 0] = 1.0
    models = GestureModels(("forward", "back"), [DiscreteHMM([1.0], [[1.0]], only_right)] * 2)
    x, y, flag = gesture_frames("forward")
    run = run_on_trajectory(models, x, y, flag)
    (result,) = run.results
    assert result.outcome == "rejected" and "probability 0" in result.reason
    assert "rejected" in caplog.text


def test_discrete_models_with_thresholds_refuse_below_them():
    x, y, flag = gesture_frames("left")
    plain = run_on_trajectory(MODELS, x, y, flag).results[0]
    per_step = plain.scores[GESTURE_NAMES.index("left")] / plain.num_symbols
    accepting = MODELS.with_thresholds([per_step - 1e-6] * len(GESTURE_NAMES))
    assert run_on_trajectory(accepting, x, y, flag).recognised == ["left"]
    refusing = MODELS.with_thresholds([per_step + 1e-6] * len(GESTURE_NAMES))
    link = RecordingLink()
    run = run_on_trajectory(refusing, x, y, flag, link=link)
    (result,) = run.results
    assert result.outcome == "rejected" and "'left'" in result.reason
    assert result.scores == plain.scores and link.sent == []


# ---- gaussian models with rejection ----------------------------------------------------------
GAUSSIAN_CLASSES = ("forward", "left", "rotate-right", "stop")


@pytest.fixture(scope="module")
def gaussian_models():
    """Gaussian models of four gestures drawn by three synthetic people (aspect,
    time warp, size, jitter), rejection calibrated on held-out people."""
    from recognition.recogniser import Recogniser
    from sim.gesture_shapes import random_time_warp
    from sw_hps.stroke import stroke_features
    rng = np.random.RandomState(0)   # legacy stream: same draws on the board's numpy 1.16
    feats, labels, people = [], [], []
    for name in GAUSSIAN_CLASSES:
        for i in range(6):
            n = int(rng.randint(40, 80))
            path = gesture_path(name, n, aspect=float(rng.uniform(0.8, 1.25)),
                                time_warp=random_time_warp(n, rng))
            path = path * rng.uniform(100, 160) + rng.normal(0, 0.5, (n, 2))
            feats.append(stroke_features(path, 20))
            labels.append(name)
            people.append(i % 3)
    recogniser = Recogniser(resample=20, states=5, components=1)
    models = recogniser.fit(feats, labels, GAUSSIAN_CLASSES, groups=people)
    assert models.emission == "gaussian" and len(models.thresholds) == 4
    return models


def random_walk_frames(seed, points=30, rest=15):
    """A flagged hand movement that is no gesture, inside the frame."""
    rng = np.random.RandomState(seed)
    walk = np.clip(np.cumsum(rng.normal(0, 6, (points, 2)), axis=0) + (320, 240), 20, 400)
    xy = np.concatenate([np.tile(walk[:1], (rest, 1)), walk, np.tile(walk[-1:], (rest, 1))])
    flag = np.r_[np.zeros(rest), np.ones(points), np.zeros(rest)].astype(bool)
    return xy[:, 0], xy[:, 1], flag


@pytest.mark.parametrize("name", GAUSSIAN_CLASSES)
def test_gaussian_models_recognise_a_gesture_and_send_its_telegram(gaussian_models, name):
    link = RecordingLink()
    x, y, flag = gesture_frames(name)
    run = run_on_trajectory(gaussian_models, x, y, flag, link=link)
    assert run.recognised == [name]
    assert link.sent == [telegram(name)] == run.telegrams
    (result,) = run.results
    assert result.recognised and result.sent and result.reason is None
    assert result.num_points == flag.sum()
    # Scored once at the gesture's end on the buffered raw points: the offline scores.
    raw = np.array([[to_fixed(a), to_fixed(b)] for a, b in zip(x[flag], y[flag])])
    assert np.allclose(result.scores, gaussian_models.scores_of_points(raw), rtol=1e-12)
    symbols = orientation_symbols(raw)
    assert list(result.symbols) == symbols[symbols != NO_SYMBOL].tolist()
    assert run.app.state is State.WAIT


def test_gaussian_models_refuse_a_non_gesture_and_send_nothing(gaussian_models, caplog):
    caplog.set_level(logging.INFO, logger="sw_hps")
    link = RecordingLink()
    x, y, flag = random_walk_frames(3)
    run = run_on_trajectory(gaussian_models, x, y, flag, link=link)
    (result,) = run.results
    assert result.outcome == "rejected" and result.class_index == -1
    assert result.class_name is None and result.telegram is None and not result.sent
    best = GAUSSIAN_CLASSES[int(np.argmax(result.scores))]
    assert "not a gesture" in result.reason and repr(best) in result.reason
    assert "threshold" in result.reason and result.reason in caplog.text
    assert link.sent == [] and run.telegrams == [] and run.recognised == []
    assert result.num_symbols >= 5                # refused for its shape, not for being short


def test_gaussian_models_in_a_sequence_with_non_gestures(gaussian_models):
    parts = [gesture_frames("stop"), random_walk_frames(4), gesture_frames("rotate-right"),
             gesture_frames("rotate-left")]         # rotate-left is not in the vocabulary
    x, y, flag = (np.concatenate([p[k] for p in parts]) for k in range(3))
    link = RecordingLink()
    run = run_on_trajectory(gaussian_models, x, y, flag, link=link, reads_per_frame=2)
    assert [r.outcome for r in run.results] == ["recognised", "rejected", "recognised",
                                                "rejected"]
    assert run.recognised == ["stop", "rotate-right"]
    assert link.sent == [telegram("stop"), telegram("rotate-right")]


def test_gaussian_classifier_buffers_the_points(gaussian_models):
    classifier = GestureClassifier(gaussian_models, min_symbols=1)
    assert not classifier.streaming
    assert classifier.decide()[0] == -1                       # nothing yet: too short
    x, y, flag = gesture_frames("left")
    raw = np.array([[to_fixed(a), to_fixed(b)] for a, b in zip(x[flag], y[flag])])
    for chunk in np.array_split(raw, 7):
        classifier.add_points(chunk)
    assert classifier.num_points == len(raw)
    assert np.array_equal(classifier.scores(), gaussian_models.scores_of_points(raw))
    assert classifier.decide() == (GAUSSIAN_CLASSES.index("left"), None)
    classifier.reset()
    classifier.add_points(np.repeat(raw[:1], 10, axis=0))     # points, but no motion
    assert classifier.num_symbols == 0 and classifier.num_points == 10
    assert np.isneginf(classifier.scores()).all()
    index, reason = classifier.decide()
    assert index == -1 and "too short" in reason


# ---- faults ------------------------------------------------------------------------------------
def test_fifo_full_drops_the_gesture_and_clears():
    app, peripheral = make_app(depth=20)
    app.run(max_iterations=2)
    push_gesture(peripheral, "left", rest=0)           # 60 pairs into a 20-deep FIFO, not read
    assert peripheral.full
    clears = peripheral.clears
    results = app.run(max_iterations=5)
    assert [r.outcome for r in results] == ["dropped"] and "FIFO-FULL" in results[0].reason
    assert not peripheral.full and not peripheral.fifo_x and peripheral.clears > clears
    assert not app.link.sent
    # The next gesture goes through (polled every frame).
    x, y, flag = gesture_frames("back", points=18)
    peripheral.queue_trajectory(x, y, flag, pixels=True)
    peripheral.reads_per_frame = 1
    later = app.run(max_iterations=500, until=lambda: peripheral.frames_pending == 0
                    and app.state is State.WAIT and not peripheral.fifo_x)
    assert [r.class_name for r in later] == ["back"]


def test_too_long_gesture_is_dropped_and_its_tail_ignored():
    x, y, flag = gesture_frames("rotate-left", points=80)
    x2, y2, flag2 = gesture_frames("forward", points=30)
    run = run_on_trajectory(MODELS, np.r_[x, x2], np.r_[y, y2], np.r_[flag, flag2],
                            max_points=40)
    assert [r.outcome for r in run.results] == ["dropped", "recognised"]
    assert "max_points=40" in run.results[0].reason
    assert run.recognised == ["forward"]


def test_gesture_in_progress_at_start_is_ignored():
    x, y, flag = gesture_frames("left", rest=0)
    x2, y2, flag2 = gesture_frames("right")
    start = 20                                         # the app starts mid-gesture
    run = run_on_trajectory(MODELS, np.r_[x[start:], x2], np.r_[y[start:], y2],
                            np.r_[flag[start:], flag2])
    assert run.recognised == ["right"] and len(run.results) == 1


class FlakyBus:
    """A SimBus that raises on chosen reads."""

    def __init__(self, inner, fail_reads):
        self.inner = inner
        self.fail_reads = set(fail_reads)
        self.reads = 0

    def read32(self, offset):
        self.reads += 1
        if self.reads in self.fail_reads:
            raise OSError(5, "bridge timeout")
        return self.inner.read32(offset)

    def write32(self, offset, value):
        self.inner.write32(offset, value)

    def close(self):
        pass


def test_bus_errors_are_logged_and_the_loop_recovers_with_backoff(caplog):
    peripheral = SimulatedFifoPeripheral(reads_per_frame=1)
    parts = [gesture_frames(n) for n in ("left", "stop", "back")]
    peripheral.queue_trajectory(*(np.concatenate([p[k] for p in parts]) for k in range(3)),
                                pixels=True)
    sleeps = []
    bus = FlakyBus(SimBus(peripheral), fail_reads={60, 61, 62, 63})
    app = GestureApp(MODELS, FifoPeripheral(bus), RecordingLink(), sleep=sleeps.append,
                     poll_interval=0.0, initial_backoff=0.05, max_backoff=0.15)
    results = app.run(max_iterations=5000, until=lambda: peripheral.frames_pending == 0
                      and app.state is State.WAIT and not peripheral.fifo_x)
    assert app.errors == 4 and "bridge timeout" in caplog.text
    delays = re.findall(r"re-initialising in ([0-9.]+) s", caplog.text)
    # Doubling, capped; the same error again at the cap is not logged again.
    assert delays == ["0.05", "0.10", "0.15"]
    assert sum(sleeps) == pytest.approx(0.45)
    # The gesture hit by the errors is dropped; the later ones are recognised.
    assert [r.outcome for r in results] == ["dropped", "recognised", "recognised"]
    assert [r.class_name for r in results[1:]] == ["stop", "back"]


class DatoFailsBus(FlakyBus):
    """Status reads work, every pop fails while ``broken``."""

    def __init__(self, inner):
        super().__init__(inner, ())
        self.broken = True

    def read32(self, offset):
        if self.broken and offset == DATO_X:
            raise OSError(5, "pop failed")
        return self.inner.read32(offset)


def test_persistent_fault_backs_off_to_the_cap_then_resets_when_healthy(caplog):
    peripheral = SimulatedFifoPeripheral()
    bus = DatoFailsBus(SimBus(peripheral))
    app = GestureApp(MODELS, FifoPeripheral(bus), NullLink(), sleep=lambda s: None,
                     initial_backoff=0.05, max_backoff=0.2)
    peripheral.write32(CONTROL, 1)
    for _ in range(30):                                # data always waiting
        if not peripheral.fifo_x:
            peripheral.fifo_x.append(5), peripheral.fifo_y.append(5)
        app.run(max_iterations=1)
    delays = re.findall(r"re-initialising in ([0-9.]+) s", caplog.text)
    assert delays == ["0.05", "0.10", "0.20"]         # repeats at the cap are left out
    assert app.errors >= 10
    bus.broken = False
    app.run(max_iterations=HEALTHY_STEPS)
    assert app.backoff == 0.05


def test_link_failures_do_not_stop_the_loop():
    for result in (False, RuntimeError("link exploded")):
        link = RecordingLink(result)
        x, y, flag = gesture_frames("left")
        run = run_on_trajectory(MODELS, np.r_[x, x], np.r_[y, y], np.r_[flag, flag], link=link)
        assert run.recognised == ["left", "left"] and run.telegrams == []
        assert link.sent == [telegram("left")] * 2
        assert all(not r.sent and r.telegram == telegram("left") for r in run.results)
        assert all(r.delivery == "failed" for r in run.results)


def test_hook_errors_are_logged_and_stop_request_ends_run(caplog):
    app, peripheral = make_app()

    def hook(result):
        app.request_stop()
        raise ValueError("bad hook")
    app.on_result = hook
    peripheral.queue_trajectory(*gesture_frames("right"), pixels=True)
    peripheral.queue_trajectory(*gesture_frames("left"), pixels=True)
    peripheral.reads_per_frame = 1
    results = app.run(max_iterations=10_000)
    assert [r.class_name for r in results] == ["right"]   # stopped after the first
    assert "bad hook" in caplog.text and peripheral.frames_pending > 0


def test_keyboard_interrupt_ends_run_cleanly():
    def sleep(seconds):
        raise KeyboardInterrupt
    app = GestureApp(MODELS, FifoPeripheral(SimBus(SimulatedFifoPeripheral())), sleep=sleep)
    assert app.run(max_iterations=100) == []


def test_shutdown_clears_go():
    app, peripheral = make_app()
    app.run(max_iterations=1)
    assert peripheral.go
    app.shutdown()
    assert not peripheral.go


def test_constructor_validation():
    fifo = FifoPeripheral(SimBus(SimulatedFifoPeripheral()))
    for kwargs, name in [({"max_points": 0}, "max_points"), ({"min_symbols": 0}, "min_symbols"),
                         ({"poll_interval": -1}, "poll_interval"),
                         ({"initial_backoff": 0}, "initial_backoff")]:
        with pytest.raises(ValueError, match=name):
            GestureApp(MODELS, fifo, **kwargs)
    six = GestureModels(("a",), [DiscreteHMM([1.0], [[1.0]], [[1 / 6] * 6])])
    with pytest.raises(ValueError, match="num_symbols"):
        GestureApp(six, fifo)


def test_result_to_dict_is_json():
    result = GestureResult("recognised", 0, "forward", (-1.0, float("-inf")), 10, 9,
                           telegram=telegram(0), sent=True)
    data = json.loads(json.dumps(result.to_dict()))
    assert data["scores"] == [-1.0, None] and data["telegram"] == "06 00 80 09 00 02 31 00"


# ---- property tests ------------------------------------------------------------------------------
class RandomBus:
    """Any 32-bit words, and sometimes an exception, whatever the offset."""

    def __init__(self, words, failures):
        self.words = words or [0]
        self.failures = failures
        self.count = 0

    def read32(self, offset):
        self.count += 1
        if self.failures and self.count % self.failures == 0:
            raise OSError(5, "random bus fault")
        return self.words[self.count % len(self.words)]

    def write32(self, offset, value):
        assert 0 <= value <= 0xFFFFFFFF

    def close(self):
        pass


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(words=st.lists(st.integers(0, 2 ** 32 - 1), min_size=1, max_size=40),
       failures=st.integers(0, 7))
def test_random_register_values_never_crash_the_loop(words, failures):
    app = GestureApp(MODELS, FifoPeripheral(RandomBus(words, failures)), NullLink(),
                     sleep=lambda s: None, max_pairs_per_poll=64, max_points=100)
    results = app.run(max_iterations=150)
    assert all(r.outcome in ("recognised", "rejected", "dropped") for r in results)
    assert app.state in State


@settings(max_examples=100, deadline=None)
@given(symbols=st.lists(st.integers(0, 7), max_size=120), min_symbols=st.integers(1, 10))
def test_random_symbol_streams_give_a_class_or_a_rejection(symbols, min_symbols):
    sparse = GestureModels(GESTURE_NAMES, [left_right_model(CODES[g], hit=1.0)
                                           for g in GESTURE_NAMES])
    for models in (MODELS, sparse):
        classifier = GestureClassifier(models, min_symbols)
        for symbol in symbols:
            classifier.feed_symbol(symbol)
        index, reason = classifier.decide()
        if index >= 0:
            assert index < len(GESTURE_NAMES) and reason is None
            assert len(symbols) >= min_symbols
            assert index == int(np.argmax(models.scores(symbols)))
        else:
            assert isinstance(reason, str) and reason


@settings(max_examples=60, deadline=None)
@given(points=st.lists(st.tuples(st.integers(0, 2 ** 18 - 1), st.integers(0, 2 ** 18 - 1)),
                       max_size=50),
       split=st.integers(0, 50))
def test_points_in_any_batches_give_the_offline_symbols(points, split):
    classifier = GestureClassifier(MODELS, 1)
    classifier.add_points(points[:split])
    classifier.add_points(points[split:])
    expected = orientation_symbols(np.array(points)).tolist() if len(points) > 1 else []
    assert classifier.symbols == [s for s in expected if s != NO_SYMBOL]
    assert classifier.num_points == len(points)


@settings(max_examples=60, deadline=None)
@given(actions=st.lists(st.one_of(
    st.tuples(st.just("frames"), st.lists(st.tuples(st.integers(0, 2 ** 18 - 1),
                                                    st.integers(0, 2 ** 18 - 1), st.booleans()),
                                          max_size=30)),
    st.tuples(st.just("run"), st.integers(1, 12))), max_size=12),
    depth=st.integers(1, 16))
def test_random_fifo_full_and_garbage_sequences(actions, depth):
    app, peripheral = make_app(depth=depth, max_points=50)
    app.run(max_iterations=1)
    for kind, value in actions:
        if kind == "frames":
            for x, y, flag in value:
                peripheral.push_frame(x, y, flag)
        else:
            for result in app.run(max_iterations=value):
                assert result.outcome in ("recognised", "rejected", "dropped")
                if result.outcome == "dropped":
                    assert ("FIFO-FULL" in result.reason or "max_points" in result.reason
                            or "outside the frame" in result.reason)  # 18-bit x, y: 0..1024 px
    # Once the hand rests, the application drains everything and waits.
    peripheral.push_frame(0, 0, False)
    app.run(max_iterations=20)
    assert app.state is State.WAIT and not peripheral.full and not peripheral.fifo_x
    assert peripheral.go


# ---- command line -------------------------------------------------------------------------------
@pytest.fixture
def model_file(tmp_path):
    path = tmp_path / "models.json"
    save_models(MODELS, path)
    return path


@pytest.fixture
def trajectory_file(tmp_path):
    parts = [gesture_frames(n) for n in ("rotate-right", "stop")]
    x, y, flag = (np.concatenate([p[k] for p in parts]) for k in range(3))
    lines = ["frame,x,y,flag,symbol"] + [f"{n},{x[n]:.4f},{y[n]:.4f},{int(flag[n])},-1"
                                         for n in range(len(x))]
    path = tmp_path / "trajectory.csv"
    path.write_text("\n".join(lines) + "\n")
    return path


@pytest.mark.parametrize("robot", ["none", "uart"])
def test_cli_sim_plays_a_trajectory(model_file, trajectory_file, robot, capsys):
    code = main(["--model", str(model_file), "--bus", "sim", "--robot", robot,
                 "--sim-trajectory", str(trajectory_file), "--poll-ms", "0.01",
                 "--log-level", "warning"])
    assert code == 0
    gestures = json.loads(capsys.readouterr().out.strip().splitlines()[-1])["gestures"]
    assert [g["class_name"] for g in gestures] == ["rotate-right", "stop"]
    assert gestures[1]["telegram"] == hex_bytes(telegram("stop")) and gestures[1]["sent"]
    assert gestures[1]["delivery"] == "unconfirmed"       # nothing can tell more


@pytest.mark.parametrize("extra", [[], ["--rn42-address", "00:16:53:0A:0B:0C"]])
def test_cli_sim_robot_ack_over_the_uart(model_file, trajectory_file, extra, capsys, caplog):
    """--robot uart --robot-ack: the simulated RN-42 and brick confirm each telegram
    (sent with the reply flag); with --rn42-address the module is set up first."""
    caplog.set_level(logging.INFO)
    code = main(["--model", str(model_file), "--bus", "sim", "--robot", "uart", "--robot-ack",
                 "--sim-trajectory", str(trajectory_file), "--poll-ms", "0.01"] + extra)
    assert code == 0
    gestures = json.loads(capsys.readouterr().out.strip().splitlines()[-1])["gestures"]
    assert [g["delivery"] for g in gestures] == ["acknowledged", "acknowledged"]
    assert gestures[1]["telegram"] == hex_bytes(telegram("stop", reply=True))
    assert "for 'stop' sent, acknowledged by the NXT" in caplog.text
    assert "deliveries unconfirmed" not in caplog.text
    assert ("RN-42: master mode, connecting to 0016530A0B0C" in caplog.text) == bool(extra)


def test_cli_uart_without_ack_says_deliveries_are_unconfirmed(model_file, trajectory_file,
                                                               capsys, caplog):
    caplog.set_level(logging.INFO)
    assert main(["--model", str(model_file), "--bus", "sim", "--robot", "uart",
                 "--sim-trajectory", str(trajectory_file), "--poll-ms", "0.01"]) == 0
    assert caplog.text.count("UART link: deliveries unconfirmed; --robot-ack asks the NXT to "
                             "confirm") == 1
    assert "for 'stop' written, unconfirmed (no --robot-ack)" in caplog.text
    assert " sent, " not in caplog.text


@pytest.mark.parametrize("args,match", [
    ([], "--model"),
    (["--bus", "pci"], "--bus"),
    (["--robot", "wifi"], "--robot"),
    (["--robot", "serial:"], "--robot"),
    (["--bridge-offset", "0x3"], "--bridge-offset"),
    (["--bridge-offset", "zz"], "--bridge-offset"),
    (["--uart-offset", "0x8"], "--uart-offset"),
    (["--poll-ms", "0"], "--poll-ms"),
    (["--log-level", "loud"], "--log-level"),
    (["--bus", "devmem", "--sim-trajectory", "t.csv"], "--sim-trajectory"),
    (["--rn42-address", "0016530A0B0C"], "--rn42-address"),
    (["--robot-ack", "9"], "--robot-ack: must be in [0.05, 5] seconds, got 9"),
    (["--robot-ack", "nan"], "--robot-ack"),
    (["--robot-ack", "soon"], "--robot-ack"),
    (["--robot", "serial:/dev/null", "--rn42-address", "xyz"], "address"),
    (["--robot", "serial:/dev/null", "--baudrate", "1234"], "--baudrate"),
    (["--min-symbols", "0"], "--min-symbols"),
])
def test_cli_argument_errors(model_file, args, match, capsys):
    base = {"--model": str(model_file), "--bus": "sim", "--robot": "none"}
    argv = [] if args == [] else [t for k, v in base.items() for t in (k, v)]
    code = main(argv + args)
    err = capsys.readouterr().err
    assert code == 2
    assert err.count("\n") == 1 and err.startswith("python -m sw_hps: error:") and match in err


def test_cli_bad_model_and_trajectory_files(tmp_path, model_file, capsys):
    bad = tmp_path / "bad.json"
    bad.write_text("{}")
    assert main(["--model", str(bad), "--bus", "sim", "--robot", "none"]) == 2
    assert "bad.json" in capsys.readouterr().err
    assert main(["--model", str(model_file), "--bus", "sim", "--robot", "none",
                 "--sim-trajectory", str(tmp_path / "none.csv")]) == 2
    assert "none.csv" in capsys.readouterr().err


def test_cli_unopenable_bus_is_one_line(tmp_path, model_file, capsys):
    code = main(["--model", str(model_file), "--bus", "uio", "--uio", str(tmp_path / "uio9"),
                 "--robot", "none"])
    err = capsys.readouterr().err
    assert code == 1 and "uio9" in err and "Traceback" not in err


def test_cli_help(capsys):
    assert main(["--help"]) == 0
    assert "--sim-trajectory" in capsys.readouterr().out


@pytest.mark.parametrize("signum", [signal.SIGTERM, signal.SIGINT])
def test_cli_signals_exit_cleanly(model_file, signum):
    process = subprocess.Popen([sys.executable, "-m", "sw_hps", "--model", str(model_file),
                                "--bus", "sim", "--robot", "none"],
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 20
        line = ""
        while "running" not in line and time.monotonic() < deadline:
            line = process.stderr.readline()
        assert "running" in line
        process.send_signal(signum)
        out, err = process.communicate(timeout=10)
    finally:
        if process.poll() is None:
            process.kill()
    assert process.returncode == 0, err
    assert "Traceback" not in err and "stopping" in err


def test_simulate_trajectory_builds_without_running():
    run = simulate_trajectory(MODELS, *gesture_frames("back"))
    assert run.results == [] and run.app.state is State.INIT
    assert run.run().recognised == ["back"] and run.finished()


def test_thesis_mode_names_the_posture_held_over_each_gesture():
    """With a posture tracker the thesis loop polls the posture slave at every
    step; each gesture names the posture held over the records from the poll
    that saw it start to the one that saw it end (records counted by SEQ)."""
    from soc.hps_interface import POSTURE_WORD_COUNT, posture_word_offsets
    from sw_hps.posture import POSTURE_OFFSET, PostureReader, PostureTracker
    from sw_hps.simulated import SimulatedPostureSlave

    at = posture_word_offsets()
    slave = SimulatedPostureSlave()

    def record(posture):            # the fake model reads the posture from a polar word
        words = [0] * POSTURE_WORD_COUNT
        words[at["reference_width"]], words[at["polar"]] = 10, posture
        return words

    class Model:
        def classify(self, features):
            return {1: "fist", 2: "asl1"}.get(int(features[0] * 100))

    class Fifo(SimulatedFifoPeripheral):      # a posture record with every video frame
        def push_frame(self, x_fixed, y_fixed, flag, present=True):
            super().push_frame(x_fixed, y_fixed, flag, present)
            # "asl1" in the first 20 flagged frames of the second gesture, else "fist"
            slave.push_record(record(2 if flag and self.frames > 110 and
                                     self.frames <= 130 else 1))

    x1, y1, f1 = gesture_frames("back")
    x2, y2, f2 = gesture_frames("left")
    peripheral = Fifo(reads_per_frame=1)
    peripheral.queue_trajectory(np.r_[x1, x2], np.r_[y1, y2], np.r_[f1, f2], pixels=True)
    bus = SimBus(peripheral)
    bus.attach(POSTURE_OFFSET, slave)
    tracker = PostureTracker(PostureReader(bus), Model())
    from sw_hps.simulated import SimulatedClock, SimulationRun
    clock, link = SimulatedClock(), NullLink()
    app = GestureApp(MODELS, FifoPeripheral(bus), link, sleep=clock.sleep, clock=clock,
                     posture=tracker)
    results = SimulationRun(app, peripheral, link, 10_000).run().results
    assert [r.class_name for r in results] == ["back", "left"]
    assert results[0].posture == "fist" and results[0].posture_share >= 0.9
    # 20 of the second gesture's 60 frames in asl1: fist holds, with about 2/3
    assert results[1].posture == "fist" and 0.6 <= results[1].posture_share <= 0.72
    assert results[1].to_dict()["posture"] == "fist"
    # every record but the ones after the last poll was read, numbered from the first
    assert slave.records - 3 <= tracker.reader.frame == tracker.reader.records - 1
    assert tracker.errors == 0
    # without a tracker nothing changes and no posture is named
    plain = run_on_trajectory(MODELS, x1, y1, f1).results
    assert [(r.class_name, r.posture) for r in plain] == [("back", None)]


def test_cli_sends_the_command_a_class_maps_to_and_refuses_an_unmapped_class(
        tmp_path, trajectory_file, capsys):
    """A model whose classes are named otherwise (a user's own gestures): with
    ``commands`` each sends its robot command's telegram; a class that maps to
    none is refused at start, in one line."""
    import dataclasses
    names = tuple("spin" if n == "rotate-right" else n for n in MODELS.class_names)
    renamed = dataclasses.replace(MODELS, class_names=names, meta={})
    bad = tmp_path / "unmapped.json"
    save_models(renamed, bad)
    assert main(["--model", str(bad), "--bus", "sim", "--robot", "none",
                 "--sim-trajectory", str(trajectory_file)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "'spin' maps to no robot command" in err[0] and \
        "--commands" in err[0], err
    good = tmp_path / "mapped.json"
    save_models(dataclasses.replace(renamed, commands={"spin": "rotate-right"}, meta={}), good)
    assert main(["--model", str(good), "--bus", "sim", "--robot", "uart",
                 "--sim-trajectory", str(trajectory_file), "--poll-ms", "0.01",
                 "--log-level", "warning"]) == 0
    gestures = json.loads(capsys.readouterr().out.strip().splitlines()[-1])["gestures"]
    assert [g["class_name"] for g in gestures] == ["spin", "stop"]
    assert gestures[0]["telegram"] == hex_bytes(telegram("rotate-right"))

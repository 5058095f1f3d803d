"""Register faults of the board application (sw_hps.app, module docstring "Faults"):
a stuck gesture bit, points outside the frame, unequal FIFO lengths, and the
heartbeat; deterministic cases and property tests over arbitrary register values.

Everything runs in simulated time (:class:`sw_hps.simulated.SimulatedClock`); log records
are stamped with it by :func:`stamped` so the tests can check when a line appeared.
"""
import contextlib
import inspect
import logging
import math
from collections import Counter

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from sw_hps.__main__ import main, parse_args
from sw_hps.app import DEFAULT_GESTURE_TIMEOUT, DEFAULT_HEARTBEAT, GestureApp, State
from sw_hps.bus import SimBus
from soc.hps_interface import CORE_MAGIC, ID
from sw_hps.fifo import (CONTROL, CTRL_FIFO_DATA, CTRL_FIFO_FULL, CTRL_GO, CTRL_NO_GESTURE,
                         DATA_MASK, DATO_X, DATO_Y, FIFO_DEPTH, FRAC_BITS, FRAME_HEIGHT,
                         FRAME_WIDTH, LONGITUD_X, LONGITUD_Y, FifoPeripheral, to_fixed)
from sw_hps.hmm import save_models
from sw_hps.orientation import NO_SYMBOL, orientation_symbols
from sw_hps.telegram import GESTURE_NAMES, telegram
from sw_hps.simulated import SimulatedClock, SimulatedFifoPeripheral, run_on_trajectory
from tests.test_hps_app import MODELS, RecordingLink, gesture_frames

#: Poll interval of the applications under test (simulated seconds).
POLL = 0.01
OUTCOMES = ("recognised", "rejected", "dropped")


def make_app(wrap=None, **options):
    """Application on a simulated FIFO (optionally behind a bus wrapper) in simulated
    time; returns (app, peripheral, clock, link, bus)."""
    clock = SimulatedClock()
    peripheral = SimulatedFifoPeripheral()
    bus = SimBus(peripheral)
    if wrap is not None:
        bus = wrap(bus, peripheral)
    link = RecordingLink()
    app = GestureApp(MODELS, FifoPeripheral(bus), link, sleep=clock.sleep, clock=clock,
                     poll_interval=POLL, **options)
    return app, peripheral, clock, link, bus


@contextlib.contextmanager
def stamped(caplog, clock):
    """While active, every captured record gets ``sim_time`` (the simulated clock)."""
    def stamp(record):
        record.sim_time = clock()
        return True
    caplog.handler.addFilter(stamp)
    try:
        yield
    finally:
        caplog.handler.removeFilter(stamp)


def records(caplog, text="", level=logging.INFO):
    return [r for r in caplog.records if r.levelno >= level and text in r.getMessage()]


def warnings(caplog, text=""):
    return records(caplog, text, logging.WARNING)


def run_for(app, clock, seconds):
    end = clock() + seconds
    return app.run(max_iterations=int(seconds / POLL) * 3 + 100, until=lambda: clock() >= end)


def run_until_played(app, peripheral, bound=5000):
    """Play the queued frames (one per poll) until the application waits again."""
    peripheral.reads_per_frame = 1
    return app.run(max_iterations=bound, until=lambda: peripheral.frames_pending == 0
                   and app.state is State.WAIT and not peripheral.fifo_x)


def push_flagged(peripheral, x, y, frames):
    for n in frames:
        peripheral.push_frame(to_fixed(x[n]), to_fixed(y[n]), True)


def symbols_of(raw):
    raw = np.asarray(raw, dtype=np.int64).reshape(-1, 2)
    if len(raw) < 2:
        return []
    symbols = orientation_symbols(raw)
    return symbols[symbols != NO_SYMBOL].tolist()


@pytest.fixture(autouse=True)
def info_logs(caplog):
    caplog.set_level(logging.INFO, logger="sw_hps")


# ---- stuck gesture bit -------------------------------------------------------------------------
def test_stuck_gesture_bit_in_s2_is_dropped_within_the_timeout_then_forgotten(caplog):
    app, peripheral, clock, link, _ = make_app(gesture_timeout=2.0, heartbeat=10.0)
    app.run(max_iterations=2)                               # S0, S1
    x, y, _ = gesture_frames("left", rest=0)
    push_flagged(peripheral, x, y, range(10))               # ten frames of a gesture, then the
    with stamped(caplog, clock):                            # flag stays set but no pair comes
        start = clock()
        (result,) = app.run(max_iterations=10_000, until=lambda: len(app.results) > 0)
        assert result.outcome == "dropped" and result.telegram is None and not link.sent
        assert "stuck" in result.reason and "gesture_timeout=2 s" in result.reason
        assert result.num_points == 10
        (warning,) = warnings(caplog)
        assert "gesture dropped: gesture bit stuck at 0" in warning.getMessage()
        assert 2.0 < warning.sim_time - start <= 2.0 + 2 * POLL
        assert app.discarding and app.state is State.WAIT and not peripheral.fifo_x
        # Still stuck for 35 s: one reminder per heartbeat, not one per poll.
        caplog.clear()
        run_for(app, clock, 35.0)
        reminders = warnings(caplog)
        assert [round(r.sim_time - warning.sim_time) for r in reminders] == [10, 20, 30]
        assert all("gesture bit still 0" in r.getMessage() and "stuck: no FIFO data" in
                   r.getMessage() for r in reminders)
        assert list(app.results) == [result] and app.faults == 1
    # The bit reads 1 again: back to normal, and the next gesture is recognised.
    caplog.clear()
    peripheral.flag = False
    app.run(max_iterations=1)
    assert not app.discarding and records(caplog, "reads 1 again")
    peripheral.queue_trajectory(*gesture_frames("back"), pixels=True)
    assert [r.class_name for r in run_until_played(app, peripheral)] == ["back"]
    assert link.sent == [telegram("back")] and not warnings(caplog)


def test_stuck_gesture_bit_at_start_up_is_reported_then_reminded(caplog):
    app, peripheral, clock, link, _ = make_app(gesture_timeout=2.0, heartbeat=10.0)
    peripheral.flag = True                  # the gesture bit reads 0 as soon as S0 sets GO
    with stamped(caplog, clock):
        run_for(app, clock, 25.0)
    assert records(caplog, "ignoring the gesture in progress")       # S0 says so at once
    first, *reminders = warnings(caplog)
    assert "stuck at 0" in first.getMessage() and "gesture_timeout=2 s" in first.getMessage()
    assert 2.0 < first.sim_time <= 2.0 + 2 * POLL
    assert [round(r.sim_time) for r in reminders] == [12, 22]
    assert not app.results and app.faults == 1              # never a gesture
    peripheral.flag = False
    app.run(max_iterations=1)
    assert not app.discarding and records(caplog, "back to normal")


def test_a_discarded_gesture_that_goes_on_is_reminded_not_called_stuck(caplog):
    app, peripheral, clock, link, _ = make_app(max_points=20, heartbeat=5.0)
    x, y, flag = gesture_frames("rotate-left", points=2000, rest=5)   # 20 s of flagged frames
    peripheral.queue_trajectory(x, y, flag, pixels=True)
    with stamped(caplog, clock):
        results = run_until_played(app, peripheral, bound=10_000)
    assert [r.outcome for r in results] == ["dropped"] and "max_points=20" in results[0].reason
    drop, *reminders = warnings(caplog)
    assert "max_points" in drop.getMessage() and len(reminders) >= 3
    assert all("pairs still arrive" in r.getMessage() for r in reminders)
    assert not warnings(caplog, "stuck")
    gaps = np.diff([drop.sim_time] + [r.sim_time for r in reminders])
    assert np.all(gaps >= 5.0) and np.all(gaps <= 5.0 + 2 * POLL)


# ---- points outside the frame ---------------------------------------------------------------
def test_points_outside_the_frame_are_dropped_and_the_gesture_goes_on(caplog):
    x, y, flag = gesture_frames("left")
    bad = {20: (700.0, 240.0), 35: (320.0, 480.0), 50: (1000.0, 999.0)}
    for n, (bx, by) in bad.items():
        x[n], y[n] = bx, by
    app, peripheral, clock, link, _ = make_app()
    peripheral.queue_trajectory(x, y, flag, pixels=True)
    (result,) = run_until_played(app, peripheral)
    assert result.class_name == "left" and link.sent == [telegram("left")]
    keep = flag.copy()
    keep[list(bad)] = False
    assert result.num_points == keep.sum() == flag.sum() - 3 and app.bad_points == 3
    assert list(result.symbols) == symbols_of([[to_fixed(a), to_fixed(b)]
                                               for a, b in zip(x[keep], y[keep])])
    dropped = [r.getMessage() for r in warnings(caplog, "point dropped")]
    assert len(dropped) == 3 == len(warnings(caplog))
    assert "(700.00, 240.00) px" in dropped[0] and "x in [0, 640), y in [0, 480)" in dropped[0]
    assert "(320.00, 480.00) px" in dropped[1] and "(1000.00, 999.00) px" in dropped[2]
    assert "1 in this gesture, max_bad_points=5" in dropped[0]


def test_too_many_points_outside_the_frame_drop_the_gesture(caplog):
    x, y, flag = gesture_frames("left")
    x[[20, 21, 22]] = 800.0
    x2, y2, flag2 = gesture_frames("stop")
    app, peripheral, clock, link, _ = make_app(max_bad_points=2)
    peripheral.queue_trajectory(np.r_[x, x2], np.r_[y, y2], np.r_[flag, flag2], pixels=True)
    results = run_until_played(app, peripheral)
    assert [r.outcome for r in results] == ["dropped", "recognised"]
    assert results[0].reason == "3 points outside the frame (more than max_bad_points=2)"
    assert results[0].telegram is None and link.sent == [telegram("stop")]
    assert results[1].class_name == "stop" and app.bad_points == 3


class HighBitsBus:
    """A SimBus whose ``nth`` Dato_X read has bit ``bit`` set (above the 18 data bits)."""

    def __init__(self, inner, nth, bit=24):
        self.inner, self.nth, self.bit, self.pops = inner, nth, bit, 0

    def read32(self, offset):
        value = self.inner.read32(offset)
        if offset == DATO_X:
            self.pops += 1
            if self.pops == self.nth:
                value |= 1 << self.bit
        return value

    def write32(self, offset, value):
        self.inner.write32(offset, value)

    def close(self):
        pass


def test_bits_above_the_data_bits_make_a_bad_point(caplog):
    x, y, flag = gesture_frames("left")
    app, peripheral, clock, link, bus = make_app(wrap=lambda inner, p: HighBitsBus(inner, 30))
    peripheral.queue_trajectory(x, y, flag, pixels=True)
    (result,) = run_until_played(app, peripheral)
    assert result.class_name == "left" and result.num_points == flag.sum() - 1
    (message,) = [r.getMessage() for r in warnings(caplog)]
    raw = to_fixed(x[flag][29]) | 1 << 24
    assert f"Dato_X={raw:#010x}" in message and "bits above the 18 data bits" in message
    assert "allowed 0..0x3ffff" in message


# ---- unequal or impossible FIFO lengths ---------------------------------------------------------
def test_unequal_lengths_drop_the_gesture_and_the_clear_realigns_the_fifos(caplog):
    app, peripheral, clock, link, _ = make_app()
    app.run(max_iterations=2)
    x, y, flag = gesture_frames("left", rest=0)
    push_flagged(peripheral, x, y, range(10))
    app.run(max_iterations=1)                               # S1 -> S2, ten pairs popped
    assert app.state is State.READ and app.classifier.num_points == 10
    peripheral.fifo_x.append(to_fixed(300.0))               # an X without its Y
    push_flagged(peripheral, x, y, range(10, 15))           # Longitud_X = 6, Longitud_Y = 5
    (result,) = app.run(max_iterations=2)                   # S2 drops, S5 clears
    assert result.outcome == "dropped" and "Longitud_X=6 and Longitud_Y=5 differ" in result.reason
    (warning,) = warnings(caplog)
    assert "Longitud_X=6 and Longitud_Y=5" in warning.getMessage()
    assert not peripheral.fifo_x and not peripheral.fifo_y and not link.sent
    # The rest of that gesture is ignored; the next one is recognised.
    peripheral.queue_trajectory(x[15:], y[15:], flag[15:], pixels=True)
    peripheral.queue_trajectory(*gesture_frames("right"), pixels=True)
    assert [r.class_name for r in run_until_played(app, peripheral)] == ["right"]
    assert link.sent == [telegram("right")]


class LengthsBus:
    """A SimBus whose Longitud reads give ``override(offset, value)`` while it is set."""

    def __init__(self, inner):
        self.inner = inner
        self.override = None

    def read32(self, offset):
        value = self.inner.read32(offset)
        if self.override is not None and offset in (LONGITUD_X, LONGITUD_Y):
            value = self.override(offset, value)
        return value

    def write32(self, offset, value):
        self.inner.write32(offset, value)

    def close(self):
        pass


def test_lengths_above_the_fifo_depth_drop_the_gesture(caplog):
    app, peripheral, clock, link, bus = make_app(wrap=lambda inner, p: LengthsBus(inner))
    app.run(max_iterations=2)
    x, y, _ = gesture_frames("back", rest=0)
    push_flagged(peripheral, x, y, range(5))
    bus.override = lambda offset, value: FIFO_DEPTH + 88
    (result,) = app.run(max_iterations=2)
    assert result.outcome == "dropped"
    assert "Longitud_X=600 and Longitud_Y=600 exceed FIFO_DEPTH=512" in result.reason
    bus.override = None
    peripheral.flag = False
    app.run(max_iterations=3)
    assert app.state is State.WAIT and not app.discarding and not peripheral.fifo_x


@pytest.mark.parametrize("heartbeat, expected", [(10.0, [0, 10, 20]), (None, [0])])
def test_lasting_unequal_lengths_while_idle_are_cleared_and_warned_once_per_heartbeat(
        caplog, heartbeat, expected):
    app, peripheral, clock, link, bus = make_app(wrap=lambda inner, p: LengthsBus(inner),
                                                 heartbeat=heartbeat)
    app.run(max_iterations=2)
    bus.override = lambda offset, value: 3 if offset == LONGITUD_X else value
    clears = peripheral.clears
    with stamped(caplog, clock):
        start = clock()
        run_for(app, clock, 25.0)
    found = warnings(caplog)
    assert [round(r.sim_time - start) for r in found] == expected
    assert "Longitud_X=3 and Longitud_Y=0 differ" in found[0].getMessage()
    assert all("persists" in r.getMessage() for r in found[1:])
    assert not app.results and app.faults == 1 and peripheral.clears - clears > 2000
    bus.override = None                                     # the fault goes away
    caplog.clear()
    run_for(app, clock, 11.0)
    assert not warnings(caplog) and (heartbeat is None or records(caplog, "alive"))


class PushBetweenLengthReads:
    """A SimBus where the hardware pushes a frame right after the Longitud_X read of
    every status, before Longitud_Y is read (legitimately unequal lengths)."""

    def __init__(self, inner, peripheral):
        self.inner, self.peripheral = inner, peripheral
        self.after_control = False

    def read32(self, offset):
        value = self.inner.read32(offset)
        if offset == CONTROL:
            self.after_control = True
        elif offset == LONGITUD_X and self.after_control:
            self.after_control = False
            self.peripheral.step()
        return value

    def write32(self, offset, value):
        self.inner.write32(offset, value)

    def close(self):
        pass


def test_a_push_between_the_two_length_reads_is_not_a_fault(caplog):
    x, y, flag = gesture_frames("rotate-right")
    app, peripheral, clock, link, _ = make_app(wrap=PushBetweenLengthReads)
    peripheral.queue_trajectory(x, y, flag, pixels=True)
    (result,) = run_until_played(app, peripheral)
    assert result.class_name == "rotate-right" and result.num_points == flag.sum()
    assert not warnings(caplog) and app.faults == 0


# ---- heartbeat ---------------------------------------------------------------------------------
@pytest.mark.parametrize("heartbeat", [5.0, 0, None])
def test_heartbeat_lines_while_idle(caplog, heartbeat):
    app, peripheral, clock, link, _ = make_app(heartbeat=heartbeat)
    with stamped(caplog, clock):
        run_for(app, clock, 60.0)
    alive = records(caplog, "alive")
    if not heartbeat:
        assert alive == [] and app.heartbeat is None
        return
    times = [r.sim_time for r in alive]
    assert 11 <= len(times) <= 12 and all(r.levelno == logging.INFO for r in alive)
    assert 5.0 <= times[0] <= 5.0 + 2 * POLL
    assert all(5.0 <= b - a <= 5.0 + 2 * POLL for a, b in zip(times, times[1:]))
    assert alive[0].getMessage() == (
        "alive: waiting for a gesture (S1); gestures 0 recognised, 0 rejected, 0 dropped; "
        "0 errors; 0 faults (0 points outside the frame); 0 bus faults (0 s)")
    # The counters follow what happened.
    x, y, flag = gesture_frames("stop")
    x[30] = 900.0
    peripheral.queue_trajectory(x, y, flag, pixels=True)
    run_until_played(app, peripheral)
    peripheral.reads_per_frame = None
    caplog.clear()
    run_for(app, clock, 6.0)
    assert "gestures 1 recognised, 0 rejected, 0 dropped; 0 errors; 1 faults " \
           "(1 points outside the frame)" in records(caplog, "alive")[-1].getMessage()


def test_simulated_trajectories_run_in_simulated_time(caplog):
    # The default simulation sleeps nothing but its clock advances by the sleeps: 30
    # idle polls of 5 ms pass 0.15 s, which a real clock would not see.
    x, y, flag = gesture_frames("left")
    run = run_on_trajectory(MODELS, x, y, flag, heartbeat=0.05)
    assert run.recognised == ["left"] and records(caplog, "alive")


# ---- parameters and command line -----------------------------------------------------------------
@pytest.mark.parametrize("name, value", [
    ("gesture_timeout", 0), ("gesture_timeout", -1.0), ("gesture_timeout", math.nan),
    ("gesture_timeout", math.inf), ("gesture_timeout", True), ("gesture_timeout", "2"),
    ("heartbeat", -1), ("heartbeat", math.nan), ("heartbeat", math.inf), ("heartbeat", "60"),
    ("max_bad_points", -1), ("max_bad_points", 1.5), ("max_bad_points", True),
    ("frame_width", 0), ("frame_width", 1025), ("frame_height", 480.0), ("frame_height", 0)])
def test_constructor_validates_the_fault_parameters(name, value):
    fifo = FifoPeripheral(SimBus(SimulatedFifoPeripheral()))
    with pytest.raises(ValueError, match=name):
        GestureApp(MODELS, fifo, **{name: value})


def test_frame_size_is_the_one_the_soc_is_built_for():
    # sw_hps may import nothing else of the project, so the board's frame size is
    # written in sw_hps.fifo; it must be the default of every hardware builder.
    pytest.importorskip("amaranth")   # the hardware: not on the board's floor
    from hdl.gesture_pipeline import GesturePipeline
    from soc.core import StereogestCore
    from soc.generate import generate
    for builder in (StereogestCore.__init__, GesturePipeline.__init__, generate):
        parameters = inspect.signature(builder).parameters
        assert (parameters["width"].default, parameters["height"].default) == \
            (FRAME_WIDTH, FRAME_HEIGHT), builder.__qualname__
    assert inspect.signature(StereogestCore.__init__).parameters["fifo_depth"].default \
        == FIFO_DEPTH
    app = GestureApp(MODELS, FifoPeripheral(SimBus(SimulatedFifoPeripheral())))
    assert (app.frame_width, app.frame_height) == (FRAME_WIDTH, FRAME_HEIGHT)


@pytest.fixture
def model_file(tmp_path):
    path = tmp_path / "models.json"
    save_models(MODELS, path)
    return path


@pytest.mark.parametrize("option, value, allowed", [
    ("--gesture-timeout", "0", "[0.1, 600]"), ("--gesture-timeout", "601", "[0.1, 600]"),
    ("--gesture-timeout", "nan", "[0.1, 600]"), ("--gesture-timeout", "soon", "invalid float"),
    ("--heartbeat", "-1", "0 (off) or in [1, 86400]"), ("--heartbeat", "0.5", "[1, 86400]"),
    ("--heartbeat", "inf", "[1, 86400]"), ("--heartbeat", "nan", "[1, 86400]")])
def test_cli_fault_options_are_validated(model_file, option, value, allowed, capsys):
    code = main(["--model", str(model_file), "--bus", "sim", "--robot", "none", option, value])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1
    assert err.startswith(f"python -m sw_hps: error: argument {option}") and allowed in err


def test_cli_fault_options_reach_the_app(model_file, tmp_path, capsys):
    base = ["--model", str(model_file), "--bus", "sim", "--robot", "none"]
    args = parse_args(base)
    assert (args.gesture_timeout, args.heartbeat) == (DEFAULT_GESTURE_TIMEOUT, DEFAULT_HEARTBEAT)
    args = parse_args(base + ["--gesture-timeout", "0.5", "--heartbeat", "0"])
    assert (args.gesture_timeout, args.heartbeat) == (0.5, 0)
    x, y, flag = gesture_frames("forward")
    path = tmp_path / "trajectory.csv"
    path.write_text("frame,x,y,flag\n" + "".join(f"{n},{x[n]:.4f},{y[n]:.4f},{int(flag[n])}\n"
                                                 for n in range(len(x))))
    assert main(base + ["--sim-trajectory", str(path), "--poll-ms", "0.01", "--heartbeat", "0",
                        "--gesture-timeout", "5", "--log-level", "warning"]) == 0
    assert '"class_name": "forward"' in capsys.readouterr().out


# ---- property tests over arbitrary register values ----------------------------------------------
#: Simulated seconds a poll's bus accesses take in :class:`ScriptedRegisters`.
BUS_TIME = 0.01
IDLE_CONTROL = CTRL_GO | CTRL_NO_GESTURE


class ScriptedRegisters:
    """Fake bus playing scripted register values: each Control read moves to the next
    polled value set ``(control, length_x, length_y, fail)`` and advances the clock by
    :data:`BUS_TIME`; pops cycle through ``words``. Once the script is played the
    registers read a sane idle state (GO, no gesture, empty FIFOs)."""

    def __init__(self, phases, words, clock):
        self.steps = [(control, lx, ly, fail)
                      for control, (lx, ly), polls, fail in phases for _ in range(polls)]
        self.words = words
        self.clock = clock
        self.index = -1
        self.pops = 0

    @property
    def played(self) -> bool:
        return self.index >= len(self.steps)

    def _current(self):
        if 0 <= self.index < len(self.steps):
            return self.steps[self.index]
        return IDLE_CONTROL, 0, 0, False

    def read32(self, offset):
        if offset == CONTROL:
            self.index += 1
            self.clock.advance(BUS_TIME)
            control, _, _, fail = self._current()
            if fail:
                raise OSError(5, "scripted bus fault")
            return control
        if offset == LONGITUD_X:
            return self._current()[1]
        if offset == LONGITUD_Y:
            return self._current()[2]
        if offset in (DATO_X, DATO_Y):
            if self.played:
                return 0
            self.pops += 1
            return self.words[self.pops % len(self.words)]
        if offset == ID:
            return CORE_MAGIC        # a core answers; only its other registers misbehave
        return 0

    def write32(self, offset, value):
        assert 0 <= value <= 0xFFFFFFFF

    def close(self):
        pass


_controls = st.one_of(
    st.integers(0, 2 ** 32 - 1),
    st.sampled_from([CTRL_GO,                                         # gesture bit stuck at 0
                     CTRL_GO | CTRL_FIFO_DATA, IDLE_CONTROL, IDLE_CONTROL | CTRL_FIFO_DATA,
                     CTRL_GO | CTRL_FIFO_FULL, IDLE_CONTROL | CTRL_FIFO_FULL,
                     CTRL_GO | CTRL_FIFO_DATA | CTRL_FIFO_FULL]))
_length = st.one_of(st.integers(0, 8), st.sampled_from([FIFO_DEPTH, FIFO_DEPTH + 1]),
                    st.integers(0, 2 ** 32 - 1))
_lengths = st.one_of(_length.map(lambda n: (n, n)), st.tuples(_length, _length))
_phases = st.lists(st.tuples(_controls, _lengths, st.integers(1, 300),
                             st.integers(0, 15).map(lambda k: k == 0)), min_size=1, max_size=8)
_words = st.lists(st.one_of(st.integers(0, 2 ** 32 - 1),
                            st.integers(0, (FRAME_HEIGHT << FRAC_BITS) - 1)),
                  min_size=1, max_size=50)
TIMEOUT, HEARTBEAT = 0.5, 2.0


@settings(max_examples=40, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(phases=_phases, words=_words)
def test_arbitrary_registers_never_crash_silence_or_strand_the_app(caplog, phases, words):
    caplog.clear()
    clock = SimulatedClock()
    bus = ScriptedRegisters(phases, words, clock)
    link = RecordingLink()
    app = GestureApp(MODELS, FifoPeripheral(bus), link, sleep=clock.sleep, clock=clock,
                     poll_interval=POLL, gesture_timeout=TIMEOUT, heartbeat=HEARTBEAT,
                     max_points=40, max_pairs_per_poll=8, max_bad_points=3,
                     initial_backoff=0.05, max_backoff=0.2, max_fault_interval=0.2)
    with stamped(caplog, clock):
        results = app.run(max_iterations=4 * len(bus.steps) + 50, until=lambda: bus.played)
        assert bus.played
        # Back to sane idle registers: S1, not ignoring anything, within a few steps.
        results += app.run(max_iterations=6)
        assert app.state is State.WAIT and not app.discarding
        end = clock()
    # Never silent for longer than the heartbeat (plus a poll and a back-off).
    times = [0.0] + [r.sim_time for r in records(caplog)] + [end]
    assert max(np.diff(times)) <= HEARTBEAT + 0.25
    # Every gesture has an outcome, a reason unless recognised, and only recognised
    # gestures send telegrams.
    for result in results:
        assert result.outcome in OUTCOMES
        assert (result.reason is None) == result.recognised
        if not result.recognised:
            assert result.reason and result.telegram is None and not result.sent
    assert link.sent == [r.telegram for r in results if r.recognised and r.telegram]
    assert Counter(r.outcome for r in results) == {k: v for k, v in app.outcomes.items() if v}


@settings(max_examples=30, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(stuck=st.floats(0.05, 12.0), timeout=st.sampled_from([0.5, 1.0, 2.0]),
       heartbeat=st.sampled_from([1.0, 3.0, 5.0]), pairs=st.integers(0, 20),
       name=st.sampled_from(GESTURE_NAMES))
def test_a_stuck_bit_of_any_length_is_reported_in_time_then_forgotten(
        caplog, stuck, timeout, heartbeat, pairs, name):
    assume(abs(stuck - timeout) > 3 * POLL)
    caplog.clear()
    app, peripheral, clock, link, _ = make_app(gesture_timeout=timeout, heartbeat=heartbeat)
    app.run(max_iterations=2)
    x, y, _ = gesture_frames(name, rest=0)
    push_flagged(peripheral, x, y, range(pairs))
    peripheral.flag = True                                  # then no pair: the bit is stuck
    with stamped(caplog, clock):
        start = clock()
        results = run_for(app, clock, stuck)
        peripheral.flag = False                             # the bit reads 1 again
        results += app.run(max_iterations=6)
    assert app.state is State.WAIT and not app.discarding
    found = warnings(caplog)
    if stuck > timeout:
        (result,) = results
        assert result.outcome == "dropped" and "stuck" in result.reason and not link.sent
        assert timeout < found[0].sim_time - start <= timeout + 2 * POLL
        assert all("still 0" in r.getMessage() for r in found[1:])
        # Reminders: not once per poll, and never a silence longer than the heartbeat.
        times = [r.sim_time for r in found]
        assert np.all(np.diff(times) >= heartbeat)
        assert np.all(np.diff(times + [start + stuck]) <= heartbeat + 2 * POLL)
        assert records(caplog, "back to normal")
    else:
        assert found == [] and len(results) == 1 and results[0].outcome != "dropped"
    # A following good gesture goes through.
    peripheral.queue_trajectory(*gesture_frames("left"), pixels=True)
    assert [r.class_name for r in run_until_played(app, peripheral)] == ["left"]


def _is_bad(x, y):
    return (x > DATA_MASK or y > DATA_MASK or x >= FRAME_WIDTH << FRAC_BITS
            or y >= FRAME_HEIGHT << FRAC_BITS)


_word = st.one_of(st.integers(0, 2 ** 32 - 1), st.integers(0, DATA_MASK),
                  st.sampled_from([0, (FRAME_WIDTH << FRAC_BITS) - 1, FRAME_WIDTH << FRAC_BITS,
                                   (FRAME_HEIGHT << FRAC_BITS) - 1, FRAME_HEIGHT << FRAC_BITS,
                                   DATA_MASK, DATA_MASK + 1]))


@settings(max_examples=60, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(words=st.lists(st.tuples(_word, _word), min_size=1, max_size=40),
       max_bad=st.integers(0, 5))
def test_arbitrary_dato_values_keep_the_points_inside_the_frame(caplog, words, max_bad):
    caplog.clear()
    app, peripheral, clock, link, _ = make_app(max_bad_points=max_bad)
    app.run(max_iterations=2)
    for x, y in words:                          # straight into the FIFOs, unchecked
        peripheral.fifo_x.append(x)
        peripheral.fifo_y.append(y)
    (result,) = app.run(max_iterations=6)
    assert app.state is State.WAIT and not peripheral.fifo_x
    bad = [_is_bad(x, y) for x, y in words]
    good = [w for w, b in zip(words, bad) if not b]
    dropped = warnings(caplog, "point dropped")
    assert all("x in [0, 640), y in [0, 480)" in r.getMessage()
               or "bits above the 18 data bits" in r.getMessage() for r in dropped)
    if sum(bad) > max_bad:
        assert result.outcome == "dropped" and not link.sent
        assert result.reason == (f"{max_bad + 1} points outside the frame "
                                 f"(more than max_bad_points={max_bad})")
        assert app.bad_points == len(dropped) == max_bad + 1
    else:
        assert result.outcome in ("recognised", "rejected")
        assert app.bad_points == len(dropped) == sum(bad)
        assert result.num_points == len(good) and list(result.symbols) == symbols_of(good)


_any_length = st.one_of(st.integers(0, 600), st.integers(0, 2 ** 32 - 1))


@settings(max_examples=60, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(first=st.tuples(_any_length, _any_length), second=st.tuples(_any_length, _any_length))
def test_arbitrary_length_values_drop_the_gesture_only_when_read_wrong_twice(
        caplog, first, second):
    caplog.clear()
    app, peripheral, clock, link, bus = make_app(wrap=lambda inner, p: LengthsBus(inner))
    app.run(max_iterations=2)
    x, y, _ = gesture_frames("left", rest=0)
    push_flagged(peripheral, x, y, range(3))
    reads = {LONGITUD_X: [first[0], second[0]], LONGITUD_Y: [first[1], second[1]]}
    bus.override = lambda offset, value: reads[offset].pop(0) if reads[offset] else value
    results = app.run(max_iterations=1)                     # S1 -> S2: the first status
    bus.override = None
    peripheral.flag = False
    results += app.run(max_iterations=8)
    assert app.state is State.WAIT and not app.discarding and not peripheral.fifo_x
    assert all(r.outcome in OUTCOMES for r in results)
    dropped = [r for r in results if "Longitud" in (r.reason or "")]
    if first[0] == first[1] <= FIFO_DEPTH or second[0] == second[1] <= FIFO_DEPTH:
        assert dropped == [] and warnings(caplog, "Longitud") == []
    else:
        (result,) = dropped
        assert result.outcome == "dropped" and not link.sent
        assert f"Longitud_X={second[0]} and Longitud_Y={second[1]}" in result.reason
        assert len(warnings(caplog, "Longitud")) == 1

"""Bus faults of the board's loops (sw_hps.busfault; sw_hps.app and sw_hps.streaming,
module docstrings): a bridge that reads all ones or all zeros, one that comes and
goes, one that raises, a stuck FIFO data or FIFO-FULL bit, impossible lengths.
Each is driven for thousands of steps in simulated time: every step must sleep
(or make progress, with a sleep at least every MAX_BUSY_STEPS steps), the log must
stay at a handful of lines, and the loop must come back when the bus does.
"""
import dataclasses
import logging
import re

import pytest

from soc.hps_interface import (CONTROL, CORE_MAGIC, CTRL_FIFO_DATA, CTRL_FIFO_FULL, CTRL_GO,
                               CTRL_NO_GESTURE, CTRL_STREAM, DATO_X, DATO_Y, FIFO_DEPTH, ID,
                               LONGITUD_X)
from sw_hps.app import GestureApp, State
from sw_hps.bus import DevMemBus, SimBus
from sw_hps.busfault import (CHECK_HINT, FAULT_REMINDER, MAX_BUSY_STEPS, MAX_FAULT_INTERVAL,
                             BusFaultWatch, RepeatFilter, control_fault, describe_bus,
                             lengths_fault)
from sw_hps.fifo import FifoPeripheral, to_fixed
from sw_hps.simulated import SimulatedClock, SimulatedFifoPeripheral
from sw_hps.streaming import StreamingApp
from sw_hps.telegram import telegram
from tests.test_hps_app import MODELS, RecordingLink, gesture_frames
from tests.test_hps_app_faults import records, run_until_played, stamped, warnings

#: Poll interval of the loops under test (simulated seconds).
POLL = 0.005
ALL_ONES = 0xFFFFFFFF
STEPS = 3000
#: Discrete models with a ``spotting`` entry, enough for the streaming loop.
STREAM_MODELS = dataclasses.replace(MODELS, spotting={"threshold_bias": -0.5, "end_delay": 8,
                                                      "min_symbols": 4, "step": 12})


@pytest.fixture(autouse=True)
def info_logs(caplog):
    caplog.set_level(logging.INFO, logger="sw_hps")


class FaultyBridge:
    """A SimBus behind a bridge that can go bad. ``pattern`` None passes every access
    through; an int makes every read return it and every write vanish (all ones: a
    bridge with nothing decoding the address; 0: a core held in reset); ``"raise"``
    makes every access raise OSError (EIO)."""

    def __init__(self, inner, pattern=None):
        self.inner, self.pattern = inner, pattern
        self.reads = 0

    def read32(self, offset):
        self.reads += 1
        if self.pattern == "raise":
            raise OSError(5, "Input/output error")
        if self.pattern is not None:
            return self.pattern
        return self.inner.read32(offset)

    def write32(self, offset, value):
        if self.pattern == "raise":
            raise OSError(5, "Input/output error")
        if self.pattern is None:
            self.inner.write32(offset, value)

    def close(self):
        pass


def thesis_app(pattern=None, heartbeat=60.0, **options):
    """GestureApp on a simulated FIFO behind a FaultyBridge, in simulated time."""
    clock = SimulatedClock()
    peripheral = SimulatedFifoPeripheral()
    bus = FaultyBridge(SimBus(peripheral), pattern)
    link = RecordingLink()
    app = GestureApp(MODELS, FifoPeripheral(bus), link, sleep=clock.sleep, clock=clock,
                     poll_interval=POLL, heartbeat=heartbeat, **options)
    return app, peripheral, bus, clock, link


def streaming_app(bus, clock, **options):
    return StreamingApp(STREAM_MODELS, FifoPeripheral(bus), RecordingLink(), sleep=clock.sleep,
                        clock=clock, poll_interval=POLL, **options)


def drive(app, clock, steps):
    """Run ``steps`` steps one at a time; the simulated seconds each one slept."""
    gaps = []
    for _ in range(steps):
        start = clock()
        app.run(max_iterations=1)
        gaps.append(clock() - start)
    return gaps


def longest_busy_run(gaps):
    """Most steps in a row that slept nothing."""
    longest = run = 0
    for gap in gaps:
        run = 0 if gap > 0 else run + 1
        longest = max(longest, run)
    return longest


# ---- the loops of the thesis mode ----------------------------------------------------------
@pytest.mark.parametrize("pattern, reads", [
    (ALL_ONES, "Control reads 0xffffffff: bits 0xffffffc8 set, which the core never sets"),
    (0, "Control reads 0x00000000: GO does not read back after the application set it")])
def test_a_dead_bridge_is_backed_off_logged_once_and_recovered(caplog, pattern, reads):
    app, peripheral, bus, clock, link = thesis_app(pattern, heartbeat=None)
    with stamped(caplog, clock):
        gaps = drive(app, clock, STEPS)
    # Every step slept: the probe interval doubles from the poll interval to the cap.
    assert min(gaps) > 0
    assert gaps[:4] == pytest.approx([POLL, 2 * POLL, 4 * POLL, 8 * POLL])
    assert max(gaps) == pytest.approx(MAX_FAULT_INTERVAL)
    assert sum(gaps) > (STEPS - 20) * MAX_FAULT_INTERVAL
    # One line for the whole fault (no heartbeat: no reminders), naming what was read,
    # the ID register, the likely cause and the check; never a FIFO-FULL flood.
    (warning,) = warnings(caplog)
    message = warning.getMessage()
    assert reads in message and f"ID reads {pattern:#010x}, not CORE_MAGIC" in message
    assert "bridge is disabled or held in reset" in message and CHECK_HINT in message
    assert not records(caplog, "FIFO-FULL") and not records(caplog, "S0: FIFO cleared")
    assert app.bus_faults == 1 and app.errors == 0 and not app.results and not link.sent
    # The bridge comes back: one probe, S0 re-initialises the core, S1.
    bus.pattern = None
    app.run(max_iterations=3)
    assert app.state is State.WAIT and peripheral.go and not app.bus_watch.active
    (back,) = records(caplog, "bus reads sane again")
    assert "core re-initialised (FIFO-CLR, GO); 1 bus faults" in back.getMessage()
    peripheral.queue_trajectory(*gesture_frames("left"), pixels=True)
    assert [r.class_name for r in run_until_played(app, peripheral)] == ["left"]
    assert link.sent == [telegram("left")]


def test_a_lasting_fault_is_reminded_once_per_heartbeat_and_counted_in_the_alive_line(caplog):
    app, peripheral, bus, clock, link = thesis_app(heartbeat=60.0)
    app.run(max_iterations=2)                               # S0, S1: running normally
    bus.pattern = ALL_ONES
    with stamped(caplog, clock):
        start = clock()
        gaps = drive(app, clock, STEPS)
        found = warnings(caplog)
    elapsed = clock() - start
    assert min(gaps) > 0 and elapsed > 2900
    first, *reminders = found
    assert "bus fault at FaultyBridge (slave at offset 0x0)" in first.getMessage()
    # A reminder per heartbeat (a minute here), not per step: ~50 lines in 50 minutes.
    assert len(reminders) == pytest.approx(elapsed / 60.0, abs=1)
    times = [r.sim_time for r in found]
    assert all(60.0 <= b - a <= 60.0 + MAX_FAULT_INTERVAL for a, b in zip(times, times[1:]))
    assert all("bus fault persists" in r.getMessage() for r in reminders)
    bus.pattern = None
    caplog.clear()
    app.run(max_iterations=3)
    with stamped(caplog, clock):
        drive(app, clock, int(61 / POLL))
    alive = records(caplog, "alive")[-1].getMessage()
    seconds = re.search(r"; 1 bus faults \((\d+) s\)$", alive).group(1)
    assert int(seconds) == pytest.approx(elapsed, abs=2)


def test_a_fault_during_a_gesture_drops_it_and_the_next_one_goes_through(caplog):
    app, peripheral, bus, clock, link = thesis_app()
    x, y, flag = gesture_frames("right")
    peripheral.queue_trajectory(x, y, flag, pixels=True)
    peripheral.reads_per_frame = 1
    app.run(max_iterations=40, until=lambda: app.classifier.num_points >= 20)
    assert app.state is State.READ
    bus.pattern = ALL_ONES
    (result,) = app.run(max_iterations=5)
    assert result.outcome == "dropped" and result.num_points >= 20 and not link.sent
    assert result.reason.startswith("bus fault: Control reads 0xffffffff")
    bus.pattern = None
    peripheral.queue_trajectory(*gesture_frames("stop"), pixels=True)
    later = run_until_played(app, peripheral)
    # The rest of the interrupted gesture is ignored (its start was lost).
    assert [r.class_name for r in later] == ["stop"] and link.sent == [telegram("stop")]


def test_a_flapping_bridge_cannot_flood_the_log(caplog):
    """Good for 7 steps, all ones for 5, over and over: after the first line, nothing
    new until a reminder is due, and the back-off carries over."""
    app, peripheral, bus, clock, link = thesis_app(heartbeat=60.0)
    gaps = []
    with stamped(caplog, clock):
        for step in range(STEPS):
            bus.pattern = ALL_ONES if step % 12 >= 7 else None
            gaps.extend(drive(app, clock, 1))
    elapsed = clock()
    assert app.bus_faults > 200                              # every flap was seen ...
    lines = [r for r in records(caplog) if r.getMessage().startswith("gesture loop: ")]
    assert 1 <= len(lines) <= 2 * (elapsed / 60.0 + 1)       # ... but logged per minute
    assert len(records(caplog, "S0: FIFO cleared")) == 1     # only the first start says so
    assert longest_busy_run(gaps) <= MAX_BUSY_STEPS


def test_a_bridge_that_raises_is_logged_per_backoff_level_not_per_step(caplog):
    app, peripheral, bus, clock, link = thesis_app("raise", heartbeat=60.0,
                                                   initial_backoff=0.1, max_backoff=5.0)
    with stamped(caplog, clock):
        gaps = drive(app, clock, STEPS)
    elapsed = clock()
    assert min(gaps) > 0 and app.errors == STEPS
    lines = records(caplog, "Input/output error", level=logging.ERROR)
    levels = 7                                               # 0.1, 0.2, ... 3.2, 5.0 s
    assert levels <= len(lines) <= levels + elapsed / 60.0 + 1
    assert "more like it not logged" in lines[-1].getMessage()


class StuckDataBit:
    """A core whose FIFO data bit is stuck at 1 with both lengths at 0 (pops read 0):
    each poll pops a point, so no poll is idle."""

    def read32(self, offset):
        return {CONTROL: CTRL_GO | CTRL_FIFO_DATA | CTRL_NO_GESTURE, ID: CORE_MAGIC}.get(offset, 0)

    def write32(self, offset, value):
        pass

    def close(self):
        pass


def test_steps_that_never_idle_still_sleep_every_max_busy_steps():
    clock = SimulatedClock()
    app = GestureApp(MODELS, FifoPeripheral(StuckDataBit()), RecordingLink(), sleep=clock.sleep,
                     clock=clock, poll_interval=POLL)
    gaps = drive(app, clock, STEPS)
    assert longest_busy_run(gaps) <= MAX_BUSY_STEPS
    assert sum(1 for gap in gaps if gap > 0) >= STEPS // MAX_BUSY_STEPS
    assert all(r.outcome == "dropped" and "max_points" in r.reason for r in app.results)


# ---- the continuous mode ---------------------------------------------------------------------
@pytest.mark.parametrize("pattern, reads", [
    (ALL_ONES, "Control reads 0xffffffff: bits 0xffffffc8 set"),
    (0, "Control reads 0x00000000: GO does not read back")])
def test_streaming_backs_off_a_dead_bridge_and_restarts_when_it_returns(caplog, pattern, reads):
    clock = SimulatedClock()
    peripheral = SimulatedFifoPeripheral()
    bus = FaultyBridge(SimBus(peripheral), pattern)
    app = streaming_app(bus, clock)
    with stamped(caplog, clock):
        gaps = drive(app, clock, STEPS)
    assert min(gaps) > 0 and max(gaps) == pytest.approx(MAX_FAULT_INTERVAL)
    elapsed = clock()
    found = warnings(caplog)
    assert reads in found[0].getMessage() and CHECK_HINT in found[0].getMessage()
    assert len(found) == pytest.approx(1 + elapsed / FAULT_REMINDER, abs=1)
    assert not records(caplog, "FIFO-FULL") and app.bus_faults == 1 and app.errors == 0
    bus.pattern = None
    app.run(max_iterations=2)                                # a probe, the restart
    assert peripheral.go and peripheral.streaming and not app.bus_watch.active
    assert records(caplog, "core re-initialised (FIFO-CLR, GO, STREAM)")
    for n in range(5):
        peripheral.push_frame(to_fixed(100 + 20 * n), to_fixed(100), False)
    app.run(max_iterations=1)
    assert app.frames == 5


class Overlay:
    """A SimBus whose Control reads get ``control_or`` ORed in and whose Longitud_X
    reads give ``length_x`` if set; counts the pops."""

    def __init__(self, inner, control_or=0, length_x=None):
        self.inner, self.control_or, self.length_x = inner, control_or, length_x
        self.pops = 0

    def read32(self, offset):
        value = self.inner.read32(offset)
        if offset == CONTROL:
            value |= self.control_or
        elif offset == LONGITUD_X and self.length_x is not None:
            value = self.length_x
        elif offset in (DATO_X, DATO_Y):
            self.pops += 1
        return value

    def write32(self, offset, value):
        self.inner.write32(offset, value)

    def close(self):
        pass


def test_streaming_with_a_stuck_fifo_full_bit_neither_spins_nor_floods(caplog):
    clock = SimulatedClock()
    peripheral = SimulatedFifoPeripheral()
    bus = Overlay(SimBus(peripheral))
    app = streaming_app(bus, clock)
    drive(app, clock, 3)
    bus.control_or = CTRL_FIFO_FULL
    with stamped(caplog, clock):
        gaps = drive(app, clock, STEPS)
    elapsed = clock()
    # Before: one "FIFO-FULL" warning and a restart per step, never sleeping.
    assert app.lost == 1 and len(records(caplog, "FIFO-FULL (the loop fell")) == 1
    (fault, *reminders) = [r for r in warnings(caplog) if "bus fault" in r.getMessage()]
    assert "FIFO-FULL set right after FIFO-CLR cleared it" in fault.getMessage()
    assert len(reminders) <= elapsed / FAULT_REMINDER + 1
    assert longest_busy_run(gaps) <= 1 and elapsed > 1000


def test_streaming_never_pops_an_impossible_length(caplog):
    clock = SimulatedClock()
    peripheral = SimulatedFifoPeripheral()
    bus = Overlay(SimBus(peripheral), control_or=CTRL_FIFO_DATA, length_x=0xFFFF)
    app = streaming_app(bus, clock)
    peripheral.write32(CONTROL, CTRL_GO | CTRL_STREAM)
    peripheral.push_frame(to_fixed(10), to_fixed(10), False)   # so that Longitud_Y is 1
    gaps = drive(app, clock, 50)
    assert bus.pops == 0 and min(gaps) > 0 and app.bus_faults == 1
    (fault,) = warnings(caplog)
    assert "Longitud_X=65535 and Longitud_Y=" in fault.getMessage()
    assert "Longitud_X exceeds FIFO_DEPTH=%d" % FIFO_DEPTH in fault.getMessage()


# ---- the pieces ------------------------------------------------------------------------------
def test_control_and_length_checks():
    go = CTRL_GO | CTRL_NO_GESTURE
    assert control_fault(go, stream=False, just_set=True) is None
    assert control_fault(go | CTRL_STREAM, stream=True, just_set=False) is None
    assert "bits 0x40 set" in control_fault(go | 0x40, stream=False, just_set=False)
    assert "bits 0x8 set" in control_fault(go | 0x8, stream=False, just_set=False)  # FIFO_CLR
    assert "another program" in control_fault(0, stream=False, just_set=False)
    assert "STREAM reads 1" in control_fault(go | CTRL_STREAM, stream=False, just_set=False)
    assert "STREAM reads 0" in control_fault(go, stream=True, just_set=True)
    assert lengths_fault(FIFO_DEPTH, FIFO_DEPTH) is None and lengths_fault(0, 3) is None
    assert "Longitud_Y exceeds" in lengths_fault(2, FIFO_DEPTH + 1)
    assert " exceed FIFO_DEPTH" in lengths_fault(FIFO_DEPTH + 1, FIFO_DEPTH + 1)


def test_describe_bus_names_the_device_and_window(tmp_path):
    path = tmp_path / "mem"
    path.write_bytes(bytes(0x3000))
    with DevMemBus(base=0x1000, offset=0x100, span=0x1000, path=str(path)) as bus:
        assert describe_bus(bus, 0x20) == (f"{path} window 0x00001100-0x000020ff (slave at "
                                           "0x00001120)")
    assert describe_bus(SimBus()) == "the simulated bus (slave at offset 0x0)"


def test_watch_and_filter_validate_and_count():
    clock = SimulatedClock()
    with pytest.raises(ValueError, match=r"max_fault_interval must be in \(0, 60\]"):
        BusFaultWatch(label="x", where="y", read_id=lambda: 0, poll_interval=POLL,
                      max_interval=0)
    repeats = RepeatFilter(10.0, clock)
    assert repeats.admit("a") == 0 and repeats.admit("a") is None
    assert repeats.admit("b") == 1                     # a new line: one copy left out before
    clock.sleep(10.0)
    assert repeats.admit("b") == 0

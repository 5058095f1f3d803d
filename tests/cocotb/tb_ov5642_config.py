"""cocotb testbench of :class:`soc.ov5642_config.Ov5642Config` (thesis §5.1).

Runs on the wrapper ``ov5642_tb`` of ``tests/test_soc_ov5642_config.py``: the
emitted ``ov5642_config`` plus an open-drain bus, ``scl = ~scl_oe & t_scl_o``
and ``sda = ~sda_oe & t_sda_o`` (wired AND of master and target), fed back to
``scl_i`` / ``sda_i``. The target is cocotbext-i2c's ``I2cDevice`` at 7-bit
address 0x3C with a recorder of transactions and an optional NACK plan, and it
behaves as the OV5642's power-up sequence says: it does not answer its address
while PWDN is high or RESETB low, nor until its settling time has passed since
RESETB rose. A bus monitor time-stamps every SCL/SDA edge for the timing
checks (:func:`analyse`).

Environment: ``OV5642_CLK_NS`` is the clock period matching the design's
``clk_freq`` (default 20 ns = 50 MHz), so every time below is real time;
``OV5642_MAX_RETRIES`` is the design's ``max_retries``; ``OV5642_POWER_MS``
the design's power-up and retry waits (JSON of
:func:`sim.model.ov5642_config.power_up_timing`'s ``*_ms`` arguments; missing
ones at their defaults); ``OV5642_SENSOR_SETTLE_MS`` the sensor's settling
time (default: the datasheet's 20 ms); ``OV5642_REPORT`` (optional) is a JSON
file the tests write their measurements to.
"""
from __future__ import annotations

import json
import os
import sys
from pathlib import Path

import cocotb
from cocotb.clock import Clock
from cocotb.triggers import ClockCycles, First, RisingEdge, Timer
from cocotb.utils import get_sim_time
from cocotbext.i2c import I2cDevice

ROOT = Path(__file__).resolve().parents[2]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

#: Fast-mode limits (NXP UM10204 Table 10), in picoseconds (the sim step).
SPEC_PS = {"t_low": 1_300_000, "t_high": 600_000, "t_hd_sta": 600_000, "t_su_sta": 600_000,
           "t_su_sto": 600_000, "t_buf": 1_300_000, "t_su_dat": 100_000}
F_SCL_MAX = 400e3
#: Clock period of the design under test (its clk_freq), ns.
CLK_PERIOD_NS = float(os.environ.get("OV5642_CLK_NS", "20"))
TARGET_ADDRESS = 0x3C
BYTE_INDEX = {"hi": 0, "lo": 1, "value": 2}
MAX_RETRIES = int(os.environ.get("OV5642_MAX_RETRIES", "3"))
POWER_MS = json.loads(os.environ.get("OV5642_POWER_MS", "{}"))
SENSOR_SETTLE_PS = round(float(os.environ.get("OV5642_SENSOR_SETTLE_MS", "20")) * 1e9)


def clk_ps() -> int:
    return round(CLK_PERIOD_NS * 1000)


def design_timing():
    """The design's I2C and power-up cycle counts (the model's, as the design
    takes them)."""
    from sim.model.ov5642_config import i2c_timing, power_up_timing
    clk_freq = 1e9 / CLK_PERIOD_NS
    timing = i2c_timing(clk_freq, F_SCL_MAX)
    return timing, power_up_timing(clk_freq, **POWER_MS, buf=timing.buf)


def expected_rows():
    """The vendored table as (address, value) pairs."""
    from soc.ov5642_config import load_ov5642_table
    return [(r.address, r.value) for r in load_ov5642_table()]


# --------------------------------------------------------------------------- bus analysis

def analyse(events):
    """Timing of a two-wire waveform.

    Parameters
    ----------
    events : list of (time_ps, "scl" | "sda", level)
        Every edge of the bus lines, both lines start high (idle).

    Returns
    -------
    dict
        ``starts`` / ``stops`` (times), ``repeated_starts``, ``violations``
        (SDA moving together with a rising SCL edge; a STOP that is not after
        whole bytes, i.e. an SDA change while SCL is high in the middle of a
        byte, or without a START), the minimum of each timing figure in ps (``t_low``,
        ``t_high``, ``t_hd_sta``, ``t_su_sta``, ``t_su_sto``, ``t_buf``,
        ``t_su_dat``, ``t_hd_dat`` = master data hold (changes after the SCL
        fall), ``period``) and ``f_scl_hz`` (1 / shortest rise-to-rise period),
        plus ``gaps`` (STOP to next START, ps, in order).
    """
    by_time = {}
    for t, name, level in events:
        by_time.setdefault(t, []).append((name, level))
    scl = sda = 1
    last_rise = last_fall = None
    pending_data = []           # SDA changes in this low phase, waiting for the SCL rise
    starts, stops, violations = [], [], []
    open_start = False
    mins = {k: None for k in ("t_low", "t_high", "t_hd_sta", "t_su_sta", "t_su_sto", "t_buf",
                              "t_su_dat", "t_hd_dat", "period")}
    repeated = 0
    last_start = None
    clocks = 0                  # SCL rises since the last START

    def note(key, value):
        if mins[key] is None or value < mins[key]:
            mins[key] = value

    for t in sorted(by_time):
        changes = dict(by_time[t])      # last level per line at this instant
        new_scl = changes.get("scl", scl)
        new_sda = changes.get("sda", sda)
        scl_rises = new_scl == 1 and scl == 0
        scl_falls = new_scl == 0 and scl == 1
        sda_moves = new_sda != sda
        if sda_moves:
            if scl_falls or (scl == 0 and new_scl == 0):
                # data change while low (coincident with a fall: the target's zero hold)
                pending_data.append(t)
                if not scl_falls and last_fall is not None:
                    note("t_hd_dat", t - last_fall)
            elif scl_rises:
                violations.append((t, "SDA changes with the SCL rising edge"))
            elif new_sda == 0:                      # START (SCL high, SDA falls)
                if open_start:
                    repeated += 1
                if last_rise is not None:
                    note("t_su_sta", t - last_rise)
                if stops:
                    note("t_buf", t - stops[-1])
                starts.append(t)
                open_start = True
                last_start = t
                clocks = 0
            else:                                   # STOP (SCL high, SDA rises)
                if last_rise is not None:
                    note("t_su_sto", t - last_rise)
                # whole bytes (8 bits + ACK) and the STOP's own clock
                if not open_start or clocks < 10 or (clocks - 1) % 9:
                    violations.append((t, f"STOP after {clocks} SCL clocks"
                                          + ("" if open_start else " without a START")))
                stops.append(t)
                open_start = False
        if scl_rises:
            clocks += 1
            if last_fall is not None:
                note("t_low", t - last_fall)
            if last_rise is not None:
                note("period", t - last_rise)
            for d in pending_data:
                note("t_su_dat", t - d)
            pending_data = []
            last_rise = t
        if scl_falls:
            if last_rise is not None:
                note("t_high", t - last_rise)
            if last_start is not None and (last_fall is None or last_fall < last_start):
                note("t_hd_sta", t - last_start)
            last_fall = t
        scl, sda = new_scl, new_sda
    gaps = []                   # every STOP paired with the first START after it
    j = 0
    for s in stops:
        while j < len(starts) and starts[j] <= s:
            j += 1
        if j < len(starts):
            gaps.append(starts[j] - s)
    out = dict(mins)
    out.update(starts=starts, stops=stops, repeated_starts=repeated, violations=violations,
               gaps=gaps, f_scl_hz=(1e12 / mins["period"]) if mins["period"] else None)
    return out


def check_timing(result):
    """Assertion messages for every fast-mode limit the waveform breaks."""
    bad = []
    if result["violations"]:
        bad.append(f"{len(result['violations'])} SDA changes while SCL high: "
                   f"{result['violations'][:3]}")
    for key, limit in SPEC_PS.items():
        if result[key] is not None and result[key] < limit:
            bad.append(f"{key} = {result[key]} ps < {limit} ps")
    if result["f_scl_hz"] is not None and result["f_scl_hz"] > F_SCL_MAX * (1 + 1e-9):
        bad.append(f"f_SCL = {result['f_scl_hz']:.1f} Hz > 400 kHz")
    return bad


# --------------------------------------------------------------------------- bench parts

class BusMonitor:
    """Time stamps of every SCL and SDA edge (one coroutine per line, so
    simultaneous edges are both seen)."""

    def __init__(self, dut):
        self.events = []
        self._tasks = [cocotb.start_soon(self._watch(dut.scl, "scl")),
                       cocotb.start_soon(self._watch(dut.sda, "sda"))]

    async def _watch(self, signal, name):
        while True:
            await signal.value_change
            self.events.append((get_sim_time("step"), name, int(signal.value)))

    def stop(self):
        for task in self._tasks:
            task.cancel()


class RecordingTarget(I2cDevice):
    """I2C target that records each transaction and can refuse bytes, powered
    as an OV5642.

    ``nack_plan`` maps a row number (count of completed, ACKed writes so far)
    to a list of bytes to NACK on its consecutive attempts: ``"addr"`` (the
    control byte: the target does not answer), ``"hi"``, ``"lo"`` or ``"value"``.

    Power (:data:`sim.model.ov5642_config.OV5642_POWER_UP_MS`): the target
    does not answer its address (an attempt refused as ``"asleep"``) while
    PWDN is high or RESETB low, nor before ``settle_ps`` have passed since
    RESETB rose with PWDN low.
    ``pins`` records every edge of PWDN and RESETB as (time_ps, name, level).
    """

    def __init__(self, dut, address=TARGET_ADDRESS, nack_plan=None,
                 settle_ps=SENSOR_SETTLE_PS):
        super().__init__(sda=dut.sda, sda_o=dut.t_sda_o, scl=dut.scl, scl_o=dut.t_scl_o)
        self.addr = address
        self.own_address = address
        self.nack_plan = dict(nack_plan or {})
        self.settle_ps = settle_ps
        self.log.setLevel("WARNING")
        self.transactions = []      # dicts: row, bytes, nack ('addr'/'asleep'/'hi'/..), end, t
        self.ok = []                # (address, value) of completed writes
        self.cur = None
        self._nack_byte = None
        self._failed = {}
        self.pins = []
        self._pin_tasks = [cocotb.start_soon(self._watch(dut.pwdn, "pwdn")),
                           cocotb.start_soon(self._watch(dut.reset_n, "reset_n"))]
        self._dut = dut

    async def _watch(self, signal, name):
        while True:
            await signal.value_change
            self.pins.append((get_sim_time("step"), name, int(signal.value)))

    def awake(self, now) -> bool:
        """The sensor answers on SCCB at ``now`` (ps)."""
        if int(self._dut.pwdn.value) or not int(self._dut.reset_n.value):
            return False
        # RESETB falls at every power-up: its last rise began this one
        rises = [t for t, name, level in self.pins if name == "reset_n" and level == 1]
        return now - (rises[-1] if rises else 0) >= self.settle_ps

    def _close(self, end):
        if self.cur is not None:
            self.cur["end"] = end
            if self.cur["nack"] is None and end == "stop" and len(self.cur["bytes"]) == 3:
                b = self.cur["bytes"]
                self.ok.append(((b[0] << 8) | b[1], b[2]))
            elif self.cur["nack"] not in (None, "asleep"):
                self._failed[self.cur["row"]] = self._failed.get(self.cur["row"], 0) + 1
            self.transactions.append(self.cur)
            self.cur = None

    def handle_start(self):
        # the device does not see the STOP after its own address NACK
        refused = self.cur and self.cur["nack"] in ("addr", "asleep")
        self._close("after address NACK" if refused else "start")
        now = get_sim_time("step")
        row = len(self.ok)
        plan = self.nack_plan.get(row, [])
        attempt = self._failed.get(row, 0)
        kind = plan[attempt] if attempt < len(plan) else None
        if not self.awake(now):
            kind = "asleep"
        self.addr = (self.own_address ^ 1) if kind in ("addr", "asleep") else self.own_address
        self._nack_byte = BYTE_INDEX.get(kind)
        self.cur = {"row": row, "bytes": [],
                    "nack": kind if kind in ("addr", "asleep") else None, "end": None, "t": now}

    async def handle_write(self, data):
        self.cur["bytes"].append(data)

    def handle_stop(self):
        self._close("stop")

    async def _recv_byte_ack(self, ack):
        # the only hook where the device chooses a data byte's ACK bit
        if self.cur is not None and self._nack_byte == len(self.cur["bytes"]):
            ack = 1
            self.cur["nack"] = next(k for k, v in BYTE_INDEX.items() if v == self._nack_byte)
            self._nack_byte = None
        return await super()._recv_byte_ack(ack)


async def setup(dut, **target_kw):
    """Clock, reset, target and monitor; the design auto-starts after reset
    (``target.released``: the time reset was released, ps)."""
    dut.start.value = 0
    Clock(dut.clk, CLK_PERIOD_NS, unit="ns").start()
    target = RecordingTarget(dut, **target_kw)
    monitor = BusMonitor(dut)
    dut.rst.value = 1
    await ClockCycles(dut.clk, 4)
    dut.rst.value = 0
    target.released = get_sim_time("step")
    return target, monitor


def expected_schedule(target, *, ready: bool = True):
    """The model's power-up and first-row schedule for this design and this
    target (``ready=False``: a target that never answers)."""
    from sim.model.ov5642_config import first_row_schedule
    timing, power = design_timing()
    settle = -(-target.settle_ps // clk_ps())        # whole cycles, rounded up
    never = 1 << 62
    # the model counts from the first cycle out of reset; ready is relative to RESETB
    start_to_reset = power.pwdn + power.reset
    return first_row_schedule(timing, power, max_retries=MAX_RETRIES,
                              ready=start_to_reset + settle if ready else never)


def check_power_up(target, monitor, schedule, *, restarted_after=None):
    """The power-up of the waveform against the model's ``schedule``, edge for
    edge: PWDN falls, RESETB rises and each attempt of row 0 STARTs as many
    clock cycles after the previous edge as the model says. The sequence
    begins at the reset's release (PWDN's fall within 2 cycles of the model:
    the reset's own synchronisation) or, with ``restarted_after`` (ps), where
    PWDN rises again after that time (exactly). Returns the measured waits, ms."""
    cyc = clk_ps()
    if restarted_after is None:
        since, slack = target.released, 2 * cyc
    else:
        since = next(t for t, name, level in target.pins
                     if name == "pwdn" and level == 1 and t > restarted_after)
        slack = 0
    falls = [t for t, name, level in target.pins if name == "pwdn" and level == 0 and t > since]
    rises = [t for t, name, level in target.pins
             if name == "reset_n" and level == 1 and t > since]
    assert falls and rises, f"no power-up after {since} ps: {target.pins}"
    pwdn_fall, reset_rise = falls[0], rises[0]
    assert abs(pwdn_fall - since - schedule.pwdn_fall * cyc) <= slack, \
        (pwdn_fall - since, schedule.pwdn_fall * cyc)
    assert reset_rise - pwdn_fall == (schedule.reset_rise - schedule.pwdn_fall) * cyc
    starts = [t for t in analyse(monitor.events)["starts"] if t > since]
    want = [reset_rise + (s - schedule.reset_rise) * cyc for s in schedule.starts]
    assert starts[:len(want)] == want, (starts[:len(want)], want)
    return {"pwdn_ms": (pwdn_fall - since) / 1e9, "reset_ms": (reset_rise - pwdn_fall) / 1e9,
            "settle_ms": (starts[0] - reset_rise) / 1e9,
            "retry_starts_ms": [(t - reset_rise) / 1e9 for t in starts[:len(want)]]}


async def rising_times(signal, times):
    """Append the time (ps) of every rising edge of ``signal`` to ``times``."""
    while True:
        await RisingEdge(signal)
        times.append(get_sim_time("step"))


async def wait_finished(dut, timeout_ms):
    await First(RisingEdge(dut.done), RisingEdge(dut.error), Timer(timeout_ms, unit="ms"))
    await ClockCycles(dut.clk, 2)


def report(key, value):
    path = os.environ.get("OV5642_REPORT")
    if not path:
        return
    p = Path(path)
    data = json.loads(p.read_text()) if p.exists() else {}
    data[key] = value
    p.write_text(json.dumps(data, indent=1))


def timing_summary(result):
    keys = ("t_low", "t_high", "t_hd_sta", "t_su_sta", "t_su_sto", "t_buf", "t_su_dat",
            "t_hd_dat", "period")
    out = {k: (result[k] / 1e6 if result[k] is not None else None) for k in keys}   # us
    out["f_scl_khz"] = result["f_scl_hz"] / 1e3 if result["f_scl_hz"] else None
    out["starts"] = len(result["starts"])
    out["stops"] = len(result["stops"])
    out["repeated_starts"] = result["repeated_starts"]
    return out


def check_complete_run(dut, target, monitor, rows, t0):
    """After a run to the end: done, every row once in order (refused attempts
    aside), the 300 ms pause after the 0x302b row with a delay, the retry
    spacing after each refused attempt and only t_BUF after the others,
    fast-mode timing. Returns the measurements."""
    t_end = get_sim_time("step")
    assert int(dut.done.value) == 1 and int(dut.error.value) == 0, \
        f"done={dut.done.value} error={dut.error.value} after {len(target.ok)} rows"
    assert int(dut.busy.value) == 0
    assert len(target.ok) == len(rows), f"{len(target.ok)} writes arrived, expected {len(rows)}"
    for i, (got, want) in enumerate(zip(target.ok, rows)):
        assert got == want, f"row {i}: got {got[0]:#06x}={got[1]:#04x}, " \
                            f"expected {want[0]:#06x}={want[1]:#04x}"
    trs = target.transactions
    assert all(t["end"] in ("stop", "after address NACK") for t in trs)
    result = analyse(monitor.events)
    bad = check_timing(result)
    assert not bad, "; ".join(bad)
    # STOP after every transaction, refused or not: no repeated START
    assert result["repeated_starts"] == 0
    assert len(result["starts"]) == len(result["stops"]) == len(trs), \
        (len(result["starts"]), len(result["stops"]), len(trs))
    gaps = result["gaps"]
    assert len(gaps) == len(trs) - 1
    delay_row = 489     # row 490 of the CSV: 0x302b = 0x00, then 300 ms
    assert rows[delay_row][0] == 0x302b
    k = next(i for i, t in enumerate(trs) if t["row"] == delay_row and t["nack"] is None)
    pause = gaps[k]
    assert 300e9 <= pause < 300e9 + 10e6, f"pause after row {delay_row}: {pause / 1e9:.6f} ms"
    retry_ps = design_timing()[1].retry * clk_ps()
    retries = [g for i, g in enumerate(gaps) if trs[i]["nack"]]
    assert all(g == retry_ps for g in retries), (retries, retry_ps)
    others = [g for i, g in enumerate(gaps) if i != k and not trs[i]["nack"]]
    assert max(others) < 10e6, f"unexpected long gap of {max(others) / 1e9:.6f} ms"
    summary = timing_summary(result)
    summary.update(clk_ns=CLK_PERIOD_NS, pause_ms=pause / 1e9, sequence_ms=(t_end - t0) / 1e9,
                   edges=len(monitor.events))
    dut._log.info("timing: %s", summary)
    return result, summary


# --------------------------------------------------------------------------- tests

@cocotb.test()
async def test_full_sequence(dut):
    """All 988 writes in order, done = 1, the 300 ms pause after 0x302b,
    fast-mode timing of the whole waveform; no NACK."""
    rows = expected_rows()
    target, monitor = await setup(dut)
    t0 = get_sim_time("step")
    await wait_finished(dut, 700)
    monitor.stop()
    assert not any(t["nack"] for t in target.transactions)
    _, summary = check_complete_run(dut, target, monitor, rows, t0)
    summary["power_up"] = check_power_up(target, monitor, expected_schedule(target))
    report("full_sequence", summary)


@cocotb.test()
async def test_nack_retry(dut):
    """The whole sequence with row 500 NACKed on three consecutive attempts
    (register low byte, value byte, control byte): each refused attempt ends
    with STOP, the same row is written again from START after t_BUF, the
    fourth attempt succeeds (max_retries = 3); otherwise as
    test_full_sequence: all 988 rows once in order, done = 1, the pause, timing."""
    rows = expected_rows()
    plan = ["lo", "value", "addr"]
    target, monitor = await setup(dut, nack_plan={500: plan})
    t0 = get_sim_time("step")
    await wait_finished(dut, 700)
    monitor.stop()
    result, summary = check_complete_run(dut, target, monitor, rows, t0)
    schedule = expected_schedule(target)
    assert schedule.accepted == 0, "the datasheet's sensor takes the first attempt"
    summary["power_up"] = check_power_up(target, monitor, schedule)
    trs = target.transactions
    failed = [i for i, t in enumerate(trs) if t["nack"]]
    assert [trs[i]["nack"] for i in failed] == plan, [trs[i]["nack"] for i in failed]
    first = failed[0]
    assert failed == [first, first + 1, first + 2] and trs[first]["row"] == 500
    # refused attempts of the same row: the bytes up to the refused one
    # (none when the control byte is refused), then the full row
    hi, lo, value = rows[500][0] >> 8, rows[500][0] & 0xFF, rows[500][1]
    assert [trs[first + k]["bytes"] for k in range(4)] == \
        [[hi, lo], [hi, lo, value], [], [hi, lo, value]]
    assert trs[first + 3]["nack"] is None and trs[first + 3]["row"] == 500
    assert trs[first - 1]["row"] == 499 and trs[first + 4]["row"] == 501
    # the retries follow their STOPs after the retry spacing
    retry_gaps = [result["gaps"][first + k] for k in range(len(plan))]
    assert retry_gaps == [design_timing()[1].retry * clk_ps()] * len(plan), retry_gaps
    summary["retry_gaps_us"] = [g / 1e6 for g in retry_gaps]
    report("nack_retry", summary)
@cocotb.test()
async def test_never_ack(dut):
    """A target that never answers (wrong address): 1 + max_retries attempts of
    row 0, each ended by STOP, then error = 1, done = 0, bus released and quiet.
    A start edge clears error and runs the attempts again."""
    retries = MAX_RETRIES
    target, monitor = await setup(dut, address=TARGET_ADDRESS + 1)
    error_rose = []
    watch = cocotb.start_soon(rising_times(dut.error, error_rose))
    await wait_finished(dut, 200)
    assert int(dut.error.value) == 1 and int(dut.done.value) == 0
    # every attempt and the error when the model says, counted from RESETB
    schedule = expected_schedule(target, ready=False)
    power_up = check_power_up(target, monitor, schedule)
    assert len(schedule.starts) == retries + 1 and schedule.accepted is None
    reset_rise = next(t for t, name, level in target.pins if name == "reset_n" and level)
    error_at = reset_rise + (schedule.error_at - schedule.reset_rise) * clk_ps()
    assert error_rose == [error_at], (error_rose, error_at)
    watch.cancel()
    assert int(dut.busy.value) == 0 and int(dut.row.value) == 0
    assert int(dut.scl_oe.value) == 0 and int(dut.sda_oe.value) == 0
    n_events = len(monitor.events)
    await Timer(200, unit="us")
    assert len(monitor.events) == n_events, "bus activity after error"
    result = analyse(monitor.events)
    assert len(result["starts"]) == len(result["stops"]) == retries + 1, \
        (len(result["starts"]), len(result["stops"]))
    assert target.ok == []
    # start again: error clears at once, the same attempts follow
    dut.start.value = 1
    await ClockCycles(dut.clk, 5)
    dut.start.value = 0
    assert int(dut.busy.value) == 1 and int(dut.error.value) == 0
    assert int(dut.pwdn.value) == 1 and int(dut.reset_n.value) == 0, "start power-cycles"
    await wait_finished(dut, 200)
    assert int(dut.error.value) == 1
    monitor.stop()
    result = analyse(monitor.events)
    assert len(result["starts"]) == len(result["stops"]) == 2 * (retries + 1)
    bad = check_timing(result)
    assert not bad, "; ".join(bad)
    report("never_ack", {"attempts_per_start": retries + 1, "power_up": power_up,
                         "error_after_reset_ms": (error_at - reset_rise) / 1e9})


@cocotb.test()
async def test_restart_while_busy(dut):
    """A start edge in the middle of the sequence lets the current row finish,
    then the sequence begins again at row 0."""
    rows = expected_rows()
    target, monitor = await setup(dut)
    # pulse start while row 5 is on the bus (some of its bytes already sent)
    while len(target.ok) < 5 or target.cur is None or not target.cur["bytes"]:
        await Timer(5, unit="us")
    in_progress = int(dut.row.value)
    assert in_progress == 5
    pressed = get_sim_time("step")
    dut.start.value = 1
    await ClockCycles(dut.clk, 5)
    dut.start.value = 0
    while len(target.ok) < 14:
        await Timer(20, unit="us")
    monitor.stop()
    # the current row ends, then the camera is powered up again as after reset
    check_power_up(target, monitor, expected_schedule(target), restarted_after=pressed)
    rows_done = [t["t"] for t in target.transactions if t["row"] == in_progress]
    assert all(t < pressed for t in rows_done)
    ok = target.ok
    assert ok[:in_progress + 1] == rows[:in_progress + 1]
    assert ok[in_progress + 1:] == rows[:len(ok) - in_progress - 1], \
        f"after the restart: {ok[in_progress + 1:]}"
    assert not any(t["nack"] for t in target.transactions)
    assert all(t["end"] == "stop" for t in target.transactions), "a row was cut short"
    assert int(dut.busy.value) == 1 and int(dut.done.value) == 0
    bad = check_timing(analyse(monitor.events))
    assert not bad, "; ".join(bad)


@cocotb.test()
async def test_slow_sensor(dut):
    """A sensor that needs 45 ms after RESETB rises (more than twice the
    datasheet's 20 ms): the first attempts are refused at its address, the
    master retries ``retry_ms`` apart, and the attempt the model says is
    ACKed; the rows follow in order."""
    rows = expected_rows()
    target, monitor = await setup(dut, settle_ps=45 * 10**9)
    while len(target.ok) < 3:
        await Timer(100, unit="us")
        assert int(dut.error.value) == 0, "gave up on a slow sensor"
    monitor.stop()
    schedule = expected_schedule(target)
    assert schedule.accepted is not None and schedule.accepted >= 1, schedule
    measured = check_power_up(target, monitor, schedule)
    trs = target.transactions
    assert [t["nack"] for t in trs[:schedule.accepted + 1]] == \
        ["asleep"] * schedule.accepted + [None]
    assert target.ok == rows[:len(target.ok)]
    bad = check_timing(analyse(monitor.events))
    assert not bad, "; ".join(bad)
    report("slow_sensor", {"refused": schedule.accepted, **measured})


@cocotb.test()
async def test_early_writes_refused(dut):
    """A design without the power-up waits (``OV5642_POWER_MS`` at 0 ms and
    retries t_BUF apart, as the master was before it had them): the datasheet's
    sensor refuses every attempt, and the master ends with ``error``."""
    target, monitor = await setup(dut)
    await wait_finished(dut, 5)
    monitor.stop()
    assert int(dut.error.value) == 1 and int(dut.done.value) == 0
    trs = target.transactions + ([target.cur] if target.cur else [])
    assert target.ok == [] and len(trs) == MAX_RETRIES + 1
    assert all(t["nack"] == "asleep" for t in trs), trs
    report("early_writes", {"attempts": len(trs),
                            "error_after_reset_us": (get_sim_time("step") - target.released) / 1e6})

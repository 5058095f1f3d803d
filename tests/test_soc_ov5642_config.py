# amaranth: UnusedElaboratable=no
"""Ov5642Config (thesis §5.1): the register table loader, parameter checks, the
emitted ports, the power-up and retry schedule against the model
(``sim.model.ov5642_config``) in Amaranth's simulator, and the cocotb testbench
``tests/cocotb/tb_ov5642_config.py`` under Verilator with cocotbext-i2c's
target, powered as an OV5642, on an open-drain bus model (the power-up, all 988
writes, the 300 ms pause, NACK retry and give-up, a slow sensor, a master
without the power-up waits, restart, fast-mode timing).

The whole-table runs print their measured timing with ``-s``; the run of the
board configuration (50 MHz / 400 kHz, 21 M clock cycles) is opt-in:
``OV5642_FULL_50MHZ=1 pytest tests/test_soc_ov5642_config.py -k full_sequence -s``.
"""
from __future__ import annotations

import functools
import json
import os
import re
import sys
from pathlib import Path

import pytest
from amaranth.back import verilog
from amaranth.sim import Simulator

from verif.cocotb_run import run_cocotb
from sim.model.ov5642_config import OV5642_POWER_UP_MS, first_row_schedule
from soc.ov5642_config import (DEFAULT_TABLE, Ov5642Config, load_ov5642_table)

TB_DIR = Path(__file__).resolve().parent / "cocotb"
TB = "tb_ov5642_config"
DUT = "ov5642_config"
TOP = "ov5642_tb"
PORTS = {"clk", "rst", "start", "done", "error", "busy", "row", "pwdn", "reset_n",
         "scl_oe", "sda_oe", "scl_i", "sda_i"}
SHARED_CSV = Path("/work/shared/data/ov5642/vga_yuv422_30fps.csv")

#: Open-drain bus around the design: each line is the AND of the master's and
#: the target's drive (1 = released), fed back to the master.
WRAPPER = f"""
module {TOP}(input clk, input rst, input start, input t_scl_o, input t_sda_o,
             output scl, output sda, output done, output error, output busy,
             output [9:0] row, output scl_oe, output sda_oe, output pwdn,
             output reset_n);
  {DUT} dut(.clk(clk), .rst(rst), .start(start), .scl_i(scl), .sda_i(sda),
            .scl_oe(scl_oe), .sda_oe(sda_oe), .done(done), .error(error),
            .busy(busy), .row(row), .pwdn(pwdn), .reset_n(reset_n));
  assign scl = ~scl_oe & t_scl_o;
  assign sda = ~sda_oe & t_sda_o;
endmodule
"""


def emit(component) -> str:
    return verilog.convert(component, name=DUT, emit_src=False)


#: Clock of the long cocotb runs: the slowest clock that keeps 400 kHz fast-mode
#: timing (must exceed 4 MHz), simulated at its real period, so every time in
#: the waveform is real but the 300 ms pause costs 1.5 M cycles instead of 15 M.
SCALED_CLK = 5e6
FULL_50MHZ = os.environ.get("OV5642_FULL_50MHZ") == "1"


#: Power-up and retry waits of a master without them (one cycle each, retries
#: t_BUF apart): the bus timing of the master before it had the power-up.
NO_POWER_UP = (("pwdn_ms", 0), ("reset_ms", 0), ("settle_ms", 0), ("retry_ms", 0))


@functools.cache
def bench_verilog(clk_freq: float = 50e6, power=()) -> str:
    return emit(Ov5642Config(clk_freq=clk_freq, **dict(power))) + WRAPPER


def run_tb(testcase, tmp_path, clk_freq: float = 50e6, power=()):
    report = tmp_path / "report.json"
    run_cocotb(bench_verilog(clk_freq, power), TOP, TB, TB_DIR, testcase=testcase,
               extra_env={"OV5642_REPORT": report, "OV5642_MAX_RETRIES": 3,
                          "OV5642_CLK_NS": 1e9 / clk_freq,
                          "OV5642_POWER_MS": json.dumps(dict(power))})
    return json.loads(report.read_text()) if report.exists() else {}


# --------------------------------------------------------------------------- table

def test_vendored_table():
    rows = load_ov5642_table()
    assert len(rows) == 988
    delayed = [(i, r) for i, r in enumerate(rows) if r.delay_ms]
    assert delayed == [(489, (0x302B, 0x00, 300))]
    assert rows[0] == (0x3103, 0x93, 0) and rows[1] == (0x3008, 0x82, 0)
    assert all(0 <= r.address <= 0xFFFF and 0 <= r.value <= 0xFF for r in rows)
    if SHARED_CSV.exists():
        assert DEFAULT_TABLE.read_bytes() == SHARED_CSV.read_bytes()


def _csv(tmp_path, text):
    path = tmp_path / "t.csv"
    path.write_text(text)
    return path


@pytest.mark.parametrize("text, match", [
    ("addr,delay_ms\n0x3103,0\n", r"t\.csv: missing column\(s\) value"),
    ("addr,value,delay_ms\n0x3103,0x93,0\n0x3008,0x100,0\n",
     r"t\.csv: row 2 \(line 3\): field 'value': 0x100 is out of range \[0x0, 0xff\]"),
    ("addr,value,delay_ms\n0x13103,0x93,0\n", r"row 1 \(line 2\): field 'addr': 0x13103"),
    ("addr,value,delay_ms\n0x3103,zz,0\n", r"row 1 \(line 2\): field 'value': 'zz' is not an"),
    ("addr,value,delay_ms\n0x3103,0x93\n", r"row 1 \(line 2\): field 'delay_ms' is missing"),
    ("addr,value,delay_ms\n0x3103,0x93,-1\n", r"field 'delay_ms': -1 is out of range \[0, 10000\]"),
    ("addr,value,delay_ms,mask\n0x3103,0x93,0,0x0f\n", r"field 'mask': 0xf is not 0"),
    ("addr,value,delay_ms\n", r"must hold 1 to 1024 rows, got 0"),
])
def test_loader_rejects_bad_csv(tmp_path, text, match):
    with pytest.raises(ValueError, match=match):
        load_ov5642_table(_csv(tmp_path, text))


def test_loader_accepts_decimal_and_extra_columns(tmp_path):
    rows = load_ov5642_table(_csv(tmp_path, "table,addr,value,delay_ms\nx,12291,255,5\n"))
    assert rows == [(0x3003, 0xFF, 5)]


# --------------------------------------------------------------------------- parameters

@pytest.mark.parametrize("kwargs, match", [
    ({"scl_freq": 0}, r"scl_freq must be a number in \(0, 400000\] Hz"),
    ({"scl_freq": 400_001}, r"scl_freq must be a number in \(0, 400000\]"),
    ({"scl_freq": "fast"}, r"scl_freq must be a number"),
    ({"clk_freq": 0.5e6}, r"clk_freq must be a number in \[1e\+06, 1e\+09\] Hz"),
    ({"clk_freq": 4e6}, r"clk_freq=4e\+06 Hz is too low for scl_freq=400000 Hz"),
    ({"device_address": 0x79}, r"device_address must be an even 8-bit write address"),
    ({"device_address": 0x100}, r"device_address must be .* \[0x10, 0xEE\]"),
    ({"max_retries": -1}, r"max_retries must be an integer in \[0, 255\]"),
    ({"max_retries": 1.5}, r"max_retries must be an integer"),
    ({"auto_start": 1}, r"auto_start must be True or False"),
    ({"pwdn_ms": -1}, r"pwdn_ms must be a number in \[0, 1000\] ms"),
    ({"reset_ms": 1001}, r"reset_ms must be a number in \[0, 1000\] ms"),
    ({"settle_ms": "20"}, r"settle_ms must be a number"),
    ({"retry_ms": float("nan")}, r"retry_ms must be a number in \[0, 1000\] ms"),
    ({"table": []}, r"table: must hold 1 to 1024 rows, got 0"),
    ({"table": [(0x3103, 0x93, 0)] * 1025}, r"got 1025"),
    ({"table": [(0x3103, 0x93)]}, r"table: row 1: expected \(address, value, delay_ms\)"),
    ({"table": [(0x3103, 0x93, 0), (0x3103, 256, 0)]},
     r"table: row 2: field 'value': 0x100 is out of range"),
])
def test_parameter_validation(kwargs, match):
    with pytest.raises(ValueError, match=match):
        Ov5642Config(**kwargs)


def test_emitted_ports_and_rom():
    text = bench_verilog()
    header = re.search(rf"module {DUT}\((.*?)\);", text, re.S).group(1)
    assert {p.strip() for p in header.split(",")} == PORTS
    assert re.search(r"output \[9:0\] row;", text)
    assert re.search(r"output pwdn;", text) and re.search(r"output reset_n;", text)
    # one 988-word ROM: 16-bit address, 8-bit value, 1-bit delay index
    assert re.search(r"reg \[24:0\] rom \[987:0\];", text)
    dut = Ov5642Config()
    assert dut.delay_cycles == [0, 15_000_000]


# --------------------------------------------------------------------------- Amaranth sim

def _small(**kw):
    return Ov5642Config(clk_freq=10e6, scl_freq=400e3,
                        table=[(0x1234, 0x56, 0), (0x9abc, 0xde, 1)],
                        **{**dict(NO_POWER_UP), **kw})


def test_auto_start_off_waits_for_start():
    """auto_start=False: bus released and busy=0 until a start edge."""
    dut = _small(auto_start=False)
    seen = {}

    async def bench(ctx):
        for _ in range(300):
            await ctx.tick()
            assert ctx.get(dut.busy) == 0
            assert ctx.get(dut.scl_oe) == 0 and ctx.get(dut.sda_oe) == 0
        ctx.set(dut.start, 1)
        for n in range(10):
            await ctx.tick()
            if ctx.get(dut.busy):
                seen["busy_after"] = n + 1
                break
        ctx.set(dut.start, 0)
        for n in range(200):
            await ctx.tick()
            if ctx.get(dut.sda_oe):
                seen["start_condition"] = True
                assert ctx.get(dut.scl_oe) == 0     # SDA falls while SCL is high
                break

    sim = Simulator(dut)
    sim.add_clock(1 / 10e6)
    sim.add_testbench(bench)
    sim.run()
    assert seen.get("busy_after", 99) <= 4 and seen.get("start_condition")


def test_clock_stretching_holds_the_high_phase():
    """While the target holds SCL low the master neither pulls SCL low again
    nor moves SDA; the high time is counted from the release."""
    dut = _small()
    t = dut.timing
    log = {}

    async def bench(ctx):
        async def step(stretch=False):
            await ctx.tick()
            # the line: low while the master or the stretching target pulls it
            ctx.set(dut.scl_i, not (ctx.get(dut.scl_oe) or stretch))

        while not ctx.get(dut.scl_oe):              # START, then SCL low
            await step()
        while ctx.get(dut.scl_oe):                  # first bit's low phase
            await step()
        ctx.set(dut.scl_i, 0)                       # the target holds SCL low
        sda = ctx.get(dut.sda_oe)
        for _ in range(500):
            await step(stretch=True)
            assert ctx.get(dut.scl_oe) == 0 and ctx.get(dut.sda_oe) == sda
        ctx.set(dut.scl_i, 1)
        n = 0
        while not ctx.get(dut.scl_oe):
            await step()
            n += 1
        log["high_after_release"] = n

    sim = Simulator(dut)
    sim.add_clock(1 / 10e6)
    sim.add_testbench(bench)
    sim.run()
    assert log["high_after_release"] == t.high + 2


def _run_constant_sda(dut, sda_level, cycles):
    """Run ``dut`` with SDA read as a constant (0: every ACK slot is an ACK,
    1: nobody answers) and SCL following the master; count START conditions
    and note when ``done`` / ``error`` rose."""
    log = {"starts": 0, "done_at": None, "error_at": None}

    async def bench(ctx):
        ctx.set(dut.sda_i, sda_level)
        prev_sda = 0
        for n in range(cycles):
            await ctx.tick()
            scl_oe, sda_oe = ctx.get(dut.scl_oe), ctx.get(dut.sda_oe)
            ctx.set(dut.scl_i, not scl_oe)
            if sda_oe and not prev_sda and not scl_oe:
                log["starts"] += 1
            prev_sda = sda_oe
            for key, port in (("done_at", dut.done), ("error_at", dut.error)):
                if log[key] is None and ctx.get(port):
                    log[key] = n + 1
            if log["done_at"] or log["error_at"]:
                break
        log["busy"] = ctx.get(dut.busy)
        log["row"] = ctx.get(dut.row)

    sim = Simulator(dut)
    sim.add_clock(1 / dut.clk_freq)
    sim.add_testbench(bench)
    sim.run()
    return log


def test_one_row_table_with_delay_runs_to_done():
    """Smallest table: one START, done only after the row's 1 ms delay."""
    dut = Ov5642Config(clk_freq=5e6, table=[(0x3008, 0x82, 1)], **dict(NO_POWER_UP))
    log = _run_constant_sda(dut, 0, 20_000)
    row_cycles = dut.timing.hd_sta + 37 * dut.timing.period
    assert log["starts"] == 1 and log["error_at"] is None and log["busy"] == 0
    assert 5_000 + row_cycles <= log["done_at"] <= 5_000 + row_cycles + 50


@pytest.mark.parametrize("max_retries", [0, 1, 3])
def test_attempts_before_error(max_retries):
    """Nobody answers: row 0 is attempted 1 + max_retries times, then error."""
    dut = Ov5642Config(clk_freq=5e6, table=[(0x1234, 0x56, 0)] * 3, max_retries=max_retries,
                       **dict(NO_POWER_UP))
    log = _run_constant_sda(dut, 1, 10_000)
    assert log["error_at"] is not None and log["done_at"] is None
    assert log["starts"] == 1 + max_retries and log["busy"] == 0 and log["row"] == 0


def _run_sensor(dut, ready, cycles, *, start_at=None):
    """Run ``dut`` against a sensor that ACKs every byte of an attempt whose
    START comes at or after cycle ``ready`` and refuses earlier ones at their
    address (SDA read high); SCL follows the master. Cycles count from reset,
    or from the ``start`` edge at ``start_at`` (auto_start off). Returns the
    first cycles of PWDN low and RESETB high, every START, and when ``error``
    or ``done`` rose."""
    log = {"pwdn_fall": None, "reset_rise": None, "starts": [], "error_at": None,
           "done_at": None, "pwdn_before": [], "reset_n_before": []}

    async def bench(ctx):
        ctx.set(dut.sda_i, 1)
        origin, prev_sda = 0, 0
        for n in range(1, cycles + 1):
            if start_at is not None and n == start_at:
                ctx.set(dut.start, 1)
            await ctx.tick()
            if start_at is not None and n == start_at + 1:
                ctx.set(dut.start, 0)
            scl_oe, sda_oe = ctx.get(dut.scl_oe), ctx.get(dut.sda_oe)
            ctx.set(dut.scl_i, not scl_oe)
            if start_at is not None and origin == 0:
                # the camera stays in power-down and reset until the master starts
                log["pwdn_before"].append(ctx.get(dut.pwdn))
                log["reset_n_before"].append(ctx.get(dut.reset_n))
                if ctx.get(dut.busy):
                    origin = n
                continue
            t = n - origin
            if log["pwdn_fall"] is None and not ctx.get(dut.pwdn):
                log["pwdn_fall"] = t
            if log["reset_rise"] is None and ctx.get(dut.reset_n):
                log["reset_rise"] = t
            if sda_oe and not prev_sda and not scl_oe:
                log["starts"].append(t)
                ctx.set(dut.sda_i, 0 if t >= ready else 1)
            prev_sda = sda_oe
            for key, port in (("error_at", dut.error), ("done_at", dut.done)):
                if log[key] is None and ctx.get(port):
                    log[key] = t
            if log["error_at"] or log["done_at"]:
                break

    sim = Simulator(dut)
    sim.add_clock(1 / dut.clk_freq)
    sim.add_testbench(bench)
    sim.run()
    return log


#: Short power-up waits at 5 MHz (50, 100, 150 cycles; retries 200 apart).
SHORT_POWER = dict(pwdn_ms=0.01, reset_ms=0.02, settle_ms=0.03, retry_ms=0.04)


@pytest.mark.parametrize("ready, accepted", [(0, 0), (400, 1), (900, 2), (10**9, None)])
def test_power_up_and_retries_follow_the_model(ready, accepted):
    """PWDN, RESETB, every START of row 0 and the error come on the cycles of
    ``first_row_schedule``, for a sensor ready at once, after one or two
    refusals, and never."""
    dut = Ov5642Config(clk_freq=5e6, table=[(0x1234, 0x56, 0)], max_retries=2, **SHORT_POWER)
    want = first_row_schedule(dut.timing, dut.power, max_retries=2, ready=ready)
    assert want.accepted == accepted
    log = _run_sensor(dut, ready, 5_000)
    assert (log["pwdn_fall"], log["reset_rise"]) == (want.pwdn_fall, want.reset_rise)
    assert tuple(log["starts"]) == want.starts
    assert log["error_at"] == want.error_at
    assert (log["done_at"] is None) == (accepted is None)


def test_start_powers_the_camera_up_from_idle():
    """auto_start off: the camera stays in power-down and reset until a start
    edge, then the power-up follows the model from the edge."""
    dut = Ov5642Config(clk_freq=5e6, table=[(0x1234, 0x56, 0)], auto_start=False,
                       **SHORT_POWER)
    want = first_row_schedule(dut.timing, dut.power, max_retries=3, ready=0)
    log = _run_sensor(dut, 0, 3_000, start_at=100)
    assert log["pwdn_before"] and set(log["pwdn_before"]) == {1}
    assert set(log["reset_n_before"]) == {0}
    assert (log["pwdn_fall"], log["reset_rise"]) == (want.pwdn_fall, want.reset_rise)
    assert tuple(log["starts"]) == want.starts and log["done_at"]


def test_default_power_up_meets_the_datasheet_minimums():
    """At the board's 50 MHz the defaults wait at least the datasheet's
    minimums, and a sensor 3x slower than the datasheet still gets configured."""
    dut = Ov5642Config()
    ms = {k: v * 1000 / 50e6 for k, v in dut.power._asdict().items()}
    assert ms["pwdn"] >= OV5642_POWER_UP_MS["pwdn"]
    assert ms["reset"] >= OV5642_POWER_UP_MS["reset"]
    assert ms["settle"] >= OV5642_POWER_UP_MS["settle"]
    reset_rise = dut.power.pwdn + dut.power.reset
    slow = first_row_schedule(dut.timing, dut.power, max_retries=dut.max_retries,
                              ready=reset_rise + 3 * round(OV5642_POWER_UP_MS["settle"] * 50e3))
    assert slow.accepted == 2


# --------------------------------------------------------------------------- cocotb

def _show(title, rep):
    print(f"\n{title}, measured (us unless noted):", json.dumps(rep, indent=1))


def test_sequence_with_nack_retry_cocotb(tmp_path):
    """The whole table at 5 MHz / 400 kHz with row 500 NACKed three times (low
    byte, value, control byte): each refused attempt ends with STOP and the
    row is rewritten from START after t_BUF; all 988 rows arrive once in order,
    done=1, error=0, the 300 ms pause after 0x302b, fast-mode timing."""
    rep = run_tb("test_nack_retry", tmp_path, SCALED_CLK)["nack_retry"]
    _show("Ov5642Config 5 MHz / 400 kHz, NACK at row 500", rep)
    assert len(rep["retry_gaps_us"]) == 3
    assert rep["f_scl_khz"] <= 400.0 + 1e-6 and rep["pause_ms"] >= 300.0


@pytest.mark.skipif(not FULL_50MHZ, reason="21 M clock cycles of simulation; "
                    "set OV5642_FULL_50MHZ=1")
def test_full_sequence_50mhz_cocotb(tmp_path):
    """The board configuration, 50 MHz / 400 kHz: the power-up as the model
    says, all 988 writes in order, done=1, the 300 ms pause after 0x302b,
    fast-mode timing; no NACK."""
    rep = run_tb("test_full_sequence", tmp_path)["full_sequence"]
    _show("Ov5642Config 50 MHz / 400 kHz", rep)
    assert rep["f_scl_khz"] <= 400.0 + 1e-6 and rep["pause_ms"] >= 300.0


def test_never_ack_and_restart_cocotb(tmp_path):
    """The board configuration (50 MHz): no ACK ever: 4 attempts, error=1; a
    start edge runs them again; a start edge mid-sequence restarts at row 0
    after the current row (fast-mode timing checked on both waveforms)."""
    run_tb(["test_never_ack", "test_restart_while_busy"], tmp_path)


def test_slow_sensor_cocotb(tmp_path):
    """A sensor that needs 45 ms after RESETB (5 MHz / 400 kHz): refused
    attempts, retries 20 ms apart, accepted where the model says; the power-up
    edges as the model says."""
    rep = run_tb("test_slow_sensor", tmp_path, SCALED_CLK)["slow_sensor"]
    _show("Ov5642Config 5 MHz, sensor settling 45 ms", rep)
    assert rep["refused"] == 2 and rep["settle_ms"] >= 20.0


def test_early_writes_refused_cocotb(tmp_path):
    """The master without its power-up waits meets the datasheet's sensor:
    every attempt refused, error (the sensor model does refuse early writes)."""
    rep = run_tb("test_early_writes_refused", tmp_path, SCALED_CLK,
                 NO_POWER_UP)["early_writes"]
    _show("Ov5642Config 5 MHz without power-up waits", rep)
    assert rep["attempts"] == 4


def test_timing_checker_catches_violations():
    """The waveform analysis of the testbench flags what it should (so the
    timing test can fail)."""
    sys.path.insert(0, str(TB_DIR))
    try:
        import tb_ov5642_config as tb
    finally:
        sys.path.remove(str(TB_DIR))
    us = 1_000_000

    def wave(low, high, hd_sta, su_dat, glitch=False):
        """START, one byte 0xA5 + ACK, STOP; ``glitch``: SDA pulses low while
        SCL is high in the middle of the byte."""
        low, high, hd_sta, su_dat = (round(x * us) for x in (low, high, hd_sta, su_dat))
        ev, t = [], 10 * us
        ev.append((t, "sda", 0))                    # START
        t += hd_sta
        ev.append((t, "scl", 0))
        for n, bit in enumerate([1, 0, 1, 0, 0, 1, 0, 1, 0] + [0]):     # 8 bits, ACK, STOP clock
            t += low - su_dat
            ev.append((t, "sda", bit))
            t += su_dat
            ev.append((t, "scl", 1))
            if glitch and n == 2:
                ev += [(t + high // 3, "sda", 0), (t + 2 * high // 3, "sda", 1)]
            t += high
            if n < 9:
                ev.append((t, "scl", 0))
        ev.append((t, "sda", 1))                    # STOP
        return ev

    def problems(*args, **kw):
        return " ".join(tb.check_timing(tb.analyse(wave(*args, **kw))))

    good = tb.analyse(wave(1.6, 0.9, 0.7, 0.5))
    assert tb.check_timing(good) == []
    assert len(good["starts"]) == 1 and len(good["stops"]) == 1
    assert good["t_low"] == 1_600_000 and good["t_su_sto"] == 900_000
    assert good["f_scl_hz"] == pytest.approx(400e3)
    assert "t_low" in problems(1.2, 1.3, 0.7, 0.5)
    assert "t_high" in problems(2.0, 0.5, 0.7, 0.5)
    assert "f_SCL" in problems(1.3, 0.6, 0.7, 0.5)
    assert "t_hd_sta" in problems(1.6, 0.9, 0.5, 0.5)
    assert "t_su_dat" in problems(1.6, 0.9, 0.7, 0.05)
    glitch = problems(1.6, 0.9, 0.7, 0.5, glitch=True)   # START + STOP inside the byte
    assert "SDA changes while SCL high" in glitch and "STOP after 0 SCL clocks" in glitch

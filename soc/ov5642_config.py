"""OV5642 camera configuration over I2C (thesis §5.1).

Each camera gets one :class:`Ov5642Config`: an I2C (SCCB) master that writes the
988-entry register table of ``data/ov5642/vga_yuv422_30fps.csv`` (640x480
YUV422 at 30 fps) to the sensor after reset or on ``start``. The table is held
in a ROM (block RAM); :func:`load_ov5642_table` reads and validates it.
"""
from __future__ import annotations

import csv
import math
import numbers
from pathlib import Path
from typing import NamedTuple

from amaranth.hdl import Cat, Const, Module, Mux, Signal
from amaranth.lib import data, enum, memory, wiring
from amaranth.lib.cdc import FFSynchronizer
from amaranth.lib.wiring import In, Out

from sim.model.ov5642_config import (FAST_MODE, OV5642_POWER_UP_MS, POWER_UP_MS_RANGE,
                                     RETRY_MS, SYNC_STAGES, I2cTiming, i2c_timing,
                                     power_up_timing)
from sim.model.validation import check_number

__all__ = [
    "Ov5642Config", "RegisterWrite", "load_ov5642_table", "I2cTiming", "i2c_timing",
    "DEFAULT_TABLE", "OV5642_WRITE_ADDRESS", "ROW_BITS", "MAX_ROWS",
    "SCL_FREQ_RANGE", "CLK_FREQ_RANGE", "MAX_RETRIES_RANGE", "DELAY_MS_RANGE",
    "FAST_MODE", "SYNC_STAGES", "OV5642_POWER_UP_MS", "POWER_UP_MS_RANGE", "RETRY_MS",
]

#: The vendored table (see ``data/ov5642/README.md``).
DEFAULT_TABLE = Path(__file__).resolve().parent.parent / "data" / "ov5642" / "vga_yuv422_30fps.csv"
#: Control byte of a write: 7-bit SCCB address 0x3C shifted left, R/W bit 0.
OV5642_WRITE_ADDRESS = 0x78
#: Width of the ``row`` port; the table may hold at most ``MAX_ROWS`` writes.
ROW_BITS = 10
MAX_ROWS = 1 << ROW_BITS
SCL_FREQ_RANGE = (0.0, 400e3)        # (exclusive, inclusive], Hz
CLK_FREQ_RANGE = (1e6, 1e9)          # inclusive, Hz
MAX_RETRIES_RANGE = (0, 255)
DELAY_MS_RANGE = (0, 10_000)
class RegisterWrite(NamedTuple):
    """One table row: write ``value`` to register ``address``, then wait ``delay_ms``."""
    address: int
    value: int
    delay_ms: int


_RANGES = {"addr": (0, 0xFFFF), "value": (0, 0xFF), "delay_ms": DELAY_MS_RANGE}


def _check_field(where: str, field: str, value) -> int:
    lo, hi = _RANGES[field]
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise ValueError(f"{where}: field {field!r} must be an integer, got {value!r}")
    if not lo <= value <= hi:
        shown = f"{value:#x}" if field != "delay_ms" else str(value)
        rng = f"[0x0, {hi:#x}]" if field != "delay_ms" else f"[{lo}, {hi}]"
        raise ValueError(f"{where}: field {field!r}: {shown} is out of range {rng}")
    return int(value)


def _check_table(table, source: str) -> list[RegisterWrite]:
    """Validate an in-memory table of (address, value, delay_ms) rows."""
    try:
        rows = list(table)
    except TypeError:
        raise ValueError(f"table must be a sequence of (address, value, delay_ms), "
                         f"got {table!r}") from None
    if not 1 <= len(rows) <= MAX_ROWS:
        raise ValueError(f"{source}: must hold 1 to {MAX_ROWS} rows, got {len(rows)}")
    out = []
    for i, row in enumerate(rows, 1):
        try:
            address, value, delay_ms = row
        except (TypeError, ValueError):
            raise ValueError(f"{source}: row {i}: expected (address, value, delay_ms), "
                             f"got {row!r}") from None
        where = f"{source}: row {i}"
        out.append(RegisterWrite(_check_field(where, "addr", address),
                                 _check_field(where, "value", value),
                                 _check_field(where, "delay_ms", delay_ms)))
    return out


def load_ov5642_table(path=None) -> list[RegisterWrite]:
    """Read an OV5642 register table CSV.

    Parameters
    ----------
    path : str or Path, optional
        CSV with the header columns ``addr`` (16-bit register address),
        ``value`` (8-bit) and ``delay_ms`` (sleep after the write, 0..10000);
        integers in decimal or ``0x`` hex. An optional ``mask`` column must be
        0 (plain writes; read-modify-write is not supported); other columns
        (``table``) are ignored. Default: :data:`DEFAULT_TABLE`.

    Returns
    -------
    list of RegisterWrite
        ``(address, value, delay_ms)`` rows in file order (rows are 1-based
        below, the header is line 1).

    Raises
    ------
    ValueError
        Naming the file, the row (and line) and the field of the first bad
        entry, or the missing columns.
    """
    path = Path(DEFAULT_TABLE if path is None else path)
    with open(path, newline="") as f:
        reader = csv.DictReader(f)
        columns = [c.strip() for c in (reader.fieldnames or [])]
        missing = [c for c in ("addr", "value", "delay_ms") if c not in columns]
        if missing:
            raise ValueError(f"{path}: missing column(s) {', '.join(missing)} "
                             f"(header has {columns})")
        reader.fieldnames = columns
        rows = []
        for i, rec in enumerate(reader, 1):
            where = f"{path}: row {i} (line {reader.line_num})"
            parsed = {}
            for field in ("addr", "value", "delay_ms") + (("mask",) if "mask" in columns else ()):
                text = rec.get(field)
                if text is None or not text.strip():
                    raise ValueError(f"{where}: field {field!r} is missing or empty")
                try:
                    parsed[field] = int(text.strip(), 0)
                except ValueError:
                    raise ValueError(f"{where}: field {field!r}: {text.strip()!r} is not an "
                                     f"integer (decimal or 0x hex)") from None
            if parsed.get("mask", 0) != 0:
                raise ValueError(f"{where}: field 'mask': {parsed['mask']:#x} is not 0 "
                                 f"(only plain writes are supported)")
            rows.append(RegisterWrite(*(_check_field(where, fld, parsed[fld])
                                        for fld in ("addr", "value", "delay_ms"))))
    if not 1 <= len(rows) <= MAX_ROWS:
        raise ValueError(f"{path}: must hold 1 to {MAX_ROWS} rows, got {len(rows)}")
    return rows


class _Phase(enum.Enum, shape=2):
    START = 0   # SDA low, SCL high: t_HD;STA
    HOLD = 1    # SCL low, SDA unchanged: t_HD;DAT
    SETUP = 2   # SCL low, SDA at the new bit: t_SU;DAT
    HIGH = 3    # SCL released: t_HIGH (or t_SU;STO before a STOP)


class _Ending(enum.Enum, shape=2):
    NEXT = 0    # another write follows the wait
    DONE = 1
    ERROR = 2


class Ov5642Config(wiring.Component):
    """Powers one OV5642 up and writes its register table over I2C (thesis §5.1).

    After reset, or on ``start``, the master runs the sensor's power-up
    sequence (figures and their sources in
    :data:`sim.model.ov5642_config.OV5642_POWER_UP_MS`): PWDN high and RESETB
    low for ``pwdn_ms``, PWDN low for ``reset_ms``, RESETB high, then
    ``settle_ms`` before the first write. Every table row is then one I2C
    write transaction: START, control byte ``device_address`` (0x78: 7-bit
    address 0x3C, write), register address high byte, low byte, value, STOP,
    with the ACK checked after every byte. A row with a delay (0x302b: 300 ms)
    is followed by that pause, counted in clock cycles of ``clk_freq``; every
    other STOP is followed by the bus-free time t_BUF. The table sits in a ROM
    (``lib.memory.Memory`` with ``init``, so it maps to block RAM: 988 words
    of 25 bits = register address, value and an index into the few distinct
    delays). The cycle counts come from :mod:`sim.model.ov5642_config`, whose
    :func:`~sim.model.ov5642_config.first_row_schedule` is the specification
    of the power-up and retry timing.

    The FSM has six states:

    * ``POWER_DOWN``, ``RESET``, ``SETTLE``: the power-up waits (PWDN and
      RESETB as above, I2C bus released).
    * ``IDLE``: bus released, waiting for a rising edge of ``start``; the
      camera stays powered (after ``done`` or ``error``) or, before the first
      start with ``auto_start=False``, held in power-down and reset.
    * ``WRITE``: the byte engine: START, the four bytes MSB first with an ACK
      slot each, STOP. It steps through bit phases (START hold, SCL-low hold,
      data setup, SCL high).
    * ``WAIT``: the pause after a row (t_BUF, the row's delay, or
      ``retry_ms`` after a refused attempt); at its end the next attempt is
      written, or the FSM goes to ``IDLE`` setting ``done`` or ``error``.

    Retry on NACK (the documented behaviour): when the ACK slot of any byte
    reads SDA high, the master sends STOP right after it (skipping the rest of
    the row), waits ``retry_ms`` and writes the *same row* again from START. A
    row is attempted at most ``1 + max_retries`` times in a row: if all those
    attempts are NACKed, ``error`` goes to 1 and the FSM stops in ``IDLE`` (bus
    released; ``row`` shows the failing row) until the next ``start``. An
    ACKed row resets the retry count. With the defaults (3 retries 20 ms
    apart) a sensor that answers up to 60 ms later than the datasheet's 20 ms
    is configured without an error.

    Start: with ``auto_start`` (the default) the sequence begins by itself
    after reset, so the cameras are powered up and configured at power-up;
    KEY[1] on the board drives ``start`` to power-cycle and configure them
    again. A rising edge of ``start`` in ``IDLE`` (after ``done`` or
    ``error``) clears both and begins the power-up sequence. A rising edge
    while writing is remembered: the current transaction and its pause
    finish (up to 300 ms after 0x302b), then the power-up sequence begins with
    row 0 and a fresh retry count. A rising edge during the power-up waits
    changes nothing (the sequence is already starting over). ``start`` passes
    a two-flip-flop synchroniser, so it may come straight from a debounced key.

    Parameters
    ----------
    clk_freq : float in [1e6, 1e9]
        Frequency of the ``sync`` domain in Hz (the board's 50 MHz ``config``
        domain). It must leave room in one SCL period for the fast-mode minimum
        low and high times (at 400 kHz: more than 4 MHz).
    scl_freq : float in (0, 400e3]
        Highest SCL frequency in Hz (fast mode at most). Stretching or slow rise
        only make SCL slower.
    table : sequence of (address, value, delay_ms), optional
        1 to 1024 rows (addresses 16 bit, values 8 bit, delays 0..10000 ms).
        Default: :func:`load_ov5642_table` of the vendored 988-row table.
    device_address : int
        8-bit write address (control byte): even, in [0x10, 0xEE] (7-bit
        0x08..0x77). OV5642: 0x78.
    max_retries : int in [0, 255]
        Extra attempts of a NACKed row before giving up (see above).
    auto_start : bool
        Start the sequence after reset without a ``start`` edge.
    pwdn_ms, reset_ms, settle_ms : float in [0, 1000]
        The power-up waits (above), each rounded up to whole cycles (at least
        one). Defaults: the datasheet minimums, 5, 1 and 20 ms.
    retry_ms : float in [0, 1000]
        STOP of a refused attempt to the next START (at least t_BUF). Default 20.

    Ports
    -----
    start : In(1)
        A rising edge (re)starts the sequence: power-up, then row 0.
    done : Out(1)
        All rows written and ACKed (after the last row's pause); held until
        the next start.
    error : Out(1)
        A row was NACKed ``1 + max_retries`` times in a row; held until the next
        start.
    busy : Out(1)
        Not in ``IDLE``.
    row : Out(10)
        Row being written or waited after (0-based), for debug; after
        ``done`` the last row, after ``error`` the refused row.
    pwdn : Out(1)
        The camera's PWDN pin (1: power down); 1 from reset until the first
        wait has passed.
    reset_n : Out(1)
        The camera's RESETB pin (0: reset); 0 from reset until the second wait
        has passed.
    scl_oe, sda_oe : Out(1)
        Open-drain drives: 1 pulls the line low, 0 releases it (the board top
        drives 0 with these enables; pull-ups make the high level).
    scl_i, sda_i : In(1)
        Line levels, re-timed by two flip-flops. ``sda_i`` is sampled at the
        end of each SCL high phase (ACK check). ``scl_i`` is used for clock
        stretching: the high time is counted only once SCL is seen high, so a
        target holding SCL low (or a slow rising edge) lengthens the period. A
        target that holds SCL low for ever keeps the master waiting (no time-out).

    ``done`` and ``error`` rise at the end of the last wait (t_BUF, the last
    row's delay, or ``retry_ms`` after the last refusal) after the final STOP.

    Timing (50 MHz, 400 kHz): period 125 cycles = 2.5 us (400 kHz with ideal
    edges; rise time and stretching only lengthen it); t_LOW = 79 cycles
    (1.58 us, SDA changes 15 cycles = 0.3 us after SCL falls), t_HIGH = 44 + 2
    cycles (0.92 us), t_HD;STA = 44 cycles, t_SU;STO = 46 cycles, t_BUF = 79
    cycles. One row takes 4748 cycles (95 us); the power-up takes 26 ms, the
    988 rows plus the 300 ms pause about 394 ms.
    """

    def __init__(self, clk_freq=50e6, scl_freq=400e3, table=None,
                 device_address=OV5642_WRITE_ADDRESS, max_retries=3, auto_start=True, *,
                 pwdn_ms=OV5642_POWER_UP_MS["pwdn"], reset_ms=OV5642_POWER_UP_MS["reset"],
                 settle_ms=OV5642_POWER_UP_MS["settle"], retry_ms=RETRY_MS):
        clk_freq = check_number("clk_freq", clk_freq, *CLK_FREQ_RANGE, unit="Hz")
        scl_freq = check_number("scl_freq", scl_freq, *SCL_FREQ_RANGE, unit="Hz", lo_open=True)
        if isinstance(device_address, bool) or not isinstance(device_address, numbers.Integral) \
                or not 0x10 <= device_address <= 0xEE or device_address % 2:
            raise ValueError(f"device_address must be an even 8-bit write address in "
                             f"[0x10, 0xEE] (7-bit 0x08..0x77), got {device_address!r}")
        if isinstance(max_retries, bool) or not isinstance(max_retries, numbers.Integral) \
                or not MAX_RETRIES_RANGE[0] <= max_retries <= MAX_RETRIES_RANGE[1]:
            raise ValueError(f"max_retries must be an integer in [{MAX_RETRIES_RANGE[0]}, "
                             f"{MAX_RETRIES_RANGE[1]}], got {max_retries!r}")
        if not isinstance(auto_start, bool):
            raise ValueError(f"auto_start must be True or False, got {auto_start!r}")
        self.timing = i2c_timing(clk_freq, scl_freq)
        self.power = power_up_timing(clk_freq, pwdn_ms=pwdn_ms, reset_ms=reset_ms,
                                     settle_ms=settle_ms, retry_ms=retry_ms,
                                     buf=self.timing.buf)
        rows = load_ov5642_table() if table is None else _check_table(table, "table")
        self.clk_freq = clk_freq
        self.scl_freq = scl_freq
        self.table = rows
        self.device_address = int(device_address)
        self.max_retries = int(max_retries)
        self.auto_start = auto_start
        #: Distinct delays in cycles; index 0 is "no delay" (t_BUF only).
        delays = sorted({r.delay_ms for r in rows if r.delay_ms})
        self._delay_index = {0: 0, **{ms: i for i, ms in enumerate(delays, 1)}}
        self.delay_cycles = [0] + [math.ceil(ms * clk_freq / 1000 - 1e-6) for ms in delays]
        super().__init__({
            "start": In(1),
            "done": Out(1),
            "error": Out(1),
            "busy": Out(1),
            "row": Out(ROW_BITS),
            "pwdn": Out(1, init=1),
            "reset_n": Out(1),
            "scl_oe": Out(1),
            "sda_oe": Out(1),
            "scl_i": In(1, init=1),
            "sda_i": In(1, init=1),
        })

    def elaborate(self, platform):
        m = Module()
        t = self.timing
        n_rows = len(self.table)

        word = data.StructLayout({
            "address": 16, "value": 8,
            "delay": range(len(self.delay_cycles)) if len(self.delay_cycles) > 1 else 1,
        })
        m.submodules.rom = rom = memory.Memory(shape=word, depth=n_rows, init=[
            {"address": r.address, "value": r.value, "delay": self._delay_index[r.delay_ms]}
            for r in self.table])
        rd = rom.read_port(domain="sync")
        entry = rd.data

        scl = Signal(init=1)
        sda = Signal(init=1)
        start = Signal()
        m.submodules.scl_sync = FFSynchronizer(self.scl_i, scl, init=1, stages=SYNC_STAGES)
        m.submodules.sda_sync = FFSynchronizer(self.sda_i, sda, init=1, stages=SYNC_STAGES)
        m.submodules.start_sync = FFSynchronizer(self.start, start, stages=SYNC_STAGES)
        start_prev = Signal()
        m.d.sync += start_prev.eq(start)
        start_edge = start & ~start_prev

        row = Signal(range(n_rows))
        m.d.comb += [rd.addr.eq(row), self.row.eq(row)]

        power = self.power
        wait_loads = [t.buf, power.retry] + [max(t.buf, c) for c in self.delay_cycles]
        timer = Signal(range(max(wait_loads + [t.hold, t.setup, t.high, t.hd_sta, power.pwdn,
                                               power.reset, power.settle])),
                       init=power.pwdn - 1 if self.auto_start else 0)
        phase = Signal(_Phase)
        shifter = Signal(32)            # control byte, address high, low, value; MSB first
        bit = Signal(range(9))          # 8 = the ACK slot
        last_byte = Signal()
        stopping = Signal()             # this bit slot sends STOP
        nacked = Signal()
        retries = Signal(range(self.max_retries + 1))
        restart = Signal()              # start edge while busy, served at the end of WAIT
        ending = Signal(_Ending)
        byte_count = Signal(2)

        scl_oe = Signal()
        sda_oe = Signal()
        done = Signal()
        error = Signal()
        pwdn = Signal(init=1)
        reset_n = Signal()
        m.d.comb += [self.scl_oe.eq(scl_oe), self.sda_oe.eq(sda_oe),
                     self.done.eq(done), self.error.eq(error),
                     self.pwdn.eq(pwdn), self.reset_n.eq(reset_n)]

        with m.If(start_edge):
            m.d.sync += restart.eq(1)

        def begin_write():
            m.d.sync += [sda_oe.eq(1), phase.eq(_Phase.START), timer.eq(t.hd_sta - 1)]
            m.next = "WRITE"

        def power_up():
            # the camera into power-down and reset, then the table from row 0
            m.d.sync += [restart.eq(0), done.eq(0), error.eq(0), row.eq(0), retries.eq(0),
                         ending.eq(_Ending.NEXT), pwdn.eq(1), reset_n.eq(0),
                         timer.eq(power.pwdn - 1)]
            m.next = "POWER_DOWN"

        def power_wait(then, *actions):
            with m.If(timer == 0):
                m.d.sync += actions
                then()
            with m.Else():
                m.d.sync += timer.eq(timer - 1)
            # a start edge now would only begin the same sequence again
            m.d.sync += restart.eq(0)

        def goto(state, timer_load):
            def then():
                m.d.sync += timer.eq(timer_load - 1)
                m.next = state
            return then

        with m.FSM(init="POWER_DOWN" if self.auto_start else "IDLE") as fsm:
            with m.State("POWER_DOWN"):
                power_wait(goto("RESET", power.reset), pwdn.eq(0))
            with m.State("RESET"):
                power_wait(goto("SETTLE", power.settle), reset_n.eq(1))
            with m.State("SETTLE"):
                power_wait(begin_write)

            with m.State("IDLE"):
                with m.If(restart | start_edge):
                    power_up()

            with m.State("WRITE"):
                with m.Switch(phase):
                    with m.Case(_Phase.START):
                        with m.If(timer == 0):
                            # the ROM word of `row` has been valid since WAIT
                            m.d.sync += [
                                scl_oe.eq(1),
                                shifter.eq(Cat(entry.value, entry.address[:8],
                                               entry.address[8:], Const(self.device_address, 8))),
                                bit.eq(0), byte_count.eq(0), last_byte.eq(0),
                                stopping.eq(0), nacked.eq(0),
                                phase.eq(_Phase.HOLD), timer.eq(t.hold - 1),
                            ]
                        with m.Else():
                            m.d.sync += timer.eq(timer - 1)
                    with m.Case(_Phase.HOLD):
                        with m.If(timer == 0):
                            # STOP needs SDA low under the coming SCL high; the ACK
                            # slot releases SDA for the target
                            m.d.sync += [
                                sda_oe.eq(Mux(stopping, 1, Mux(bit == 8, 0, ~shifter[31]))),
                                phase.eq(_Phase.SETUP), timer.eq(t.setup - 1),
                            ]
                        with m.Else():
                            m.d.sync += timer.eq(timer - 1)
                    with m.Case(_Phase.SETUP):
                        with m.If(timer == 0):
                            m.d.sync += [scl_oe.eq(0), phase.eq(_Phase.HIGH),
                                         timer.eq(t.high - 1)]
                        with m.Else():
                            m.d.sync += timer.eq(timer - 1)
                    with m.Case(_Phase.HIGH):
                        # count only once SCL is seen high: clock stretching
                        with m.If(scl & (timer != 0)):
                            m.d.sync += timer.eq(timer - 1)
                        with m.If(scl & (timer == 0)):
                            with m.If(stopping):
                                m.d.sync += sda_oe.eq(0)        # STOP
                                self._after_stop(m, t, entry, row, n_rows, retries, nacked,
                                                 ending, timer)
                                m.next = "WAIT"
                            with m.Else():
                                m.d.sync += [scl_oe.eq(1), phase.eq(_Phase.HOLD),
                                             timer.eq(t.hold - 1)]
                                with m.If(bit == 8):
                                    with m.If(sda | last_byte):   # NACK, or row complete
                                        m.d.sync += [stopping.eq(1), nacked.eq(sda)]
                                    with m.Else():
                                        m.d.sync += [bit.eq(0), byte_count.eq(byte_count + 1),
                                                     last_byte.eq(byte_count == 2)]
                                with m.Else():
                                    m.d.sync += [shifter.eq(shifter << 1), bit.eq(bit + 1)]

            with m.State("WAIT"):
                with m.If(timer != 0):
                    m.d.sync += timer.eq(timer - 1)
                with m.Elif(restart):
                    power_up()
                with m.Elif(ending == _Ending.DONE):
                    m.d.sync += done.eq(1)
                    m.next = "IDLE"
                with m.Elif(ending == _Ending.ERROR):
                    m.d.sync += error.eq(1)
                    m.next = "IDLE"
                with m.Else():
                    begin_write()

        m.d.comb += self.busy.eq(~fsm.ongoing("IDLE"))
        return m

    def _after_stop(self, m, t, entry, row, n_rows, retries, nacked, ending, timer):
        """Choose the pause and what follows it, in the cycle that sends STOP."""
        with m.If(nacked):
            m.d.sync += timer.eq(self.power.retry - 1)
            with m.If(retries == self.max_retries):
                m.d.sync += ending.eq(_Ending.ERROR)
            with m.Else():
                m.d.sync += retries.eq(retries + 1)       # same row again
        with m.Else():
            with m.Switch(entry.delay):
                for index, cycles in enumerate(self.delay_cycles):
                    with m.Case(index):
                        m.d.sync += timer.eq(max(t.buf, cycles) - 1)
            m.d.sync += retries.eq(0)
            with m.If(row == n_rows - 1):
                m.d.sync += ending.eq(_Ending.DONE)
            with m.Else():
                m.d.sync += row.eq(row + 1)

"""Timing of the OV5642 configuration master (thesis §5.1): the I2C bit timing,
the camera's power-up sequence and when each attempt of the first register
write reaches the bus.

This is the cycle-level specification of :class:`soc.ov5642_config.Ov5642Config`:
the hardware takes its cycle counts from :func:`i2c_timing` and
:func:`power_up_timing`, and the tests compare the edges of its ``pwdn``,
``reset_n`` and SDA outputs with :func:`first_row_schedule`, cycle for cycle.

Power-up: PWDN is held high, then released with RESETB still low; RESETB is
released after a further wait; the sensor answers on SCCB only some time after
that. :data:`OV5642_POWER_UP_MS` holds the minimums; the configuration master
waits at least these by default and spaces its retries of a refused write so
that a sensor slower than the datasheet still gets time.
"""
from __future__ import annotations

import math
from typing import NamedTuple

from .validation import check_int, check_number

__all__ = [
    "FAST_MODE", "SYNC_STAGES", "I2cTiming", "i2c_timing", "cycles",
    "OV5642_POWER_UP_MS", "POWER_UP_MS_RANGE", "RETRY_MS", "PowerUpTiming",
    "power_up_timing", "attempt_cycles", "FirstRowSchedule", "first_row_schedule",
]

#: Fast-mode minimum times in seconds (NXP UM10204 rev. 7, Table 10), plus the
#: 300 ns hold the master adds after SCL falls so SDA never moves inside the
#: falling edge's undefined region (same document, note 3 of Table 10).
FAST_MODE = {
    "t_low": 1.3e-6, "t_high": 0.6e-6, "t_hd_sta": 0.6e-6, "t_su_sta": 0.6e-6,
    "t_su_sto": 0.6e-6, "t_buf": 1.3e-6, "t_su_dat": 100e-9, "t_hd_dat": 300e-9,
}
#: Two flip-flops re-time the line levels (the pins are asynchronous).
SYNC_STAGES = 2

#: Power-up minimums in ms: ``pwdn``, supplies stable to PWDN low (5 ms);
#: ``reset``, PWDN low to RESETB high (1 ms); ``settle``, RESETB high to the
#: first SCCB access (20 ms). These are the OV5640 datasheet's (rev. 2.03,
#: section 2.7, figure 2-3: t0 + t1 + t2 >= 5 ms, t3 >= 1 ms, t4 >= 20 ms), the
#: strictest of the family; the OV5647 datasheet gives the same 20 ms ("20ms
#: after PWDN goes low or 20ms after RESETB goes high"). The OV5642 datasheet
#: (preliminary specification, 2009, section 2.6 "power up sequence") could not
#: be read here: check these against it. The board's XCLK runs before the first
#: access: it comes from the PLL whose lock releases the master's reset.
OV5642_POWER_UP_MS = {"pwdn": 5.0, "reset": 1.0, "settle": 20.0}
#: Range of every power-up and retry wait, ms (0: one clock cycle).
POWER_UP_MS_RANGE = (0.0, 1000.0)
#: Default wait between a refused attempt and the next (ms): with three retries
#: a sensor gets 4x the datasheet's settling time before the master gives up.
RETRY_MS = 20.0


def cycles(seconds: float, clk_freq: float) -> int:
    """Whole clock cycles covering ``seconds`` (at least 1)."""
    # the tolerance keeps 1.3 us * 50 MHz = 65.000000001 at 65 cycles
    return max(1, math.ceil(seconds * clk_freq - 1e-6))


class I2cTiming(NamedTuple):
    """Clock-cycle counts of the bit timing (see :func:`i2c_timing`)."""
    hold: int       #: SCL low -> SDA change (t_HD;DAT)
    setup: int      #: SDA change -> SCL released (t_SU;DAT); t_LOW = hold + setup
    high: int       #: SCL counted high (t_HIGH = high + SYNC_STAGES, more if stretched)
    hd_sta: int     #: START -> SCL low (t_HD;STA)
    buf: int        #: STOP -> next START (t_BUF)
    period: int     #: cycles per SCL period: hold + setup + high + SYNC_STAGES


def i2c_timing(clk_freq: float, scl_freq: float) -> I2cTiming:
    """Cycle counts that meet the fast-mode minimum times and give an SCL
    frequency of at most ``scl_freq`` (when SCL is not stretched).

    Each minimum is rounded up to whole cycles; the cycles left over in a
    period of ``ceil(clk_freq / scl_freq)`` go half to the low and half to the
    high phase. Raises ``ValueError`` if the minimums do not fit in a period.
    """
    fm = FAST_MODE
    period = math.ceil(clk_freq / scl_freq - 1e-6)
    hold = cycles(fm["t_hd_dat"], clk_freq)
    low = max(cycles(fm["t_low"], clk_freq), hold + cycles(fm["t_su_dat"], clk_freq))
    # the high count alone meets t_HIGH; the synchroniser cycles are margin
    high = cycles(max(fm["t_high"], fm["t_su_sto"]), clk_freq)
    need = low + high + SYNC_STAGES
    if need > period:
        raise ValueError(
            f"clk_freq={clk_freq:g} Hz is too low for scl_freq={scl_freq:g} Hz: an SCL period "
            f"is {period} cycles but the fast-mode minimums (t_LOW 1.3 us, t_HIGH 0.6 us) and "
            f"{SYNC_STAGES} synchroniser cycles need {need}; raise clk_freq or lower scl_freq")
    spare = period - need
    low += spare // 2
    high += spare - spare // 2
    hd_sta = max(high, cycles(fm["t_hd_sta"], clk_freq))
    buf = max(low, cycles(fm["t_buf"], clk_freq))
    return I2cTiming(hold=hold, setup=low - hold, high=high, hd_sta=hd_sta, buf=buf,
                     period=low + high + SYNC_STAGES)


class PowerUpTiming(NamedTuple):
    """Clock-cycle counts of the power-up sequence (see :func:`power_up_timing`)."""
    pwdn: int       #: PWDN high (RESETB low) after reset or ``start``
    reset: int      #: PWDN low, RESETB still low
    settle: int     #: RESETB high to the first START
    retry: int      #: STOP of a refused attempt to the next START (at least t_BUF)


def power_up_timing(clk_freq: float, *, pwdn_ms: float = OV5642_POWER_UP_MS["pwdn"],
                    reset_ms: float = OV5642_POWER_UP_MS["reset"],
                    settle_ms: float = OV5642_POWER_UP_MS["settle"],
                    retry_ms: float = RETRY_MS, buf: int = 1) -> PowerUpTiming:
    """The power-up waits and the retry spacing in cycles of ``clk_freq``.

    Parameters
    ----------
    clk_freq : float
        Clock of the configuration master, Hz.
    pwdn_ms, reset_ms, settle_ms, retry_ms : float in [0, 1000]
        The waits of :class:`PowerUpTiming` in ms, each rounded up to whole
        cycles (at least one).
    buf : int
        t_BUF in cycles, the shortest retry spacing.
    """
    waits = {}
    for name, ms in (("pwdn_ms", pwdn_ms), ("reset_ms", reset_ms), ("settle_ms", settle_ms),
                     ("retry_ms", retry_ms)):
        waits[name] = cycles(check_number(name, ms, *POWER_UP_MS_RANGE, unit="ms") / 1000,
                             clk_freq)
    return PowerUpTiming(pwdn=waits["pwdn_ms"], reset=waits["reset_ms"],
                         settle=waits["settle_ms"], retry=max(buf, waits["retry_ms"]))


def attempt_cycles(timing: I2cTiming, acked_bytes: int) -> int:
    """Cycles from an attempt's START to its STOP when the target ACKs
    ``acked_bytes`` bytes (0: not even its address) and refuses the next one:
    t_HD;STA, a period per bit and ACK slot, and the period of the STOP's
    clock (SCL seen high :data:`SYNC_STAGES` cycles after its release)."""
    acked_bytes = check_int("acked_bytes", acked_bytes, 0, 3)
    return timing.hd_sta + (9 * (acked_bytes + 1) + 1) * timing.period


class FirstRowSchedule(NamedTuple):
    """Edges of the master's outputs from reset (or a ``start`` edge) to the
    end of the first register write, in cycles counted from that moment."""
    pwdn_fall: int          #: first cycle PWDN is low
    reset_rise: int         #: first cycle RESETB is high
    starts: tuple           #: first cycle of each START condition of row 0
    accepted: int | None    #: index in ``starts`` of the ACKed attempt; None: refused
    error_at: int | None    #: first cycle ``error`` is high (every attempt refused)


def first_row_schedule(timing: I2cTiming, power: PowerUpTiming, *, max_retries: int,
                       ready: int) -> FirstRowSchedule:
    """When the master powers the camera up and tries the first write.

    Parameters
    ----------
    timing, power : I2cTiming, PowerUpTiming
        The master's cycle counts.
    max_retries : int in [0, 255]
        Extra attempts of a refused row.
    ready : int
        First cycle at which the sensor ACKs its address; an attempt that
        STARTs earlier is refused at the address byte.

    Returns
    -------
    FirstRowSchedule
        PWDN falls ``power.pwdn`` cycles after the start, RESETB rises
        ``power.reset`` later, the first START comes ``power.settle`` after
        that; a refused attempt ends with STOP after :func:`attempt_cycles`
        ``(timing, 0)`` and the next STARTs ``power.retry`` cycles later.
        After ``1 + max_retries`` refusals ``error`` rises ``power.retry``
        cycles after the last STOP.
    """
    max_retries = check_int("max_retries", max_retries, 0, 255)
    pwdn_fall = power.pwdn
    reset_rise = pwdn_fall + power.reset
    start = reset_rise + power.settle
    refused = attempt_cycles(timing, 0) + power.retry
    starts = []
    for attempt in range(1 + max_retries):
        starts.append(start)
        if start >= ready:
            return FirstRowSchedule(pwdn_fall, reset_rise, tuple(starts), attempt, None)
        start += refused
    return FirstRowSchedule(pwdn_fall, reset_rise, tuple(starts), None, start)

"""sim/model/ov5642_config.py: the configuration master's cycle counts (I2C bit
timing, power-up waits) and the schedule of the power-up and of row 0's
attempts. The hardware against this model: tests/test_soc_ov5642_config.py."""
from __future__ import annotations

import pytest

from sim.model.ov5642_config import (OV5642_POWER_UP_MS, attempt_cycles, first_row_schedule,
                                     i2c_timing, power_up_timing)


def test_timing_counts_meet_fast_mode():
    for clk in (4.001e6, 10e6, 27e6, 50e6, 100e6):
        for scl in (100e3, 400e3):
            t = i2c_timing(clk, scl)
            cyc = 1 / clk
            assert t.period >= clk / scl - 1e-6
            assert (t.hold + t.setup) * cyc >= 1.3e-6 - 1e-12
            assert t.high * cyc >= 0.6e-6 - 1e-12 and t.hd_sta * cyc >= 0.6e-6 - 1e-12
            assert t.buf * cyc >= 1.3e-6 - 1e-12 and t.setup * cyc >= 100e-9 - 1e-12
    t = i2c_timing(50e6, 400e3)
    assert (t.hold, t.setup, t.high, t.hd_sta, t.buf, t.period) == (15, 64, 44, 44, 79, 125)



def test_power_up_waits_round_up_to_whole_cycles():
    p = power_up_timing(50e6)
    assert (p.pwdn, p.reset, p.settle, p.retry) == (250_000, 50_000, 1_000_000, 1_000_000)
    assert p.pwdn / 50e6 * 1e3 == OV5642_POWER_UP_MS["pwdn"] == 5.0
    odd = power_up_timing(3e6, pwdn_ms=0.0011, reset_ms=0, settle_ms=0.001, retry_ms=0, buf=7)
    # 3.3 cycles -> 4; 0 ms -> one cycle; 3 cycles exactly; the retry never under t_BUF
    assert (odd.pwdn, odd.reset, odd.settle, odd.retry) == (4, 1, 3, 7)


@pytest.mark.parametrize("kwargs, match", [
    ({"pwdn_ms": -0.1}, r"pwdn_ms must be a number in \[0, 1000\] ms, got -0.1"),
    ({"settle_ms": 1000.5}, r"settle_ms must be a number in \[0, 1000\] ms"),
    ({"retry_ms": True}, r"retry_ms must be a number"),
    ({"reset_ms": None}, r"reset_ms must be a number"),
])
def test_power_up_timing_names_a_bad_wait(kwargs, match):
    with pytest.raises(ValueError, match=match):
        power_up_timing(50e6, **kwargs)


def test_attempt_cycles():
    t = i2c_timing(50e6, 400e3)
    # refused at the address: START hold, 9 bit slots, the STOP's clock
    assert attempt_cycles(t, 0) == 44 + 10 * 125
    # a whole row (three bytes ACKed after the address): 37 slots
    assert attempt_cycles(t, 3) == 44 + 37 * 125
    with pytest.raises(ValueError, match="acked_bytes must be in \\[0, 3\\]"):
        attempt_cycles(t, 4)


def test_first_row_schedule():
    t = i2c_timing(5e6, 400e3)
    p = power_up_timing(5e6, pwdn_ms=0.01, reset_ms=0.02, settle_ms=0.03, retry_ms=0.04,
                        buf=t.buf)
    first = p.pwdn + p.reset + p.settle
    step = attempt_cycles(t, 0) + p.retry
    now = first_row_schedule(t, p, max_retries=3, ready=0)
    assert (now.pwdn_fall, now.reset_rise) == (p.pwdn, p.pwdn + p.reset)
    assert now.starts == (first,) and now.accepted == 0 and now.error_at is None
    # ready one cycle after an attempt's START: that attempt is refused
    later = first_row_schedule(t, p, max_retries=3, ready=first + step + 1)
    assert later.starts == (first, first + step, first + 2 * step) and later.accepted == 2
    never = first_row_schedule(t, p, max_retries=3, ready=1 << 62)
    assert never.starts == tuple(first + k * step for k in range(4))
    assert never.accepted is None and never.error_at == first + 4 * step
    assert first_row_schedule(t, p, max_retries=0, ready=1 << 62).error_at == first + step
    with pytest.raises(ValueError, match="max_retries must be in \\[0, 255\\]"):
        first_row_schedule(t, p, max_retries=256, ready=0)

# amaranth: UnusedElaboratable=no
"""hdl/delay_line.py: BeatDelay, bit for bit against its input ``beats`` beats, then
``cycles`` clock cycles, later."""
import numpy as np
import pytest
from amaranth.hdl import Elaboratable, Module, Signal

from hdl.delay_line import MEMORY_MIN_BEATS, BeatDelay
from verif.streams import field, gap_pattern, pack, run_stream


class _Clocked(Elaboratable):
    """A component plus a register, so the simulator has a clock domain even
    when the component is a plain wire (no delay)."""

    def __init__(self, dut):
        self.dut, self.i_stream, self.o_stream = dut, dut.i_stream, dut.o_stream

    def elaborate(self, platform):
        m = Module()
        m.submodules.dut = self.dut
        toggle = Signal()
        m.d.sync += toggle.eq(~toggle)
        return m


@pytest.mark.parametrize("bits, beats, cycles", [
    (1, 0, 0), (8, 0, 3), (5, 1, 0), (3, 7, 2), (4, MEMORY_MIN_BEATS - 1, 1),
    (1, MEMORY_MIN_BEATS, 2), (20, 45, 3), (9, 70, 4)])
def test_beat_delay(bits, beats, cycles):
    n = 3 * beats + 40
    rng = np.random.default_rng(beats * 10 + cycles)
    values = [int(v) for v in rng.integers(0, 1 << bits, n)]
    dut = BeatDelay(bits, beats, cycles)
    assert dut.uses_memory == (beats >= MEMORY_MIN_BEATS)
    assert dut.memory_bits == beats * bits * dut.uses_memory
    out_cycles = []
    out = run_stream(_Clocked(dut),
                     [pack(dut.i_stream.payload.shape(), {"data": v}) for v in values],
                     idle=0.4, seed=beats, out_cycles=out_cycles)
    expect = [0] * beats + values[:n - beats]
    assert list(field(dut.o_stream.payload.shape(), out, "data")) == expect
    # Output of beat t comes exactly `cycles` clock cycles after beat t.
    idle = gap_pattern(4 * n + 16, 0.4, beats)
    in_cycles = np.flatnonzero(~idle)[:n]
    assert list(np.array(out_cycles) - in_cycles) == [cycles] * n


@pytest.mark.parametrize("make, name", [
    (lambda: BeatDelay(0, 4), r"bits must be in \[1, 1024\]"),
    (lambda: BeatDelay(8, -1), r"beats must be in \[0, 65536\]"),
    (lambda: BeatDelay(8, MEMORY_MIN_BEATS, 1),
     r"cycles must be at least 2 for beats >= 32 \(the memory's read and its register\)"),
    (lambda: BeatDelay(8, 4, -2), r"cycles must be in \[0, 4096\]"),
])
def test_bad_parameters_name_the_parameter(make, name):
    with pytest.raises(ValueError, match=name):
        make()

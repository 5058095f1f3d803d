"""Beat delay line: a value delayed by a number of beats, then by free-running
clock cycles (the skin delay line of the hand segmentation, thesis §6.3, Fig. 58).

Two streams that advance on the same beats but reach a stage a fixed number of
clock cycles apart (the chroma of the left camera and the disparity of the same
pixels, which spent the stereo matcher's pipeline in between) are aligned by
delaying the early one ``beats`` beats (the look-ahead of the late stream's
windows) and then ``cycles`` clock cycles (its pipeline registers).

Short lines are beat-gated shift registers. Long ones (``beats`` >=
:data:`MEMORY_MIN_BEATS`) are a :class:`~hdl.row_buffer.RowBuffer` of ``beats``
words, whose word is ``beats`` beats old :attr:`RowBuffer.cycles` clock cycles
after the beat: those cycles are taken from ``cycles``, which must be at least
that long.
"""
from __future__ import annotations

from amaranth.hdl import Module, Signal
from amaranth.lib import data, stream, wiring
from amaranth.lib.wiring import In, Out

from ._util import PIXEL_BITS_RANGE, check_int, delay
from .row_buffer import RowBuffer

__all__ = ["BeatDelay", "MEMORY_MIN_BEATS", "delay_memory_bits"]

#: From this many beats on, the line is a memory instead of registers.
MEMORY_MIN_BEATS = 32
BITS_RANGE = (1, 1024)
BEATS_RANGE = (0, 65536)  # RowBuffer lengths up to 65536
CYCLES_RANGE = (0, 4096)


def _lanes(bits: int) -> tuple[int, int]:
    """Lanes of the memory and bits per lane: RowBuffer lanes hold at most 16
    bits, so wide values are split."""
    lanes = -(-bits // PIXEL_BITS_RANGE[1])
    return lanes, -(-bits // lanes)


def delay_memory_bits(bits: int, beats: int) -> int:
    """Bits of the memory of a :class:`BeatDelay` (0 when it is registers)."""
    if beats < MEMORY_MIN_BEATS:
        return 0
    lanes, lane_bits = _lanes(bits)
    return beats * lanes * lane_bits


class BeatDelay(wiring.Component):
    """``data`` delayed by ``beats`` beats followed by ``cycles`` clock cycles.

    Parameters
    ----------
    bits : int in [1, 1024]
        Width of the value.
    beats : int in [0, 65536]
        Beats of delay (0: none). Registers below :data:`MEMORY_MIN_BEATS`
        (32) beats, a memory of ``beats`` words from there on.
    cycles : int in [0, 4096]
        Free-running clock cycles after the beat delay; with a memory at least
        :attr:`RowBuffer.cycles <hdl.row_buffer.RowBuffer.cycles>` (2), the
        memory's read and its register.

    Ports
    -----
    i_stream : payload ``{data}``, a beat per ``valid`` cycle (idle cycles anywhere).
    o_stream : payload ``{data}``; ``valid`` is ``i_stream.valid`` ``cycles``
        clock cycles later, and the output in the cycle of beat t plus
        ``cycles`` is the input of beat t - ``beats`` (0 for t < ``beats``:
        reset content). With ``beats`` = ``cycles`` = 0 the output is the input.

    Attributes
    ----------
    lag : int, = ``beats``
    cycles : int
    uses_memory : bool
    memory_bits : int, bits of the memory (0 for registers)
    """

    def __init__(self, bits: int, beats: int, cycles: int = 0):
        self.bits = check_int("bits", bits, *BITS_RANGE)
        self.beats = check_int("beats", beats, *BEATS_RANGE)
        self.cycles = check_int("cycles", cycles, *CYCLES_RANGE)
        self.lag = self.beats
        self.uses_memory = self.beats >= MEMORY_MIN_BEATS
        if self.uses_memory and self.cycles < RowBuffer.cycles:
            raise ValueError(f"cycles must be at least {RowBuffer.cycles} for beats >= "
                             f"{MEMORY_MIN_BEATS} (the memory's read and its register), "
                             f"got {self.cycles}")
        self.memory_bits = delay_memory_bits(bits=self.bits, beats=self.beats)
        layout = data.StructLayout({"data": self.bits})
        super().__init__({
            "i_stream": In(stream.Signature(layout, always_ready=True)),
            "o_stream": Out(stream.Signature(layout, always_ready=True)),
        })

    def elaborate(self, platform):
        m = Module()
        beat = self.i_stream.valid
        value = self.i_stream.payload.data
        cycles = self.cycles
        if self.uses_memory:
            lanes, lb = _lanes(self.bits)
            m.submodules.line = buf = RowBuffer(length=self.beats, lanes=lanes, pixel_bits=lb)
            # RowBuffer samples its input when its output is valid
            held = delay(m, value, RowBuffer.cycles, "wdata")
            m.d.comb += buf.beat.eq(beat)
            for lane in range(lanes):
                m.d.comb += buf.i_data[lane].eq(held[lane * lb:(lane + 1) * lb])
            beat_delayed = buf.o_data.as_value()[:self.bits]
            cycles -= RowBuffer.cycles
        else:
            beat_delayed = value
            for k in range(self.beats):
                reg = Signal(self.bits, name=f"line_{k}")
                with m.If(beat):
                    m.d.sync += reg.eq(beat_delayed)
                beat_delayed = reg
        m.d.comb += [
            self.o_stream.payload.data.eq(delay(m, beat_delayed, cycles, "pipe")),
            self.o_stream.valid.eq(delay(m, beat, self.cycles, "valid")),
        ]
        return m
